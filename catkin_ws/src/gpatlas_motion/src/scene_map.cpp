#include "gpatlas_motion/scene_map.h"

#include <octomap/OcTree.h>

#include <cmath>
#include <algorithm>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace gpatlas_motion {

namespace {

octomap::point3d toOctomap(const Eigen::Vector3d& p) {
  return octomap::point3d(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
}

// Points bucketed in cubes of a side: which lie within a distance (at most the side) of a query
// is told from the 27 cubes around it.
class PointBuckets {
 public:
  PointBuckets(const std::vector<Eigen::Vector3d>& points, double side) : side_(side) {
    if (!(side_ > 0.0)) return;
    for (const Eigen::Vector3d& p : points)
      if (p.allFinite()) buckets_[key(cell(p))].push_back(p);
  }

  bool anyWithin(const Eigen::Vector3d& q, double distance) const {
    if (!(side_ > 0.0) || buckets_.empty()) return false;
    const Eigen::Vector3i c = cell(q);
    const double squared = distance * distance;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = buckets_.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == buckets_.end()) continue;
          for (const Eigen::Vector3d& p : it->second)
            if ((p - q).squaredNorm() <= squared) return true;
        }
    return false;
  }

 private:
  Eigen::Vector3i cell(const Eigen::Vector3d& p) const { return (p / side_).array().floor().cast<int>().matrix(); }
  static std::int64_t key(const Eigen::Vector3i& c) {
    // 21 bits an axis: cubes of 1 cm reach +-10 km.
    const auto part = [](int v) { return static_cast<std::int64_t>(v & 0x1FFFFF); };
    return part(c.x()) | (part(c.y()) << 21) | (part(c.z()) << 42);
  }

  double side_;
  std::unordered_map<std::int64_t, std::vector<Eigen::Vector3d>> buckets_;
};

}  // namespace

std::string validate(const SceneMapConfig& c) {
  std::ostringstream problems;
  if (!c.min_corner_m.allFinite() || !c.max_corner_m.allFinite() ||
      (c.max_corner_m.array() <= c.min_corner_m.array()).any())
    problems << "scene_min_corner_m and scene_max_corner_m must be finite with max > min on every axis; ";
  if (!(c.max_range_m > 0.0)) problems << "scene_max_range_m must be positive; ";
  if (!(c.hit_probability > 0.5 && c.hit_probability < 1.0)) problems << "scene_hit_probability must be in (0.5, 1); ";
  if (!(c.miss_probability > 0.0 && c.miss_probability < 0.5)) problems << "scene_miss_probability must be in (0, 0.5); ";
  if (!(c.object_margin_m >= 0.0) || !std::isfinite(c.object_margin_m))
    problems << "scene_object_margin_m must be finite and >= 0; ";
  if (!(c.shadow_depth_m >= 0.0) || !std::isfinite(c.shadow_depth_m))
    problems << "scene_shadow_depth_m must be finite and >= 0; ";
  std::string out = problems.str();
  if (!out.empty()) out.resize(out.size() - 2);
  return out;
}

SceneMap::SceneMap(SceneMapConfig config, double resolution_m) : config_(std::move(config)) {
  const std::string invalid = validate(config_);
  if (!invalid.empty()) throw std::invalid_argument("scene map: " + invalid);
  if (!(resolution_m > 0.0) || !std::isfinite(resolution_m))
    throw std::invalid_argument("scene map: the resolution must be positive and finite");
  tree_ = std::make_unique<octomap::OcTree>(resolution_m);
  tree_->setProbHit(config_.hit_probability);
  tree_->setProbMiss(config_.miss_probability);
  octomap::point3d lower = toOctomap(config_.min_corner_m), upper = toOctomap(config_.max_corner_m);
  tree_->setBBXMin(lower);
  tree_->setBBXMax(upper);
  tree_->useBBXLimit(true);
  tree_->enableChangeDetection(true);
}

SceneMap::~SceneMap() = default;

std::size_t SceneMap::insertCloud(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& sensor_origin) {
  if (!sensor_origin.allFinite()) throw std::invalid_argument("scene map: the sensor origin is not finite");
  octomap::Pointcloud cloud;
  cloud.reserve(points.size());
  const Eigen::Array3d lo = config_.min_corner_m.array(), hi = config_.max_corner_m.array();
  for (const Eigen::Vector3d& p : points) {
    // OctoMap would drop these too (range, box); counted here for the caller.
    if (!p.allFinite() || (p - sensor_origin).norm() > config_.max_range_m) continue;
    if ((p.array() < lo).any() || (p.array() > hi).any()) continue;
    cloud.push_back(toOctomap(p));
  }
  // Discretised: the points of one voxel cast one ray, the rays of a 640 x 480 cloud are then
  // the voxels it hit, not its 300,000 points.
  tree_->insertPointCloud(cloud, toOctomap(sensor_origin), config_.max_range_m, false, true);
  bool changed = tree_->numChangesDetected() > 0;
  tree_->resetChangeDetection();
  const double resolution = tree_->getResolution();
  if (std::none_of(origins_.begin(), origins_.end(),
                   [&](const Eigen::Vector3d& o) { return (o - sensor_origin).norm() < resolution; })) {
    origins_.push_back(sensor_origin);
    changed = true;
  }
  if (changed) ++revision_;
  return cloud.size();
}

void SceneMap::clear() {
  tree_->clear();
  tree_->resetChangeDetection();
  origins_.clear();
  ++revision_;
}

