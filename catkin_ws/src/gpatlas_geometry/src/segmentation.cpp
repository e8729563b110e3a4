#include "gpatlas_geometry/segmentation.h"

#include <Eigen/Geometry>

#include <pcl/ModelCoefficients.h>
#include <pcl/filters/crop_box.h>
#include <pcl/filters/extract_indices.h>
#include <pcl/filters/statistical_outlier_removal.h>
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
  if (!(c.voxel_leaf_m >= 0.0)) return "voxel_leaf_m must be >= 0";
  if (c.remove_plane && !(c.plane_distance_m > 0.0)) return "plane_distance_m must be > 0";
  if (c.remove_plane && c.plane_max_iterations < 1) return "plane_max_iterations must be >= 1";
  if (!(c.plane_max_tilt_deg > 0.0 && c.plane_max_tilt_deg <= 90.0)) return "plane_max_tilt_deg must be in (0, 90]";
  if (!(c.plane_max_fraction_below >= 0.0 && c.plane_max_fraction_below <= 1.0))
    return "plane_max_fraction_below must be in [0, 1]";
  if (c.outlier_mean_k < 0 || !(c.outlier_stddev_multiplier > 0.0)) return "outlier removal settings must be positive";
  if (!(c.cluster_tolerance_m > 0.0)) return "cluster_tolerance_m must be > 0";
  if (c.cluster_min_points < 1 || c.cluster_max_points < c.cluster_min_points)
    return "need 1 <= cluster_min_points <= cluster_max_points";
  if (c.object_hint_m && !c.object_hint_m->allFinite()) return "object hint must be finite";
  return {};
}

