#include "gpatlas_core/approach_config.h"

#include <cmath>
#include <sstream>

namespace gpatlas_core {

std::string validate(const ApproachConfig& c) {
  std::ostringstream problem;
  const auto positive = [&](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) problem << name << " must be positive and finite; ";
  };
  if (!(c.occupied_probability > 0.0 && c.occupied_probability < 1.0)) problem << "occupied_probability must be in (0, 1); ";
  positive(c.approach_distance_m, "approach_distance_m");
  positive(c.max_planning_time_s, "max_planning_time_s");
  positive(c.check_resolution_m, "check_resolution_m");
  positive(c.probe.tip_radius_m, "tip_radius_m");
  positive(c.probe.shaft_radius_m, "shaft_radius_m");
  positive(c.probe.shaft_length_m, "shaft_length_m");
  positive(c.arm_link_radius_m, "arm_link_radius_m");
  positive(c.arm_check_step_rad, "arm_check_step_rad");
  positive(c.arm_joint_speed_rad_s, "arm_joint_speed_rad_s");
  if (c.arm_reachability_ik_restarts < 1) problem << "arm_reachability_ik_restarts must be >= 1; ";
  if (c.use_arm && (c.arm_base_link.empty() || c.arm_tip_link.empty()))
    problem << "use_arm needs arm_base_link and arm_tip_link; ";
  if (!c.rest_tip_position_m.allFinite()) problem << "rest_tip_position_m must be finite; ";
  if (!(c.clearance_m >= 0.0) || !(c.contact_zone_m >= 0.0) || !(c.workspace_margin_m >= 0.0))
    problem << "clearance_m, contact_zone_m and workspace_margin_m must be >= 0; ";
  return problem.str();
}

}  // namespace gpatlas_core
