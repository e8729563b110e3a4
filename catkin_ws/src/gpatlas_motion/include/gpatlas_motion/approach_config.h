#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace gpatlas_motion {

// The probe as the approach planner sees it: a spherical tip and a shaft behind it (a capsule:
// a cylinder with round ends) along the direction the probe points; the tip's centre is the
// probe's position.
struct ProbeGeometry {
  double tip_radius_m{0.02};  // simulation/probe_radius_m's sphere
  double shaft_radius_m{0.006};
  double shaft_length_m{0.15};
};

// Paper Algorithm 2's APPROACHTO and MOVEAWAY (ProbeApproachPlanner, ArmApproachPlanner):
// config/pipeline.yaml's approach/ (readApproach, config_readers.h).
struct ApproachConfig {
  // Whether the exploration plans every touch's approach and retreat (and skips the touches it
  // finds no safe way to). Off: the probe moves in a straight line from its rest to each
  // touch's approach pose and back, which the simulation judges all the same.
  bool enabled{true};
  // Where the probe's tip rests between touches (world frame): the start of every approach and
  // the end of every retreat; with an arm, it rests with the tip here pointing down. The
  // default lies 0.4 m above the table and 0.3 m to the left of an object standing at
  // simulation/object_position_xy_m, within the Vito left arm's reach. The robot's own body is
  // not an obstacle yet.
  Eigen::Vector3d rest_tip_position_m{0.7, 0.3, 0.4};
  // A collision-map voxel with P(occupied) above this is an obstacle.
  double occupied_probability{0.5};
  double approach_distance_m{0.1};  // the approach pose's distance from the touch along its normal
  double clearance_m{0.005};        // the probe is inflated by this in every check
  // The probing segment is checked up to this far from the touch: there the probe is meant to
  // meet the surface, whose voxels the map marks occupied.
  double contact_zone_m{0.02};
  double max_planning_time_s{0.2};
  double workspace_margin_m{0.2};   // the planner's box: start and approach pose, grown by this
  double check_resolution_m{0.002};  // motions are checked at least this finely
  // A touch whose approach along its normal is blocked (under a rim, next to the table, behind
  // a handle) is tried along directions tilted from the normal, in rings of tilt_step_deg up to
  // max_tilt_deg, tilt_azimuths per ring, the ring's first direction turned toward the table's
  // normal (the usual obstacle is the table; +z without one). The probe then comes in along the
  // first free one whose approach pose lies clear of the space no sensor observed, else along
  // the first free one (TouchMotionPlanner::approachDirection).
  // 0: along the normal only.
  double max_tilt_deg{60.0};
  double tilt_step_deg{15.0};
  int tilt_azimuths{8};
  ProbeGeometry probe;
  // Plan for the arm that holds the probe (the URDF's chain from arm_base_link to arm_tip_link)
  // in joint space: its links and the probe, on the same map and static world. Off: the probe
  // is planned for on its own, free-floating.
  bool use_arm{false};
  std::string arm_base_link{"world"};
  std::string arm_tip_link{"probe_tip"};
  // The arm's link capsules, inflated by clearance_m too. The tool (after the last joint) is
  // the probe's shaft, checked as the probe above.
  double arm_link_radius_m{0.06};
  // Joint-space motions are checked at least this finely (Euclidean over the joints): a point
  // 1 m from the joints' axes moves about 1 cm per step.
  double arm_check_step_rad{0.01};
  // The cheap reachability test of a candidate tries this many inverse-kinematics starts; the
  // full plan of the chosen touch the arm's own number.
  int arm_reachability_ik_restarts{4};
  // The joint trajectories' timing: the slowest joint moves at this speed.
  double arm_joint_speed_rad_s{0.5};
};

// Empty when the config is usable; otherwise what is wrong with it.
std::string validate(const ApproachConfig& config);

// The directions a touch with this outward normal may be approached from, in the order they
// are tried: the normal, then ApproachConfig's rings of tilted directions (unit vectors at
// tilt_step_deg, 2 tilt_step_deg, ... up to max_tilt_deg from the normal), each ring starting
// with the direction turned toward `up` and alternating to either side of it. The probe moves
// along minus the direction. Throws std::invalid_argument for a zero or non-finite normal.
std::vector<Eigen::Vector3d> approachDirections(const Eigen::Vector3d& outward_normal, const Eigen::Vector3d& up,
                                                const ApproachConfig& config);

}  // namespace gpatlas_motion