SegmentationResult ObjectSegmenter::segment(const std::vector<Vector3>& world_points) const {
  SegmentationResult result;
  const Config& c = config_;
  const std::string invalid = validate(c);
  if (!invalid.empty()) {
    result.message = "invalid segmentation config: " + invalid;
    return result;
  }
  result.stats.input = world_points.size();
  Cloud::Ptr cloud(new Cloud);
  cloud->reserve(world_points.size());
  for (const auto& p : world_points)
    if (p.allFinite()) cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  result.stats.finite = cloud->size();
  if (cloud->empty()) {
    result.message = world_points.empty() ? "empty cloud" : "cloud has no finite point";
    return result;
  }

  Cloud::Ptr cropped(new Cloud);
  pcl::CropBox<pcl::PointXYZ> crop;
  crop.setMin(Eigen::Vector4f(c.crop_min_m.x(), c.crop_min_m.y(), c.crop_min_m.z(), 1.0f));
  crop.setMax(Eigen::Vector4f(c.crop_max_m.x(), c.crop_max_m.y(), c.crop_max_m.z(), 1.0f));
  crop.setInputCloud(cloud);
  crop.filter(*cropped);
  result.stats.after_crop = cropped->size();
  if (cropped->empty()) {
    result.message = "no point inside the crop box";
    return result;
  }

  Cloud::Ptr downsampled = cropped;
  if (c.voxel_leaf_m > 0.0) {
    downsampled.reset(new Cloud);
    pcl::VoxelGrid<pcl::PointXYZ> voxel;
    const float leaf = static_cast<float>(c.voxel_leaf_m);
    voxel.setLeafSize(leaf, leaf, leaf);
    voxel.setInputCloud(cropped);
    voxel.filter(*downsampled);
  }
  result.stats.after_voxel = downsampled->size();

  Cloud::Ptr without_plane = downsampled;
  if (c.remove_plane && downsampled->size() >= 3) {
    pcl::SACSegmentation<pcl::PointXYZ> sac;
    sac.setOptimizeCoefficients(true);
    sac.setModelType(pcl::SACMODEL_PERPENDICULAR_PLANE);
    sac.setAxis(Eigen::Vector3f::UnitZ());
    sac.setEpsAngle(c.plane_max_tilt_deg * M_PI / 180.0);
    sac.setMethodType(pcl::SAC_RANSAC);
    sac.setDistanceThreshold(c.plane_distance_m);
    sac.setMaxIterations(c.plane_max_iterations);
    sac.setInputCloud(downsampled);
    pcl::PointIndices::Ptr inliers(new pcl::PointIndices);
    pcl::ModelCoefficients coefficients;
    sac.segment(*inliers, coefficients);
    result.stats.plane_inliers = inliers->indices.size();
    if (inliers->indices.size() >= c.plane_min_inliers && coefficients.values.size() == 4) {
      Vector3 n(coefficients.values[0], coefficients.values[1], coefficients.values[2]);
      double d = coefficients.values[3];
      if (n.z() < 0.0) {
        n = -n;
        d = -d;
      }
      const double norm = n.norm();
      n /= norm;
      d /= norm;
      // The inliers' footprint in the plane. A table's own side faces, seen at its edge, lie
      // below it but project onto the footprint's border: they do not count against it. What
      // lies below it elsewhere (an object under a flat face of its own) does.
      // Box axes: the world's x (else y) projected onto the plane, so that a table aligned with
      // the world has its sides on the box's border whatever the fitted normal's small tilt (an
      // arbitrary orthogonal, e.g. Eigen's unitOrthogonal, turns with the tilt's direction).
      Vector3 u = Vector3::UnitX() - n.x() * n;
      if (u.norm() < 0.5) u = Vector3::UnitY() - n.y() * n;
      u.normalize();
      const Vector3 v = n.cross(u);
      Eigen::AlignedBox2d footprint;
      for (int index : inliers->indices) {
        const auto& p = downsampled->points[static_cast<std::size_t>(index)];
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
      Cloud::Ptr above(new Cloud);
      std::size_t below = 0, below_on_border = 0;
      for (const auto& p : downsampled->points) {
        const Vector3 x(p.x, p.y, p.z);
        const double height = n.dot(x) + d;
        if (height > c.plane_distance_m) above->push_back(p);
        else if (height < -c.plane_distance_m) ++(onBorder(x) ? below_on_border : below);
      }
      // A support plane has (almost) nothing under it. A horizontal face of the object itself,
      // e.g. a mug's rim in an object-only cloud, has the object below: keep everything then.
      // Nor is a plane with nothing on it and faces hanging from its border: the top of a box
      // seen alone has its sides there, as a table has its own. (A bare plane is an empty table:
      // removed, it leaves nothing, which is the error to report.)
      const bool box_top = above->size() < c.cluster_min_points && below_on_border > 0;
      if (!box_top &&
          static_cast<double>(below) <= c.plane_max_fraction_below * static_cast<double>(downsampled->size())) {
        result.plane_found = true;
        result.plane_normal = n;
        result.plane_offset = d;
        without_plane = above;
      }
    }
  }
  result.stats.after_plane = without_plane->size();
  if (without_plane->empty()) {
    result.message = "nothing left above the support plane";
    return result;
  }

  Cloud::Ptr filtered = without_plane;
  if (c.outlier_mean_k > 0 && without_plane->size() > static_cast<std::size_t>(c.outlier_mean_k)) {
    filtered.reset(new Cloud);
    pcl::StatisticalOutlierRemoval<pcl::PointXYZ> sor;
    sor.setMeanK(c.outlier_mean_k);
    sor.setStddevMulThresh(c.outlier_stddev_multiplier);
    sor.setInputCloud(without_plane);
    sor.filter(*filtered);
  }
  result.stats.after_outliers = filtered->size();

  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
  tree->setInputCloud(filtered);
  std::vector<pcl::PointIndices> clusters;
  pcl::EuclideanClusterExtraction<pcl::PointXYZ> extraction;
  extraction.setClusterTolerance(c.cluster_tolerance_m);
  extraction.setMinClusterSize(static_cast<int>(c.cluster_min_points));
  extraction.setMaxClusterSize(static_cast<int>(std::min<std::size_t>(c.cluster_max_points, std::numeric_limits<int>::max())));
  extraction.setSearchMethod(tree);
  extraction.setInputCloud(filtered);
  extraction.extract(clusters);
  result.stats.clusters = clusters.size();
  if (clusters.empty()) {
    std::ostringstream msg;
    msg << "no object cluster: " << filtered->size() << " points left after filtering, none in a cluster of at least "
        << c.cluster_min_points << " points within " << c.cluster_tolerance_m << " m";
    result.message = msg.str();
    return result;
  }

  std::size_t best = 0;
  double best_score = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < clusters.size(); ++i) {
    double score = static_cast<double>(clusters[i].indices.size());
    if (c.object_hint_m) {
      Vector3 centroid = Vector3::Zero();
      for (int idx : clusters[i].indices) {
        const auto& p = filtered->points[static_cast<std::size_t>(idx)];
        centroid += Vector3(p.x, p.y, p.z);
      }
      centroid /= static_cast<double>(clusters[i].indices.size());
      score = -(centroid - *c.object_hint_m).norm();
    }
    if (score > best_score) {
      best_score = score;
      best = i;
    }
  }
  for (int idx : clusters[best].indices) {
    const auto& p = filtered->points[static_cast<std::size_t>(idx)];
    result.object_points.emplace_back(p.x, p.y, p.z);
  }
  result.stats.object = result.object_points.size();
  result.ok = true;
  std::ostringstream msg;
  msg << "object: " << result.stats.object << " points (cluster " << best + 1 << " of " << clusters.size() << ")";
  result.message = msg.str();
  return result;
}

}  // namespace gpatlas_geometry
