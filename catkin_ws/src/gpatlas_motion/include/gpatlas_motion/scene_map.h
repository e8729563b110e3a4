#pragma once

#include <gpatlas_core/common/types.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace octomap {
class OcTree;
class OcTreeKey;
}

namespace gpatlas_motion {

// The scene map's settings: config/pipeline.yaml's collision_map/scene_* (readSceneMap). Its
// voxel is the collision map's (collision_map/resolution_m): both go into one octree.
struct SceneMapConfig {
  // Off: the collision map holds the explored object's model and nothing else of the scene.
  bool enabled{true};
  // The box (world frame) the camera's clouds update; a ray is cut where it leaves it, and a
  // point outside it neither occupies nor frees anything. It holds the table, what stands on
  // it and the arm's way there.
  Eigen::Vector3d min_corner_m{-0.5, -1.0, -0.05};
  Eigen::Vector3d max_corner_m{1.6, 1.0, 1.0};
  // Points farther from the sensor than this are dropped (stereo depth is noise beyond it).
  double max_range_m{3.0};
  // OctoMap's sensor model (octomap_server's defaults): one hit makes a voxel occupied, a
  // voxel seen through once after a hit is free again only after two misses.
  double hit_probability{0.7};
  double miss_probability{0.4};
  // The scene's occupied voxels within this distance of the explored object's points (its
  // view and contacts) are left to its model: the object must not block the touches on itself,
  // whose contact zone (approach/contact_zone_m) ends at the surface; more than the probe's
  // tip radius with its clearance, so that the table at the object's foot does not either.
  double object_margin_m{0.03};
  // A camera sees an object's near side only, and the voxels behind it stay unknown, which the
  // approach planner takes as free: a probe's shaft would pass through a neighbour's hidden
  // side. So the unknown voxels up to this far behind each obstacle voxel, along the ray from
  // the sensor, are obstacles too (0: none; about a small object's depth keeps a shaft out).
  double shadow_depth_m{0.1};
  // The explored object's model predicts what the camera did not see of it, and can miss a part
  // (a handle behind it): a probe crossing that space on its way would hit it. So the voxels
  // within this distance of the object (its points and the model's occupied voxels) that no
  // camera ray reached and no probe stroke went through are obstacles for the way to a touch and
  // back, not for the approach pose and the probing stroke, a guarded move that may enter them
  // along its line (ProbeApproachPlanner::setUnseenSpace). About how far a part may stand out of
  // the predicted surface; 0: off.
  double unseen_reach_m{0.05};
  // Each distinct sensor origin (farther than a voxel from the others) casts the obstacles'
  // shadows; a moving camera brings new ones at every frame. The oldest beyond this many are
  // forgotten (their shadows go, the voxels they saw stay). A bound on memory and on each merge's
  // casts, not a setting: fixed, not in the YAML.
  int max_sensor_origins{16};
};

// Empty when the config is usable, else what is wrong with it.
std::string validate(const SceneMapConfig& config);

// What the camera saw, as octomap_server builds it: each cloud goes into an OctoMap with
// insertPointCloud (discretised: one ray per voxel, not per point), its points' voxels occupied
// and the voxels on the rays from the sensor free, within the config's box. The collision map
// takes its occupied voxels as obstacles besides the explored object's model (obstacles(),
// addObstacles()).
class SceneMap {
 public:
  // Throws std::invalid_argument for an unusable config or resolution.
  SceneMap(SceneMapConfig config, double resolution_m);
  ~SceneMap();
  SceneMap(const SceneMap&) = delete;
  SceneMap& operator=(const SceneMap&) = delete;

  // One cloud (world frame, finite points) seen from `sensor_origin` (world frame). Returns the
  // number of points inside the box and the range, which were inserted. A still camera's frames
  // hit the same voxels from the same origin: once enough of them have driven every voxel they
  // touch to OctoMap's clamping bounds, another changes nothing and is not cast (skippedClouds()).
  std::size_t insertCloud(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& sensor_origin);
  void clear();
  // Counts the changes: each insertCloud that made a voxel known or flipped one between occupied
  // and not, or brought a new sensor origin, and each clear(). Obstacles taken at one revision
  // hold until the next.
  std::uint64_t revision() const { return revision_; }
  // The clouds insertCloud did not cast, as they could not change the map.
  std::size_t skippedClouds() const { return skipped_clouds_; }
  std::size_t occupiedVoxels() const;
  // The sensor origins whose shadows are cast, oldest first (at most max_sensor_origins).
  const std::vector<Eigen::Vector3d>& sensorOrigins() const { return origins_; }
  const SceneMapConfig& config() const { return config_; }
  const octomap::OcTree& tree() const { return *tree_; }

