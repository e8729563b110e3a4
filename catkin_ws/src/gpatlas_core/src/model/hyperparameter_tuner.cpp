#include "gpatlas_core/model/hyperparameter_tuner.h"

#include "gpatlas_core/common/bounded_parameter.h"

#include <ceres/ceres.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

namespace gpatlas_core {

namespace {


class NegativeLogLikelihood : public ceres::FirstOrderFunction {
 public:
  NegativeLogLikelihood(const GpisModel& model, std::vector<BoundedParameter> boxes, bool tune_noise, double fixed_log_noise)
      : model_(model), boxes_(std::move(boxes)), tune_noise_(tune_noise), fixed_log_noise_(fixed_log_noise) {}

  int NumParameters() const override { return static_cast<int>(boxes_.size()); }

  bool Evaluate(const double* z, double* cost, double* gradient) const override {
    const int p = model_.kernel().numParams();
    Eigen::VectorXd kernel_params(p);
    for (int i = 0; i < p; ++i) kernel_params[i] = boxes_[static_cast<std::size_t>(i)].fromUnbounded(z[i]);
    const double log_noise = tune_noise_ ? boxes_[static_cast<std::size_t>(p)].fromUnbounded(z[p]) : fixed_log_noise_;
    Eigen::VectorXd grad;
    const double lml = model_.logMarginalLikelihood(kernel_params, log_noise, gradient ? &grad : nullptr);
    if (!std::isfinite(lml)) return false;
    *cost = -lml;
    if (gradient) {
      for (int i = 0; i < NumParameters(); ++i) {
        gradient[i] = -grad[i] * boxes_[static_cast<std::size_t>(i)].derivative(z[i]);
      }
    }
    return true;
  }

 private:
  const GpisModel& model_;
  std::vector<BoundedParameter> boxes_;
  bool tune_noise_;
  double fixed_log_noise_;
};

}  // namespace

TuneReport HyperparameterTuner::tune(GpisModel& model) const {
  TuneReport report;
  const auto start = std::chrono::steady_clock::now();
  if (!model.isFitted()) {
    report.message = "no fitted model to tune";
    return report;
  }
  for (const TrainingPoint& point : model.observations())
    if (observesSlope(point)) {
      report.message = "tuning a model with slope (normal) observations is not supported; hyperparameters unchanged";
      return report;
    }
  const Kernel& kernel = model.kernel();
  const int p = kernel.numParams();
  const Eigen::VectorXd log_before = kernel.logParams();
  report.params_before = log_before.array().exp();
  report.noise_scale_before = model.noiseScale();
  report.log_likelihood_before = model.logMarginalLikelihood();

  std::vector<BoundedParameter> boxes;
  if (!config_.param_bounds.empty()) {
    if (static_cast<int>(config_.param_bounds.size()) != p) {
      report.message = "param_bounds has " + std::to_string(config_.param_bounds.size()) + " entries, kernel '" +
                       kernel.name() + "' has " + std::to_string(p) + " parameters";
      return report;
    }
    for (const auto& b : config_.param_bounds) {
      if (!(b.first > 0.0 && b.second > b.first)) {
        report.message = "invalid parameter bounds (need 0 < lo < hi)";
        return report;
      }
      boxes.push_back({std::log(b.first), std::log(b.second)});
    }
  } else if (kernel.name() == "thin_plate") {
    boxes.push_back({std::log(2.0 * model.config().domain_radius * (1.0 + 1e-6)), std::log(20.0)});
  } else {
    const std::vector<std::string> names = kernel.paramNames();
    for (const auto& name : names) {
      if (name == "length") boxes.push_back({std::log(0.02), std::log(5.0)});
      else boxes.push_back({std::log(0.05), std::log(20.0)});
    }
  }
  if (config_.tune_noise) boxes.push_back({std::log(config_.min_noise_scale), std::log(config_.max_noise_scale)});

  std::vector<double> z(boxes.size());
  for (int i = 0; i < p; ++i) z[static_cast<std::size_t>(i)] = boxes[static_cast<std::size_t>(i)].toUnbounded(log_before[i]);
  const double log_noise_before = std::log(model.noiseScale());
  if (config_.tune_noise) z[static_cast<std::size_t>(p)] = boxes.back().toUnbounded(log_noise_before);

  ceres::GradientProblem problem(
      new NegativeLogLikelihood(model, boxes, config_.tune_noise, log_noise_before));
  ceres::GradientProblemSolver::Options options;
  options.line_search_direction_type = ceres::LBFGS;
  options.max_num_iterations = config_.max_iterations;
  options.function_tolerance = config_.function_tolerance;
  options.logging_type = ceres::SILENT;
  ceres::GradientProblemSolver::Summary summary;
  ceres::Solve(options, problem, z.data(), &summary);
  report.iterations = static_cast<int>(summary.iterations.size());

  auto finish = [&](bool ok, const std::string& message) {
    report.ok = ok;
    report.message = message;
    report.params_after = model.kernel().logParams().array().exp();
    report.noise_scale_after = model.noiseScale();
    report.log_likelihood_after = model.logMarginalLikelihood();
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
  };

  if (!summary.IsSolutionUsable()) return finish(false, "Ceres found no usable solution: " + summary.message);

  Eigen::VectorXd log_after(p);
  for (int i = 0; i < p; ++i) log_after[i] = boxes[static_cast<std::size_t>(i)].fromUnbounded(z[static_cast<std::size_t>(i)]);
  const double noise_after = config_.tune_noise ? std::exp(boxes.back().fromUnbounded(z[static_cast<std::size_t>(p)]))
                                                : model.noiseScale();
  if (!(-summary.final_cost >= report.log_likelihood_before - 1e-9))
    return finish(false, "tuning did not improve the likelihood; previous hyperparameters kept");

  const FitReport refit = model.setHyperparameters(log_after, noise_after);
  if (!refit.ok) return finish(false, "refit with tuned hyperparameters failed (" + refit.message + "); previous kept");
  std::ostringstream msg;
  msg << "log likelihood " << report.log_likelihood_before << " -> " << model.logMarginalLikelihood() << " in "
      << report.iterations << " iterations (" << summary.message << ")";
  return finish(true, msg.str());
}

// Defined here, not in gpis_model.cpp, so that the model does not depend on its tuner.
TuneReport GpisModel::tune(const HyperparameterTunerConfig& config) { return HyperparameterTuner(config).tune(*this); }

}  // namespace gpatlas_core
