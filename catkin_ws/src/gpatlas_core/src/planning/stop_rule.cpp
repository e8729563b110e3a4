#include "gpatlas_core/planning/stop_rule.h"

#include "gpatlas_core/model/position_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace gpatlas_core {

bool StopRule::exceeded(const SurfaceModel& model, double reported_variance, double gradient_norm) const {
  if (reported_variance > v_max) return true;
  return max_position_sd_m && positionSd(model, reported_variance, gradient_norm) > *max_position_sd_m;
}

double StopRule::excess(const SurfaceModel& model, double reported_variance, double gradient_norm) const {
  const double by_variance = reported_variance / v_max;
  if (!max_position_sd_m) return by_variance;
  return std::max(by_variance, positionSd(model, reported_variance, gradient_norm) / *max_position_sd_m);
}

std::string StopRule::describe() const {
  std::ostringstream text;
  text << "variance above V_max " << v_max;
  if (max_position_sd_m) text << " or position sd above " << *max_position_sd_m * 1000.0 << " mm";
  return text.str();
}

std::string validate(const StopRule& rule) {
  if (!(rule.v_max > 0.0) || !std::isfinite(rule.v_max)) return "V_max must be a positive finite number";
  if (rule.max_position_sd_m && (!(*rule.max_position_sd_m > 0.0) || !std::isfinite(*rule.max_position_sd_m)))
    return "max_position_sd_m must be > 0 and finite, or empty (the V_max rule alone)";
  return "";
}

}  // namespace gpatlas_core
