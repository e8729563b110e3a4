#pragma once

#include "gpatlas_motion/probe_approach_planner.h"

#include <gpatlas_core/explorer.h>
#include <gpatlas_core/occupancy_grid.h>
#include <gpatlas_core/view_free_space.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

namespace octomap {
class OcTree;
}

namespace gpatlas_motion {

// The collision map as an octree of P(occupied): every grid node becomes a leaf holding its
// log-odds (P clamped to [0.001, 0.999]), the tree's occupancy threshold is `occupied_probability`. `occupied` (optional)
// gets the number of nodes above it. Throws std::invalid_argument for a grid that is not ok.
std::unique_ptr<octomap::OcTree> collisionOctree(const gpatlas_core::OccupancyGrid& grid, double occupied_probability,
                                                 std::size_t* occupied = nullptr);

// A touch's way there and back: the approach from `rest` to the approach pose in front of
// gpatlas_core::approachTarget(touch), the probing segment from there to the target, and the
// retreat from the approach pose in front of retreatTarget back to `rest` (for a poke the
// approach reversed, for a slide planned on its own).
struct TouchMotion {
  bool ok{false};
  std::string message;  // why not, when !ok
  std::vector<Eigen::Vector3d> approach;
  std::vector<Eigen::Vector3d> probing;
  std::vector<Eigen::Vector3d> retreat;
  Eigen::Vector3d direction{Eigen::Vector3d::Zero()};  // the probe's, on the approach
  double planning_ms{0.0};
};
TouchMotion planTouchMotion(const ProbeApproachPlanner& planner, const gpatlas_core::Touch& touch,
                            const Eigen::Vector3d& rest);

// Approach planning in one process (the bench): a collision map built from the model, rebuilt
// after every touch the model took, with the table as a static half-space, and the probe's
// rest at ApproachConfig::rest_tip_position_m.
class ModelTouchApproacher : public gpatlas_core::TouchApproacher {
 public:
  ModelTouchApproacher(const gpatlas_core::SurfaceModel& model, ApproachConfig config,
                       gpatlas_core::OccupancyGridBuilder::Config grid, double map_occupied_probability,
                       std::optional<gpatlas_core::SupportPlane> table);
  ~ModelTouchApproacher() override;

  gpatlas_core::ApproachResult plan(const gpatlas_core::Touch& touch) override;
  // The approach pose and the probing segment (ProbeApproachPlanner::checkApproachPose).
  bool reachable(const Eigen::Vector3d& point, const Eigen::Vector3d& outward_normal) override;
  void modelChanged() override { planner_.reset(); }
  // Builds the map of the model as it is now (a failure is reported by plan()).
  void prepare() override { ensureMap(); }

  // The last map's build time (ms) and size.
  double lastMapBuildMs() const { return last_map_ms_; }

 private:
  const gpatlas_core::SurfaceModel& model_;
  ApproachConfig config_;
  gpatlas_core::OccupancyGridBuilder::Config grid_;
  double map_occupied_probability_;
  std::optional<gpatlas_core::SupportPlane> table_;
  std::unique_ptr<ProbeApproachPlanner> planner_;  // null: the map must be (re)built
  double last_map_ms_{0.0};

  // The planner on a map of the model as it is now; empty with why when the map fails.
  std::string ensureMap();
};

}  // namespace gpatlas_motion
