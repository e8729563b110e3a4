#include "gpatlas_motion/scene_map.h"

#include <octomap/OcTree.h>

#include <cmath>
#include <algorithm>
#include <cstdint>
#include <limits>
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

// OctoMap's KeySet is std::tr1's, which has no operator==.
bool sameKeys(const octomap::KeySet& a, const octomap::KeySet& b) {
  if (a.size() != b.size()) return false;
  return std::all_of(a.begin(), a.end(), [&](const octomap::OcTreeKey& k) { return b.count(k) > 0; });
}

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
  if (!(c.unseen_reach_m >= 0.0) || !std::isfinite(c.unseen_reach_m))
    problems << "scene_unseen_reach_m must be finite and >= 0; ";
  if (c.max_sensor_origins < 1) problems << "max_sensor_origins must be at least 1; ";
  std::string out = problems.str();
  if (!out.empty()) out.resize(out.size() - 2);
  return out;
}

// One voxel of the finest level: its key and its centre.
struct SceneVoxel {
  octomap::OcTreeKey key;
  Eigen::Vector3d centre;
};

struct SceneMap::LastCloud {
  octomap::KeySet hits;
  Eigen::Vector3d origin{Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())};  // none yet
  std::size_t repeats{0};  // of the same hits from the same origin, in a row, cast
};

struct SceneMap::Candidates {
  std::uint64_t revision{0};
  std::vector<SceneVoxel> occupied;
  // The unknown voxels behind occupied[i] seen from origins_[o], nearest first, up to
  // shadow_depth_m or to the first voxel seen free or outside the box:
  // shadows[begin[o * occupied.size() + i], begin[o * occupied.size() + i + 1]).
  std::vector<SceneVoxel> shadows;
  std::vector<std::size_t> begin;
  // How many of origins_ the chains were cast from (the chains' count, whatever origins_ holds
  // by the time they are read); none without shadows.
  std::size_t origins{0};
  // shadows[s] is the voxel numbered unique[s] (of `distinct`): chains cross, and each voxel is
  // one obstacle.
  std::vector<std::uint32_t> unique;
  std::size_t distinct{0};
};

struct SceneMap::NearObject {
  std::shared_ptr<const Candidates> candidates;
  std::vector<Eigen::Vector3d> object_points;
  std::vector<char> occupied, shadows;  // per candidate: within the margin
};

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
  last_cloud_ = std::make_unique<LastCloud>();
}

SceneMap::~SceneMap() = default;

std::size_t SceneMap::insertCloud(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& sensor_origin) {
  if (!sensor_origin.allFinite()) throw std::invalid_argument("scene map: the sensor origin is not finite");
  octomap::Pointcloud cloud;
  cloud.reserve(points.size());
  octomap::KeySet hits;
  const Eigen::Array3d lo = config_.min_corner_m.array(), hi = config_.max_corner_m.array();
  for (const Eigen::Vector3d& p : points) {
    // OctoMap would drop these too (range, box); counted here for the caller.
    if (!p.allFinite() || (p - sensor_origin).norm() > config_.max_range_m) continue;
    if ((p.array() < lo).any() || (p.array() > hi).any()) continue;
    cloud.push_back(toOctomap(p));
    octomap::OcTreeKey key;
    if (tree_->coordToKeyChecked(cloud.back(), key)) hits.insert(key);
  }
  // Discretised, OctoMap casts one ray from the origin to each hit voxel's centre, and updates
  // each voxel once (a hit, else a miss): the same hits from the same origin update the same
  // voxels the same way. Each cast moves a voxel's log-odds by at least the smaller step toward
  // its clamping bound, so after `converged` casts in a row every voxel is at its bound and
  // OctoMap leaves it there: another cast is a no-op, and costs a core at a camera's rate.
  LastCloud& last = *last_cloud_;
  if (sensor_origin == last.origin && sameKeys(hits, last.hits)) {
    const double span = tree_->getClampingThresMaxLog() - tree_->getClampingThresMinLog();
    const double step = std::min(std::abs(tree_->getProbHitLog()), std::abs(tree_->getProbMissLog()));
    const auto converged = static_cast<std::size_t>(std::ceil(span / step)) + 1;
    if (last.repeats >= converged) {
      ++skipped_clouds_;
      return cloud.size();
    }
    ++last.repeats;
  } else {
    last.hits = std::move(hits);
    last.origin = sensor_origin;
    last.repeats = 1;
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
    if (origins_.size() > static_cast<std::size_t>(config_.max_sensor_origins)) origins_.erase(origins_.begin());
    changed = true;
  }
  if (changed) ++revision_;
  return cloud.size();
}