  // The centres of the scene's occupied voxels that are obstacles for the approach planner:
  // every one except those within object_margin_m of an `object_points` point (the explored
  // object, which its model governs) and those holding a `free_points` point (the probe went
  // through it, which outweighs what the camera saw); and the unknown voxels in their shadow
  // (shadow_depth_m) but those.
  std::vector<Eigen::Vector3d> obstacles(const std::vector<Eigen::Vector3d>& object_points,
                                         const std::vector<Eigen::Vector3d>& free_points) const;

  // The centres of the voxels within unseen_reach_m of an `object_points` point (the explored
  // object: its points and its model's occupied voxels) that no camera ray reached (unknown in
  // the scene) and that hold no `free_points` point (the probe went through it): where the
  // object may have a part nobody saw. None when unseen_reach_m is 0.
  std::vector<Eigen::Vector3d> unseen(const std::vector<Eigen::Vector3d>& object_points,
                                      const std::vector<Eigen::Vector3d>& free_points) const;

 private:
  SceneMapConfig config_;
  std::unique_ptr<octomap::OcTree> tree_;
  std::vector<Eigen::Vector3d> origins_;  // of the clouds inserted, each once
  std::uint64_t revision_{0};
  // The last cloud cast, as the voxels it hit and its origin, and how often in a row it came.
  struct LastCloud;
  std::unique_ptr<LastCloud> last_cloud_;
  std::size_t skipped_clouds_{0};
  // What obstacles() takes from the tree, which only a new revision changes: the occupied
  // voxels and the unknown ones in each one's shadow, in the order of the rays (computed when
  // first asked for at a revision; the lock keeps obstacles() const and callable from threads).
  struct Candidates;
  mutable std::shared_ptr<const Candidates> candidates_;
  // Which candidates lie within object_margin_m of the object's points at the last call: the
  // training sets of one view (a still camera's) repeat them.
  struct NearObject;
  mutable std::shared_ptr<const NearObject> near_object_;
  mutable std::mutex candidates_mutex_;
  std::shared_ptr<const Candidates> candidates() const;
  std::shared_ptr<const NearObject> nearObject(const std::shared_ptr<const Candidates>& candidates,
                                               const std::vector<Eigen::Vector3d>& object_points) const;
};

// What an observation is to the scene map: the explored object (a surface point the camera or the
// probe measured), where the probe went (free space), or neither.
enum class SceneRole { kObject, kProbed, kNone };
SceneRole sceneRole(gpatlas_core::PointLabel label, gpatlas_core::PointSource source);

// SceneMap::obstacles() for a model's training data: its surface points from the camera and the
// probe, with `view_points` (the view's object points), are the explored object; its free-space
// points are where the probe went (sceneRole).
std::vector<Eigen::Vector3d> sceneObstacles(const SceneMap& scene, const std::vector<gpatlas_core::TrainingPoint>& observations,
                                            const std::vector<Eigen::Vector3d>& view_points);

// SceneMap::unseen() for a model's training data: its surface points from the camera and the
// probe, with `view_points` and `model_occupied` (its occupied voxels' centres), are the object;
// its free-space points are where the probe went (sceneRole).
std::vector<Eigen::Vector3d> sceneUnseen(const SceneMap& scene, const std::vector<gpatlas_core::TrainingPoint>& observations,
                                         const std::vector<Eigen::Vector3d>& view_points,
                                         const std::vector<Eigen::Vector3d>& model_occupied);

// An octree of `resolution_m` whose occupied voxels are those at `centres` (addObstacles), with
// nothing else known: the unseen space as ProbeApproachPlanner::setUnseenSpace takes it.
std::unique_ptr<octomap::OcTree> voxelOctree(const std::vector<Eigen::Vector3d>& centres, double resolution_m);

// Marks the voxels at `centres` occupied in `map` (the collision octree, at its clamping
// maximum, whatever the model said there). Returns how many were not occupied before.
std::size_t addObstacles(octomap::OcTree* map, const std::vector<Eigen::Vector3d>& centres);

}  // namespace gpatlas_motion
