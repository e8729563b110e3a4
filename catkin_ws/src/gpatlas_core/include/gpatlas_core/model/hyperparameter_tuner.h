#pragma once

#include "gpatlas_core/model/gpis_model.h"

#include <Eigen/Core>

#include <string>
#include <utility>
#include <vector>

namespace gpatlas_core {

struct HyperparameterTunerConfig {
  int max_iterations{40};
  double function_tolerance{1e-7};
  // Tuning the noise scale on a single partial view drives it to its lower bound (the data
  // are nearly noise-free samples of f = 0), which shrinks every variance near the data and
  // makes V_max meaningless; by default only the kernel's parameters are tuned.
  bool tune_noise{false};
  double min_noise_scale{1e-2};
  double max_noise_scale{1e2};
  // Per kernel parameter, natural units; empty selects defaults for the kernel: thin-plate
  // R in [2 * domain_radius, 20]; wendland R and sigma in [0.05, 20]; length in [0.02, 5].
  std::vector<std::pair<double, double>> param_bounds;
};

// Maximises the GP's log marginal likelihood over the kernel's log-parameters and the log
// noise scale with Ceres' line-search solver and analytic gradients. Bounds are enforced by
// a smooth change of variables (theta = lo + (hi - lo) * sigmoid(z)), so the unconstrained
// GradientProblem never leaves the box.
class HyperparameterTuner {
 public:
  using Config = HyperparameterTunerConfig;


  explicit HyperparameterTuner(Config config = Config()) : config_(std::move(config)) {}

  // Tunes and refits the model. On failure (no fitted model, a solver failure, or no
  // improvement) the model keeps its previous hyperparameters and the report says why.
  TuneReport tune(GpisModel& model) const;

 private:
  Config config_;
};

}  // namespace gpatlas_core
