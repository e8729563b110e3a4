#pragma once

#include <Eigen/Core>

#include <functional>
#include <string>
#include <vector>

namespace gpatlas_core {

// The numerics every GP of the models shares (the global GPIS and the multiscale model's local
// cells): one jitter policy for the Cholesky factor, one log marginal likelihood and its gradient,
// one bounded maximiser of it.

// Settings of the Cholesky factorisation. Jitter is a fraction of the kernel's prior variance
// k(0), so that it means the same for every kernel and scale (the GPIS reports its noise relative
// to the prior as well): no jitter first, then first_step, x10 up to max, until the factor
// exists and is well conditioned.
struct CholeskyConfig {
  double jitter_first_relative{0.0};
  double jitter_step_relative{1e-12};
  double jitter_max_relative{1e-4};
  // A pivot^2 below this fraction of k(0) is rounding noise: LLT may "succeed" on a numerically
  // rank-deficient matrix, but its solutions would be garbage.
  double min_pivot_squared_relative{1e-13};
};

// The diagonal jitters the ladder tries, in order (absolute, for this prior variance).
std::vector<double> jitterLadder(const CholeskyConfig& config, double prior_variance);

// Overwrites the lower triangle of `block` with its Cholesky factor; false when the matrix is not
// positive definite or a pivot is rounding noise (see CholeskyConfig).
bool choleskyWellConditioned(Eigen::Ref<Eigen::MatrixXd> block, double prior_variance, const CholeskyConfig& config);

// Factorises K + jitter I for the lowest jitter of the ladder that works. `block` holds K's lower
// triangle (diagonal included, without jitter) on entry and its factor L on success; its strict
// upper triangle is used as scratch. Returns the jitter used, or a negative value when even the
// largest fails (the lower triangle is then garbage).
double factoriseWithJitter(Eigen::Ref<Eigen::MatrixXd> block, double prior_variance, const CholeskyConfig& config);

// K^-1 y from the lower factor L of K (L L^T = K).
Eigen::VectorXd solveWithFactor(const Eigen::Ref<const Eigen::MatrixXd>& factor, const Eigen::VectorXd& y);

// log N(y; 0, K) = -y^T K^-1 y / 2 - log|K| / 2 - n log(2 pi) / 2, from L and alpha = K^-1 y.
double logMarginalLikelihood(const Eigen::Ref<const Eigen::MatrixXd>& factor, const Eigen::VectorXd& y,
                             const Eigen::VectorXd& alpha);

// W = alpha alpha^T - K^-1, the weight of the likelihood's gradient:
// dL/dtheta = tr(W dK/dtheta) / 2.
Eigen::MatrixXd likelihoodGradientWeight(const Eigen::Ref<const Eigen::MatrixXd>& factor, const Eigen::VectorXd& alpha);

// The gradient of logMarginalLikelihood in num_params hyperparameters, given
// covariance_gradient(i, j, out) writing dK_ij/dtheta for every parameter (called for i >= j,
// the diagonal included: a parameter of the noise has its derivative there only).
template <class CovarianceGradient>
Eigen::VectorXd logMarginalLikelihoodGradient(const Eigen::Ref<const Eigen::MatrixXd>& factor,
                                              const Eigen::VectorXd& alpha, int num_params,
                                              const CovarianceGradient& covariance_gradient) {
  const Eigen::MatrixXd weight = likelihoodGradientWeight(factor, alpha);
  const Eigen::Index n = weight.rows();
  Eigen::VectorXd gradient = Eigen::VectorXd::Zero(num_params), d(num_params);
  for (Eigen::Index j = 0; j < n; ++j) {
    covariance_gradient(j, j, d.data());
    gradient += 0.5 * weight(j, j) * d;
    for (Eigen::Index i = j + 1; i < n; ++i) {
      covariance_gradient(i, j, d.data());
      gradient += weight(i, j) * d;  // twice, for (i, j) and (j, i), times 1/2
    }
  }
  return gradient;
}

// The outcome of maximiseBounded.
struct BoundedMaximum {
  Eigen::VectorXd x;       // the best point found, within the box
  double value{0.0};       // the objective there (NaN when the solver gave nothing usable)
  bool usable{false};      // Ceres' IsSolutionUsable
  int iterations{0};
  std::string message;     // Ceres' summary
};

// f(x, gradient) returns the objective and, when `gradient` is not null, writes its gradient
// there; a non-finite value marks x as infeasible.
using BoundedObjective = std::function<double(const Eigen::VectorXd& x, Eigen::VectorXd* gradient)>;

// Maximises f over the box [lower, upper] from x0 with Ceres' L-BFGS, the box kept by a sigmoid
// change of variables (BoundedParameter) so that the solver is unconstrained.
BoundedMaximum maximiseBounded(const BoundedObjective& f, const Eigen::VectorXd& x0, const Eigen::VectorXd& lower,
                               const Eigen::VectorXd& upper, int max_iterations);

}  // namespace gpatlas_core
