#include "gpatlas_core/model/gp_numerics.h"

#include "gpatlas_core/common/bounded_parameter.h"
#include "gpatlas_core/common/dense_solve.h"

#include <ceres/ceres.h>

#include <cmath>
#include <limits>
#include <memory>

namespace gpatlas_core {

namespace {
constexpr double kLog2Pi = 1.8378770664093453;
}  // namespace

std::vector<double> jitterLadder(const CholeskyConfig& config, double prior_variance) {
  std::vector<double> ladder{config.jitter_first_relative * prior_variance};
  const double top = config.jitter_max_relative * 1.0001;
  // A rung of 0 would never climb (a step of 0, or of a first rung of 0): the ladder ends there.
  for (double j = std::max(config.jitter_first_relative * 10.0, config.jitter_step_relative); j > 0.0 && j <= top;
       j *= 10.0)
    ladder.push_back(j * prior_variance);
  return ladder;
}

bool choleskyWellConditioned(Eigen::Ref<Eigen::MatrixXd> block, double prior_variance, const CholeskyConfig& config) {
  if (!choleskyLowerInPlace(block)) return false;
  const double floor = config.min_pivot_squared_relative * prior_variance;
  return (block.diagonal().array().square() > floor).all();
}

double factoriseWithJitter(Eigen::Ref<Eigen::MatrixXd> block, double prior_variance, const CholeskyConfig& config) {
  const Eigen::Index n = block.rows();
  // K's strict lower triangle is kept in the strict upper one (which the factorisation leaves as
  // it is), its diagonal aside: each step of the ladder starts from K again without rebuilding it.
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index i = j + 1; i < n; ++i) block(j, i) = block(i, j);
  const Eigen::VectorXd diagonal = block.diagonal();
  bool first = true;
  for (double jitter : jitterLadder(config, prior_variance)) {
    if (!first)
      for (Eigen::Index j = 0; j < n; ++j)
        for (Eigen::Index i = j + 1; i < n; ++i) block(i, j) = block(j, i);
    first = false;
    block.diagonal() = diagonal.array() + jitter;
    if (n == 0 || choleskyWellConditioned(block, prior_variance, config)) return jitter;
  }
  return -1.0;
}

Eigen::VectorXd solveWithFactor(const Eigen::Ref<const Eigen::MatrixXd>& factor, const Eigen::VectorXd& y) {
  Eigen::VectorXd x = y;
  const auto lower = factor.triangularView<Eigen::Lower>();
  lower.solveInPlace(x);
  lower.transpose().solveInPlace(x);
  return x;
}

double logMarginalLikelihood(const Eigen::Ref<const Eigen::MatrixXd>& factor, const Eigen::VectorXd& y,
                             const Eigen::VectorXd& alpha) {
  const double log_det = 2.0 * factor.diagonal().array().log().sum();
  return -0.5 * y.dot(alpha) - 0.5 * log_det - 0.5 * static_cast<double>(y.size()) * kLog2Pi;
}

Eigen::MatrixXd likelihoodGradientWeight(const Eigen::Ref<const Eigen::MatrixXd>& factor, const Eigen::VectorXd& alpha) {
  const Eigen::Index n = factor.rows();
  Eigen::MatrixXd inverse = Eigen::MatrixXd::Identity(n, n);
  const auto lower = factor.triangularView<Eigen::Lower>();
  lower.solveInPlace(inverse);
  lower.transpose().solveInPlace(inverse);
  Eigen::MatrixXd weight = -inverse;
  weight.noalias() += alpha * alpha.transpose();
  return weight;
}

namespace {

// -f in the unbounded variables z, theta = box(z), for Ceres (which minimises).
class BoundedCost : public ceres::FirstOrderFunction {
 public:
  BoundedCost(const BoundedObjective& f, std::vector<BoundedParameter> boxes) : f_(f), boxes_(std::move(boxes)) {}
  int NumParameters() const override { return static_cast<int>(boxes_.size()); }
  bool Evaluate(const double* z, double* cost, double* gradient) const override {
    const Eigen::Index k = static_cast<Eigen::Index>(boxes_.size());
    Eigen::VectorXd theta(k), grad(k);
    for (Eigen::Index i = 0; i < k; ++i) theta[i] = boxes_[static_cast<std::size_t>(i)].fromUnbounded(z[i]);
    const double value = f_(theta, gradient ? &grad : nullptr);
    if (!std::isfinite(value)) return false;
    *cost = -value;
    if (gradient)
      for (Eigen::Index i = 0; i < k; ++i) gradient[i] = -grad[i] * boxes_[static_cast<std::size_t>(i)].derivative(z[i]);
    return true;
  }

 private:
  const BoundedObjective& f_;
  std::vector<BoundedParameter> boxes_;
};

}  // namespace

BoundedMaximum maximiseBounded(const BoundedObjective& f, const Eigen::VectorXd& x0, const Eigen::VectorXd& lower,
                               const Eigen::VectorXd& upper, int max_iterations) {
  const Eigen::Index k = x0.size();
  std::vector<BoundedParameter> boxes;
  std::vector<double> z(static_cast<std::size_t>(k));
  for (Eigen::Index i = 0; i < k; ++i) {
    boxes.push_back(BoundedParameter{lower[i], upper[i]});
    z[static_cast<std::size_t>(i)] = boxes.back().toUnbounded(x0[i]);
  }
  ceres::GradientProblem problem(new BoundedCost(f, boxes));
  ceres::GradientProblemSolver::Options options;
  options.line_search_direction_type = ceres::LBFGS;
  options.max_num_iterations = std::max(1, max_iterations);
  options.function_tolerance = 1e-6;
  options.logging_type = ceres::SILENT;
  ceres::GradientProblemSolver::Summary summary;
  ceres::Solve(options, problem, z.data(), &summary);
  BoundedMaximum result;
  result.x.resize(k);
  for (Eigen::Index i = 0; i < k; ++i)
    result.x[i] = boxes[static_cast<std::size_t>(i)].fromUnbounded(z[static_cast<std::size_t>(i)]);
  result.usable = summary.IsSolutionUsable();
  result.value = result.usable ? f(result.x, nullptr) : std::numeric_limits<double>::quiet_NaN();
  result.iterations = static_cast<int>(summary.iterations.size());
  result.message = summary.message;
  return result;
}

}  // namespace gpatlas_core
