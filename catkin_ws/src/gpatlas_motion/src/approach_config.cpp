#include "gpatlas_motion/approach_config.h"

#include <Eigen/Geometry>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace gpatlas_motion {

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
  if (!(c.max_tilt_deg >= 0.0 && c.max_tilt_deg < 90.0)) problem << "max_tilt_deg must be in [0, 90); ";
  positive(c.tilt_step_deg, "tilt_step_deg");
  if (c.tilt_azimuths < 1) problem << "tilt_azimuths must be >= 1; ";
  if (c.arm_reachability_ik_restarts < 1) problem << "arm_reachability_ik_restarts must be >= 1; ";
  if (c.use_arm && (c.arm_base_link.empty() || c.arm_tip_link.empty()))
    problem << "use_arm needs arm_base_link and arm_tip_link; ";
  if (!c.rest_tip_position_m.allFinite()) problem << "rest_tip_position_m must be finite; ";
  if (!(c.clearance_m >= 0.0) || !(c.contact_zone_m >= 0.0) || !(c.workspace_margin_m >= 0.0))
    problem << "clearance_m, contact_zone_m and workspace_margin_m must be >= 0; ";
  return problem.str();
}

std::vector<Eigen::Vector3d> approachDirections(const Eigen::Vector3d& outward_normal, const Eigen::Vector3d& up,
                                                const ApproachConfig& config) {
  if (!outward_normal.allFinite() || !(outward_normal.norm() > 1e-12))
    throw std::invalid_argument("approachDirections needs a finite, non-zero normal");
  const Eigen::Vector3d n = outward_normal.normalized();
  std::vector<Eigen::Vector3d> directions{n};
  if (!(config.max_tilt_deg > 0.0) || !(config.tilt_step_deg > 0.0) || config.tilt_azimuths < 1) return directions;
  // The tangent toward up; any tangent when the normal is (anti)parallel to it.
  Eigen::Vector3d toward_up = up.allFinite() ? Eigen::Vector3d(up - up.dot(n) * n) : Eigen::Vector3d::Zero();
  if (toward_up.norm() < 1e-9) toward_up = n.unitOrthogonal();
  const Eigen::Vector3d e1 = toward_up.normalized();
  const Eigen::Vector3d e2 = n.cross(e1);
  const double step = 2.0 * M_PI / config.tilt_azimuths;
  const int rings = static_cast<int>(std::floor(config.max_tilt_deg / config.tilt_step_deg + 1e-9));
  for (int ring = 1; ring <= rings; ++ring) {
    const double tilt = ring * config.tilt_step_deg * M_PI / 180.0;
    for (int k = 0; k < config.tilt_azimuths; ++k) {
      // 0, +1, -1, +2, -2, ... steps from the direction toward up.
      const int side = (k + 1) / 2;
      const double azimuth = (k % 2 == 1 ? 1.0 : -1.0) * side * step;
      directions.push_back(std::cos(tilt) * n + std::sin(tilt) * (std::cos(azimuth) * e1 + std::sin(azimuth) * e2));
    }
  }
  return directions;
}

}  // namespace gpatlas_motion