void SceneMap::clear() {
  tree_->clear();
  tree_->resetChangeDetection();
  origins_.clear();
  *last_cloud_ = LastCloud();
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

std::shared_ptr<const SceneMap::Candidates> SceneMap::candidates() const {
  std::lock_guard<std::mutex> lock(candidates_mutex_);
  if (candidates_ && candidates_->revision == revision_) return candidates_;
  auto out = std::make_shared<Candidates>();
  out->revision = revision_;
  const double resolution = tree_->getResolution();
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
          out->occupied.push_back({tree_->coordToKey(toOctomap(centre)), centre});
        }
  }
  const int steps = static_cast<int>(std::floor(config_.shadow_depth_m / resolution + 1e-9));
  out->origins = steps > 0 ? origins_.size() : 0;
  out->begin.reserve(out->origins * out->occupied.size() + 1);
  out->begin.push_back(0);
  for (std::size_t o = 0; o < out->origins; ++o)
    for (const SceneVoxel& caster : out->occupied) {
      const Eigen::Vector3d& origin = origins_[o];
      const Eigen::Vector3d step = resolution * (caster.centre - origin).normalized();
      for (int k = 1; k <= steps; ++k) {
        octomap::OcTreeKey key;
        if (!tree_->coordToKeyChecked(toOctomap(caster.centre + k * step), key) || !tree_->inBBX(key)) break;
        const octomap::OcTreeNode* node = tree_->search(key);
        if (node && !tree_->isNodeOccupied(node)) break;  // seen through: no shadow beyond
        if (node) continue;                               // occupied: an obstacle of its own
        const octomap::point3d c = tree_->keyToCoord(key);
        out->shadows.push_back({key, Eigen::Vector3d(c.x(), c.y(), c.z())});
      }
      out->begin.push_back(out->shadows.size());
    }
  std::unordered_map<octomap::OcTreeKey, std::uint32_t, octomap::OcTreeKey::KeyHash> numbers;
  out->unique.reserve(out->shadows.size());
  for (const SceneVoxel& v : out->shadows)
    out->unique.push_back(numbers.emplace(v.key, static_cast<std::uint32_t>(numbers.size())).first->second);
  out->distinct = numbers.size();
  candidates_ = std::move(out);
  return candidates_;
}

std::shared_ptr<const SceneMap::NearObject> SceneMap::nearObject(const std::shared_ptr<const Candidates>& candidates,
                                                                const std::vector<Eigen::Vector3d>& object_points) const {
  {
    std::lock_guard<std::mutex> lock(candidates_mutex_);
    if (near_object_ && near_object_->candidates == candidates && near_object_->object_points == object_points)
      return near_object_;
  }
  auto out = std::make_shared<NearObject>();
  out->candidates = candidates;
  out->object_points = object_points;
  const PointBuckets object(object_points, config_.object_margin_m);
  const auto near = [&](const std::vector<SceneVoxel>& voxels, std::vector<char>* verdicts) {
    verdicts->reserve(voxels.size());
    for (const SceneVoxel& v : voxels) verdicts->push_back(object.anyWithin(v.centre, config_.object_margin_m));
  };
  near(candidates->occupied, &out->occupied);
  near(candidates->shadows, &out->shadows);
  std::lock_guard<std::mutex> lock(candidates_mutex_);
  near_object_ = out;
  return out;
}

std::vector<Eigen::Vector3d> SceneMap::obstacles(const std::vector<Eigen::Vector3d>& object_points,
                                                 const std::vector<Eigen::Vector3d>& free_points) const {
  const std::shared_ptr<const Candidates> candidates = this->candidates();
  const std::shared_ptr<const NearObject> near = nearObject(candidates, object_points);
  octomap::KeySet probed;
  for (const Eigen::Vector3d& p : free_points) {
    octomap::OcTreeKey key;
    if (p.allFinite() && tree_->coordToKeyChecked(toOctomap(p), key)) probed.insert(key);
  }
  std::vector<Eigen::Vector3d> out;
  std::vector<std::size_t> casters;  // the kept occupied voxels, which cast shadows
  const std::vector<SceneVoxel>& occupied = candidates->occupied;
  for (std::size_t i = 0; i < occupied.size(); ++i)
    if (!near->occupied[i] && !probed.count(occupied[i].key)) {
      out.push_back(occupied[i].centre);
      casters.push_back(i);
    }
  // Behind a kept caster, its unknown voxels up to the first one the object's model or the
  // probe governs.
  std::vector<char> added(candidates->distinct, 0);
  for (std::size_t o = 0; o < candidates->origins && !candidates->shadows.empty(); ++o)
    for (const std::size_t i : casters) {
      const std::size_t chain = o * occupied.size() + i;
      for (std::size_t s = candidates->begin[chain]; s < candidates->begin[chain + 1]; ++s) {
        const SceneVoxel& v = candidates->shadows[s];
        if (near->shadows[s] || probed.count(v.key)) break;
        if (!added[candidates->unique[s]]) {
          added[candidates->unique[s]] = 1;
          out.push_back(v.centre);
        }
      }
    }
  return out;
}

