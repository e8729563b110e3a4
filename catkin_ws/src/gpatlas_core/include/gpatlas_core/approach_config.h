#pragma once

#include "gpatlas_core/types.h"

#include <string>

namespace gpatlas_core {

// The probe as the approach planner (gpatlas_motion) sees it: a spherical tip and a shaft
// behind it (a capsule: a cylinder with round ends) along the direction the probe points; the
// tip's centre is the probe's position.
struct ProbeGeometry {
  double tip_radius_m{0.02};  // simulation/probe_radius_m's sphere
  double shaft_radius_m{0.006};
  double shaft_length_m{0.15};
};

// Paper Algorithm 2's APPROACHTO and MOVEAWAY (gpatlas_motion::ProbeApproachPlanner).
struct ApproachConfig {
  // Whether the exploration plans every touch's approach and retreat (and skips the touches it
  // finds no safe way to). Off: the probe moves in a straight line from its rest to each
  // touch's approach pose and back, which the simulation judges all the same.
  bool enabled{true};
  // Where the probe's tip rests between touches (world frame): the start of every approach and
  // the end of every retreat. The default lies above the table's front, 0.4 m up and 0.3 m
  // from an object standing at simulation/object_position_xy_m. The robot's own body is not
  // an obstacle yet.
  Vector3 rest_tip_position_m{0.5, 0.25, 0.4};
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
  ProbeGeometry probe;
};

// Empty when the config is usable; otherwise what is wrong with it.
std::string validate(const ApproachConfig& config);

}  // namespace gpatlas_core
