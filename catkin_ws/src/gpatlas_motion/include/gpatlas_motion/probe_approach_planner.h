#pragma once

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace octomap {
class OcTree;
}

namespace gpatlas_motion {

// The probe as the planner sees it: a spherical tip and a shaft behind it (a capsule: a cylinder
// with round ends), along the direction the probe points; the tip's centre is the probe's position.
struct ProbeGeometry {
  double tip_radius_m{0.01};    // Vito's 2 cm tip
  double shaft_radius_m{0.006};
  double shaft_length_m{0.15};
};

// Paper Algorithm 2's APPROACHTO and MOVEAWAY for the probe on its own (without the arm): a
// collision-free path of the probe's tip from where it is to an approach pose a safe distance
// out along the touch's normal, the probing segment from there to the touch, and the retreat.
// Obstacles are the collision map's voxels with P(occupied) above occupied_probability and the
// known static world (boxes: the table). Space outside the map counts as free: the map spans
// the model's domain, outside which the model itself predicts free space. While it travels the
// probe keeps pointing along the touch's approach direction (against the normal).
struct ApproachConfig {
  double occupied_probability{0.5};
  double approach_distance_m{0.1};   // the approach pose's distance from the touch along its normal
  double clearance_m{0.005};         // the probe is inflated by this in every check
  // The probing segment is checked up to this far from the touch: there the probe is meant to
  // meet the surface, whose voxels the map marks occupied.
  double contact_zone_m{0.02};
  double max_planning_time_s{0.2};
  double workspace_margin_m{0.2};    // the planner's box: start and approach pose, grown by this
  double check_resolution_m{0.002};  // motions are checked at least this finely
  unsigned seed{1};
};

struct ApproachPlan {
  bool ok{false};
  std::string message;  // why not, when !ok
  std::vector<Eigen::Vector3d> approach;  // tip positions: the start, ..., the approach pose
  std::vector<Eigen::Vector3d> probing;   // the approach pose and the touch
  std::vector<Eigen::Vector3d> retreat;   // the approach pose back to the start (the approach reversed)
  Eigen::Vector3d direction{Eigen::Vector3d::Zero()};  // the probe's pointing direction (against the normal)
  double planning_ms{0.0};
};

class ProbeApproachPlanner {
 public:
  ProbeApproachPlanner(ApproachConfig config, ProbeGeometry probe);
  ~ProbeApproachPlanner();
  ProbeApproachPlanner(const ProbeApproachPlanner&) = delete;
  ProbeApproachPlanner& operator=(const ProbeApproachPlanner&) = delete;

  // The probabilistic collision map (the CollisionMap nodelet's octree of P(occupied)).
  void setCollisionMap(std::shared_ptr<const octomap::OcTree> map);
  // A box of the known static world, axis-aligned (the table).
  void addStaticBox(const Eigen::Vector3d& centre, const Eigen::Vector3d& size);

  // Empty when the config is usable; otherwise what is wrong with it.
  static std::string validate(const ApproachConfig& config, const ProbeGeometry& probe);

  ApproachPlan plan(const Eigen::Vector3d& start_tip, const Eigen::Vector3d& touch_point,
                    const Eigen::Vector3d& touch_normal) const;

  // Whether the probe, pointing along `direction` with its tip at `tip`, is clear of every
  // obstacle by clearance_m.
  bool isFree(const Eigen::Vector3d& tip, const Eigen::Vector3d& direction) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace gpatlas_motion