std::vector<Eigen::Vector3d> SceneMap::unseen(const std::vector<Eigen::Vector3d>& object_points,
                                              const std::vector<Eigen::Vector3d>& free_points) const {
  std::vector<Eigen::Vector3d> out;
  const double reach = config_.unseen_reach_m;
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : object_points)
    if (p.allFinite()) box.extend(p);
  if (!(reach > 0.0) || box.isEmpty()) return out;
  octomap::KeySet probed;
  for (const Eigen::Vector3d& p : free_points) {
    octomap::OcTreeKey key;
    if (p.allFinite() && tree_->coordToKeyChecked(toOctomap(p), key)) probed.insert(key);
  }
  const PointBuckets object(object_points, reach);
  const Eigen::Vector3d grow = Eigen::Vector3d::Constant(reach);
  octomap::OcTreeKey lower, upper;
  if (!tree_->coordToKeyChecked(toOctomap(box.min() - grow), lower) ||
      !tree_->coordToKeyChecked(toOctomap(box.max() + grow), upper))
    return out;
  for (unsigned k0 = lower[0]; k0 <= upper[0]; ++k0)
    for (unsigned k1 = lower[1]; k1 <= upper[1]; ++k1)
      for (unsigned k2 = lower[2]; k2 <= upper[2]; ++k2) {
        const octomap::OcTreeKey key(static_cast<octomap::key_type>(k0), static_cast<octomap::key_type>(k1),
                                     static_cast<octomap::key_type>(k2));
        if (tree_->search(key) || probed.count(key)) continue;
        const octomap::point3d c = tree_->keyToCoord(key);
        const Eigen::Vector3d centre(c.x(), c.y(), c.z());
        if (object.anyWithin(centre, reach)) out.push_back(centre);
      }
  return out;
}

SceneRole sceneRole(gpatlas_core::PointLabel label, gpatlas_core::PointSource source) {
  const bool measured = source == gpatlas_core::PointSource::kVision || source == gpatlas_core::PointSource::kTouch;
  if (label == gpatlas_core::PointLabel::kSurface && measured) return SceneRole::kObject;
  return source == gpatlas_core::PointSource::kFreeSpace ? SceneRole::kProbed : SceneRole::kNone;
}

namespace {

// The explored object's measured surface points, appended to `object`, and where the probe went,
// to `free` (sceneRole).
void splitBySceneRole(const std::vector<gpatlas_core::TrainingPoint>& observations, std::vector<Eigen::Vector3d>* object,
                      std::vector<Eigen::Vector3d>* free) {
  for (const gpatlas_core::TrainingPoint& p : observations) {
    const SceneRole role = sceneRole(p.label, p.source);
    if (role == SceneRole::kObject) object->push_back(p.position);
    else if (role == SceneRole::kProbed) free->push_back(p.position);
  }
}

}  // namespace

std::vector<Eigen::Vector3d> sceneObstacles(const SceneMap& scene, const std::vector<gpatlas_core::TrainingPoint>& observations,
                                            const std::vector<Eigen::Vector3d>& view_points) {
  std::vector<Eigen::Vector3d> object = view_points, free;
  splitBySceneRole(observations, &object, &free);
  return scene.obstacles(object, free);
}

std::vector<Eigen::Vector3d> sceneUnseen(const SceneMap& scene, const std::vector<gpatlas_core::TrainingPoint>& observations,
                                         const std::vector<Eigen::Vector3d>& view_points,
                                         const std::vector<Eigen::Vector3d>& model_occupied) {
  std::vector<Eigen::Vector3d> object = view_points, free;
  object.insert(object.end(), model_occupied.begin(), model_occupied.end());
  splitBySceneRole(observations, &object, &free);
  return scene.unseen(object, free);
}

std::unique_ptr<octomap::OcTree> voxelOctree(const std::vector<Eigen::Vector3d>& centres, double resolution_m) {
  if (!(resolution_m > 0.0) || !std::isfinite(resolution_m))
    throw std::invalid_argument("voxelOctree: the resolution must be positive and finite");
  auto tree = std::make_unique<octomap::OcTree>(resolution_m);
  addObstacles(tree.get(), centres);
  return tree;
}

std::size_t addObstacles(octomap::OcTree* map, const std::vector<Eigen::Vector3d>& centres) {
  if (!map) throw std::invalid_argument("addObstacles: no map");
  std::size_t added = 0;
  const float occupied = map->getClampingThresMaxLog();
  // In bulk: the inner nodes' occupancy once at the end, not up the tree at every voxel.
  for (const Eigen::Vector3d& c : centres) {
    octomap::OcTreeKey key;
    if (!map->coordToKeyChecked(toOctomap(c), key)) continue;
    const octomap::OcTreeNode* before = map->search(key);
    if (!before || !map->isNodeOccupied(before)) ++added;
    map->setNodeValue(key, occupied, true);
  }
  map->updateInnerOccupancy();
  map->prune();  // as the voxel-by-voxel update left it
  return added;
}

}  // namespace gpatlas_motion
