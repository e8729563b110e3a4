#include "gpatlas_geometry/segmentation.h"

#include <Eigen/Geometry>

#include <pcl/ModelCoefficients.h>
#include <pcl/filters/crop_box.h>
#include <pcl/filters/extract_indices.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <cmath>
#include <limits>
#include <sstream>

namespace gpatlas_geometry {

using namespace gpatlas_core;

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

std::string validate(const ObjectSegmenter::Config& c) {
  if (!c.crop_min_m.allFinite() || !c.crop_max_m.allFinite() || (c.crop_max_m.array() <= c.crop_min_m.array()).any())
    return "crop box: every component of crop_max_m must exceed crop_min_m";
  if (c.voxel_leaf_m && !(*c.voxel_leaf_m > 0.0)) return "voxel_leaf_m must be > 0, or empty (no voxel grid)";
  if (c.remove_plane && !(c.plane_distance_m > 0.0)) return "plane_distance_m must be > 0";
  if (c.remove_plane && c.plane_max_iterations < 1) return "plane_max_iterations must be >= 1";
  if (!(c.plane_max_tilt_deg > 0.0 && c.plane_max_tilt_deg <= 90.0)) return "plane_max_tilt_deg must be in (0, 90]";
  if (!(c.plane_max_fraction_below >= 0.0 && c.plane_max_fraction_below <= 1.0))
    return "plane_max_fraction_below must be in [0, 1]";
  if (!(c.cluster_tolerance_m > 0.0)) return "cluster_tolerance_m must be > 0";
  if (c.cluster_min_points < 1 || c.cluster_max_points < c.cluster_min_points)
    return "need 1 <= cluster_min_points <= cluster_max_points";
  if (c.object_hint_m && !c.object_hint_m->allFinite()) return "object hint must be finite";
  if (!(c.select_max_distance_m > 0.0)) return "select_max_distance_m must be > 0";
  return {};
}

namespace {

// The finite points, as PCL's floats.
Cloud::Ptr finitePoints(const std::vector<Vector3>& world_points) {
  Cloud::Ptr cloud(new Cloud);
  cloud->reserve(world_points.size());
  for (const auto& p : world_points)
    if (p.allFinite()) cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  return cloud;
}

Cloud::Ptr cropToBox(const Cloud::Ptr& cloud, const ObjectSegmenter::Config& c) {
  Cloud::Ptr cropped(new Cloud);
  pcl::CropBox<pcl::PointXYZ> crop;
  crop.setMin(Eigen::Vector4f(c.crop_min_m.x(), c.crop_min_m.y(), c.crop_min_m.z(), 1.0f));
  crop.setMax(Eigen::Vector4f(c.crop_max_m.x(), c.crop_max_m.y(), c.crop_max_m.z(), 1.0f));
  crop.setInputCloud(cloud);
  crop.filter(*cropped);
  return cropped;
}

// One point per voxel_leaf_m voxel (the cloud itself when the voxel grid is off).
Cloud::Ptr downsample(const Cloud::Ptr& cropped, const ObjectSegmenter::Config& c) {
  if (!c.voxel_leaf_m) return cropped;
  Cloud::Ptr downsampled(new Cloud);
  pcl::VoxelGrid<pcl::PointXYZ> voxel;
  const float leaf = static_cast<float>(*c.voxel_leaf_m);
  voxel.setLeafSize(leaf, leaf, leaf);
  voxel.setInputCloud(cropped);
  voxel.filter(*downsampled);
  return downsampled;
}

// The support plane n . x + d = 0 that RANSAC finds (n pointing up, unit length), with its inliers.
struct PlaneFit {
  bool found{false};
  Vector3 normal{Vector3::UnitZ()};
  double offset{0.0};
  std::vector<int> inliers;
};

PlaneFit fitSupportPlane(const Cloud::Ptr& cloud, const ObjectSegmenter::Config& c) {
  pcl::SACSegmentation<pcl::PointXYZ> sac;
  sac.setOptimizeCoefficients(true);
  sac.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
  sac.setAxis(Eigen::Vector3f::UnitZ());
  sac.setEpsAngle(c.plane_max_tilt_deg * M_PI / 180.0);
  sac.setMethodType(pcl::SAC_RANSAC);
  sac.setDistanceThreshold(c.plane_distance_m);
  sac.setMaxIterations(c.plane_max_iterations);
  sac.setInputCloud(cloud);
  pcl::PointIndices::Ptr inliers(new pcl::PointIndices);
  pcl::ModelCoefficients coefficients;
  sac.segment(*inliers, coefficients);
  PlaneFit plane;
  plane.inliers = inliers->indices;
  if (inliers->indices.size() < c.plane_min_inliers || coefficients.values.size() != 4) return plane;
  Vector3 n(coefficients.values[0], coefficients.values[1], coefficients.values[2]);
  double d = coefficients.values[3];
  if (n.z() < 0.0) {
    n = -n;
    d = -d;
  }
  const double norm = n.norm();
  n /= norm;
  d /= norm;
  plane.found = true;
  plane.normal = n;
  plane.offset = d;
  return plane;
}

// The points above the plane, counting those below it, apart (below_on_border) from those that
// project onto the border of the inliers' footprint in the plane. A table's own side faces, seen
// at its edge, lie below it but project onto the footprint's border: they do not count against
// it. What lies below it elsewhere (an object under a flat face of its own) does.
struct PlaneSides {
  Cloud::Ptr above{new Cloud};
  std::size_t below{0}, below_on_border{0};
};

PlaneSides splitAtPlane(const Cloud& cloud, const PlaneFit& plane, const ObjectSegmenter::Config& c) {
  const Vector3& n = plane.normal;
  const double d = plane.offset;
  // Box axes: the world's x (else y) projected onto the plane, so that a table aligned with
  // the world has its sides on the box's border whatever the fitted normal's small tilt (an
  // arbitrary orthogonal, e.g. Eigen's unitOrthogonal, turns with the tilt's direction).
  Vector3 u = Vector3::UnitX() - n.x() * n;
  if (u.norm() < 0.5) u = Vector3::UnitY() - n.y() * n;
  u.normalize();
  const Vector3 v = n.cross(u);
  Eigen::AlignedBox2d footprint;
  for (int index : plane.inliers) {
    const auto& p = cloud.points[static_cast<std::size_t>(index)];
    const Vector3 x(p.x, p.y, p.z);
    footprint.extend(Eigen::Vector2d(u.dot(x), v.dot(x)));
  }
  const Eigen::Vector2d band = Eigen::Vector2d::Constant(c.cluster_tolerance_m);
  const Eigen::AlignedBox2d outer(footprint.min() - band, footprint.max() + band);
  const Eigen::AlignedBox2d inner(footprint.min() + band, footprint.max() - band);
  const auto onBorder = [&](const Vector3& x) {
    const Eigen::Vector2d q(u.dot(x), v.dot(x));
    return outer.contains(q) && !inner.contains(q);
  };
  PlaneSides sides;
  for (const auto& p : cloud.points) {
    const Vector3 x(p.x, p.y, p.z);
    const double height = n.dot(x) + d;
    if (height > c.plane_distance_m) sides.above->push_back(p);
    else if (height < -c.plane_distance_m) ++(onBorder(x) ? sides.below_on_border : sides.below);
  }
  return sides;
}

// The cloud without its support plane, recording the plane in `result`; the cloud itself when
// no plane qualifies as a support.
Cloud::Ptr removeSupportPlane(const Cloud::Ptr& downsampled, const ObjectSegmenter::Config& c,
                              SegmentationResult& result) {
  if (!c.remove_plane || downsampled->size() < 3) return downsampled;
  const PlaneFit plane = fitSupportPlane(downsampled, c);
  result.stats.plane_inliers = plane.inliers.size();
  if (!plane.found) return downsampled;
  const PlaneSides sides = splitAtPlane(*downsampled, plane, c);
  // A support plane has (almost) nothing under it. A horizontal face of the object itself,
  // e.g. a mug's rim in an object-only cloud, has the object below: keep everything then.
  // Nor is a plane with nothing on it and faces hanging from its border: the top of a box
  // seen alone has its sides there, as a table has its own. (A bare plane is an empty table:
  // removed, it leaves nothing, which is the error to report.)
  const bool box_top = sides.above->size() < c.cluster_min_points && sides.below_on_border > 0;
  if (box_top ||
      !(static_cast<double>(sides.below) <= c.plane_max_fraction_below * static_cast<double>(downsampled->size())))
    return downsampled;
  result.plane_found = true;
  result.plane_normal = plane.normal;
  result.plane_offset = plane.offset;
  return sides.above;
}

std::vector<pcl::PointIndices> euclideanClusters(const Cloud::Ptr& cloud, const ObjectSegmenter::Config& c) {
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
  tree->setInputCloud(cloud);
  std::vector<pcl::PointIndices> clusters;
  pcl::EuclideanClusterExtraction<pcl::PointXYZ> extraction;
  extraction.setClusterTolerance(c.cluster_tolerance_m);
  extraction.setMinClusterSize(static_cast<int>(c.cluster_min_points));
  extraction.setMaxClusterSize(static_cast<int>(std::min<std::size_t>(c.cluster_max_points, std::numeric_limits<int>::max())));
  extraction.setSearchMethod(tree);
  extraction.setInputCloud(cloud);
  extraction.extract(clusters);
  return clusters;
}

}  // namespace

SegmentationResult ObjectSegmenter::segment(const std::vector<Vector3>& world_points) const {
  SegmentationResult result;
  const Config& c = config_;
  const std::string invalid = validate(c);
  if (!invalid.empty()) {
    result.message = "invalid segmentation config: " + invalid;
    return result;
  }
  result.stats.input = world_points.size();
  const Cloud::Ptr cloud = finitePoints(world_points);
  result.stats.finite = cloud->size();
  if (cloud->empty()) {
    result.message = world_points.empty() ? "empty cloud" : "cloud has no finite point";
    return result;
  }
  const Cloud::Ptr cropped = cropToBox(cloud, c);
  result.stats.after_crop = cropped->size();
  if (cropped->empty()) {
    result.message = "no point inside the crop box";
    return result;
  }
  const Cloud::Ptr downsampled = downsample(cropped, c);
  result.stats.after_voxel = downsampled->size();
  const Cloud::Ptr without_plane = removeSupportPlane(downsampled, c, result);
  result.stats.after_plane = without_plane->size();
  if (without_plane->empty()) {
    result.message = "nothing left above the support plane";
    return result;
  }

  const std::vector<pcl::PointIndices> clusters = euclideanClusters(without_plane, c);
  result.stats.clusters = clusters.size();
  if (clusters.empty()) {
    std::ostringstream msg;
    msg << "no object cluster: " << without_plane->size() << " points left, none in a cluster of at least "
        << c.cluster_min_points << " points within " << c.cluster_tolerance_m << " m";
    result.message = msg.str();
    return result;
  }
  result.clusters.resize(clusters.size());
  for (std::size_t i = 0; i < clusters.size(); ++i)
    for (int idx : clusters[i].indices) {
      const auto& p = without_plane->points[static_cast<std::size_t>(idx)];
      result.clusters[i].emplace_back(p.x, p.y, p.z);
    }
  const std::size_t best = chooseObject(result.clusters, c.object_hint_m);
  result.object_cluster = best;
  result.object_points = result.clusters[best];
  result.stats.object = result.object_points.size();
  result.ok = true;
  std::ostringstream msg;
  msg << "object: " << result.stats.object << " points (cluster " << best + 1 << " of " << clusters.size() << ")";
  result.message = msg.str();
  return result;
}

std::optional<std::size_t> clusterNear(const std::vector<std::vector<Vector3>>& clusters, const Vector3& point,
                                       double max_distance_m, double* nearest_m) {
  double best = std::numeric_limits<double>::infinity();
  std::size_t best_cluster = 0;
  if (point.allFinite())
    for (std::size_t i = 0; i < clusters.size(); ++i)
      for (const Vector3& p : clusters[i]) {
        const double d = (p - point).squaredNorm();
        if (d < best) best = d, best_cluster = i;
      }
  best = std::sqrt(best);
  if (nearest_m) *nearest_m = best;
  if (!(best <= max_distance_m)) return std::nullopt;
  return best_cluster;
}

std::size_t chooseObject(const std::vector<std::vector<Vector3>>& clusters, const std::optional<Vector3>& hint) {
  std::size_t best = 0;
  double best_score = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < clusters.size(); ++i) {
    const double score = hint ? -(centroidOf(clusters[i]) - *hint).norm() : static_cast<double>(clusters[i].size());
    if (score > best_score) {
      best_score = score;
      best = i;
    }
  }
  return best;
}

Vector3 centroidOf(const std::vector<Vector3>& points) {
  Vector3 sum = Vector3::Zero();
  for (const Vector3& p : points) sum += p;
  return points.empty() ? sum : Vector3(sum / static_cast<double>(points.size()));
}

}  // namespace gpatlas_geometry
