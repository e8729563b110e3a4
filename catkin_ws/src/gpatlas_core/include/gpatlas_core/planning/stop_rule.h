#pragma once

// When does a predicted surface point need a touch? The paper's variance test, and the same in
// metres: the position sd of model/position_uncertainty.h against a bound.

#include "gpatlas_core/model/surface_model.h"

#include <optional>
#include <string>

namespace gpatlas_core {

// Algorithm 1's test of one predicted surface point, and so the loop's stop rule: the paper's
// variance above V_max or, with a max_position_sd_m, the position sd above that bound.
struct StopRule {
  double v_max{0.1};                            // reported variance units
  std::optional<double> max_position_sd_m;      // the position sd test as well; empty: V_max alone

  bool exceeded(const SurfaceModel& model, double reported_variance, double gradient_norm) const;
  // How far past the rule a point is: the larger of variance / V_max and position sd / its bound
  // (the latter only with a bound); exceeded() is excess > 1. Ranks points under either rule
  // alike, and under V_max alone in the order of the variance.
  double excess(const SurfaceModel& model, double reported_variance, double gradient_norm) const;
  // "variance above V_max" or "position sd above 5 mm", for messages.
  std::string describe() const;
};

std::string validate(const StopRule& rule);

}  // namespace gpatlas_core