std::size_t SceneMap::occupiedVoxels() const {
  const double resolution = tree_->getResolution();
  std::size_t count = 0;
  for (auto it = tree_->begin_leafs(); it != tree_->end_leafs(); ++it) {
    if (!tree_->isNodeOccupied(*it)) continue;
    const auto side = static_cast<std::size_t>(std::lround(it.getSize() / resolution));
    count += side * side * side;  // a pruned leaf holds side^3 voxels
  }
  return count;
}

std::vector<Eigen::Vector3d> SceneMap::obstacles(const std::vector<Eigen::Vector3d>& object_points,
                                                 const std::vector<Eigen::Vector3d>& free_points) const {
  const PointBuckets object(object_points, config_.object_margin_m);
  octomap::KeySet probed;
  for (const Eigen::Vector3d& p : free_points) {
    octomap::OcTreeKey key;
    if (p.allFinite() && tree_->coordToKeyChecked(toOctomap(p), key)) probed.insert(key);
  }
  const auto kept = [&](const Eigen::Vector3d& centre, const octomap::OcTreeKey& key) {
    return !probed.count(key) && !object.anyWithin(centre, config_.object_margin_m);
  };
  const double resolution = tree_->getResolution();
  std::vector<Eigen::Vector3d> out;
  for (auto it = tree_->begin_leafs(); it != tree_->end_leafs(); ++it) {
    if (!tree_->isNodeOccupied(*it)) continue;
    // A pruned leaf stands for side^3 voxels of the finest level; each is judged on its own.
    const int side = static_cast<int>(std::lround(it.getSize() / resolution));
    const octomap::point3d c = it.getCoordinate();
    const Eigen::Vector3d corner =
        Eigen::Vector3d(c.x(), c.y(), c.z()) - Eigen::Vector3d::Constant(0.5 * it.getSize() - 0.5 * resolution);
    for (int i = 0; i < side; ++i)
      for (int j = 0; j < side; ++j)
        for (int k = 0; k < side; ++k) {
          const Eigen::Vector3d centre = corner + resolution * Eigen::Vector3d(i, j, k);
          if (kept(centre, tree_->coordToKey(toOctomap(centre)))) out.push_back(centre);
        }
  }
  addShadows(kept, &out);
  return out;
}

void SceneMap::addShadows(const std::function<bool(const Eigen::Vector3d&, const octomap::OcTreeKey&)>& kept,
                          std::vector<Eigen::Vector3d>* obstacles) const {
  const double resolution = tree_->getResolution();
  const int steps = static_cast<int>(std::floor(config_.shadow_depth_m / resolution + 1e-9));
  if (steps == 0) return;
  octomap::KeySet added;
  const std::size_t casters = obstacles->size();
  for (const Eigen::Vector3d& origin : origins_)
    for (std::size_t i = 0; i < casters; ++i) {
      const Eigen::Vector3d caster = (*obstacles)[i];
      const Eigen::Vector3d step = resolution * (caster - origin).normalized();
      for (int k = 1; k <= steps; ++k) {
        const Eigen::Vector3d p = caster + k * step;
        octomap::OcTreeKey key;
        if (!tree_->coordToKeyChecked(toOctomap(p), key) || !tree_->inBBX(key)) break;
        const octomap::OcTreeNode* node = tree_->search(key);
        if (node && !tree_->isNodeOccupied(node)) break;  // seen through: no shadow beyond
        if (node) continue;                               // occupied: an obstacle of its own
        const octomap::point3d c = tree_->keyToCoord(key);
        const Eigen::Vector3d centre(c.x(), c.y(), c.z());
        if (!kept(centre, key)) break;
        if (added.insert(key).second) obstacles->push_back(centre);
      }
    }
}

SceneRole sceneRole(gpatlas_core::PointLabel label, gpatlas_core::PointSource source) {
  const bool measured = source == gpatlas_core::PointSource::kVision || source == gpatlas_core::PointSource::kTouch;
  if (label == gpatlas_core::PointLabel::kSurface && measured) return SceneRole::kObject;
  return source == gpatlas_core::PointSource::kFreeSpace ? SceneRole::kProbed : SceneRole::kNone;
}

std::vector<Eigen::Vector3d> sceneObstacles(const SceneMap& scene, const std::vector<gpatlas_core::TrainingPoint>& observations,
                                            const std::vector<Eigen::Vector3d>& view_points) {
  std::vector<Eigen::Vector3d> object = view_points, free;
  for (const gpatlas_core::TrainingPoint& p : observations) {
    const SceneRole role = sceneRole(p.label, p.source);
    if (role == SceneRole::kObject) object.push_back(p.position);
    else if (role == SceneRole::kProbed) free.push_back(p.position);
  }
  return scene.obstacles(object, free);
}

std::size_t addObstacles(octomap::OcTree* map, const std::vector<Eigen::Vector3d>& centres) {
  if (!map) throw std::invalid_argument("addObstacles: no map");
  std::size_t added = 0;
  const float occupied = map->getClampingThresMaxLog();
  for (const Eigen::Vector3d& c : centres) {
    const octomap::point3d p = toOctomap(c);
    const octomap::OcTreeNode* before = map->search(p);
    if (!before || !map->isNodeOccupied(before)) ++added;
    map->setNodeValue(p, occupied);
  }
  return added;
}

}  // namespace gpatlas_motion
