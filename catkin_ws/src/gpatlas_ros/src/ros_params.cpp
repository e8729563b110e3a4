#include "gpatlas_ros/ros_params.h"

#include <ros/console.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace gpatlas_ros {

void ParamReader::invalid(const std::string& name, const std::string& why) {
  errors_.push_back(nh_.resolveName(name) + ": " + why);
}

bool ParamReader::present(const std::string& name) {
  if (nh_.hasParam(name)) return true;
  defaulted_.push_back(name);
  return false;
}

std::string ParamReader::defaulted() const {
  std::ostringstream out;
  for (std::size_t i = 0; i < defaulted_.size(); ++i) out << (i ? ", " : "") << defaulted_[i];
  return out.str();
}

void ParamReader::report(const std::string& who) const {
  if (!errors_.empty()) ROS_ERROR_STREAM(who << ": invalid parameters, defaults used instead: " << errors());
  if (!defaulted_.empty()) ROS_INFO_STREAM(who << ": parameters not set in " << nh_.getNamespace() << ", defaults used: " << defaulted());
}

std::string ParamReader::errors() const {
  std::ostringstream out;
  for (std::size_t i = 0; i < errors_.size(); ++i) out << (i ? "; " : "") << errors_[i];
  return out.str();
}

double ParamReader::number(const std::string& name, double fallback, double min, double max) {
  double value = fallback;
  if (present(name) && !nh_.getParam(name, value)) {
    int as_int = 0;
    if (nh_.getParam(name, as_int)) value = as_int;
    else {
      invalid(name, "is not a number");
      return fallback;
    }
  }
  if (!std::isfinite(value) || value < min || value > max) {
    std::ostringstream why;
    why << "= " << value << " is outside [" << min << ", " << max << "]";
    invalid(name, why.str());
    return fallback;
  }
  ROS_DEBUG_STREAM(nh_.resolveName(name) << " = " << value);
  return value;
}

int ParamReader::integer(const std::string& name, int fallback, int min, int max) {
  int value = fallback;
  if (present(name) && !nh_.getParam(name, value)) {
    invalid(name, "is not an integer");
    return fallback;
  }
  if (value < min || value > max) {
    invalid(name, "= " + std::to_string(value) + " is outside [" + std::to_string(min) + ", " + std::to_string(max) + "]");
    return fallback;
  }
  return value;
}

bool ParamReader::flag(const std::string& name, bool fallback) {
  bool value = fallback;
  if (present(name) && !nh_.getParam(name, value)) invalid(name, "is not a boolean");
  return value;
}

std::string ParamReader::text(const std::string& name, const std::string& fallback) {
  std::string value = fallback;
  if (present(name) && !nh_.getParam(name, value)) invalid(name, "is not a string");
  return value;
}

std::vector<std::string> ParamReader::texts(const std::string& name, const std::vector<std::string>& fallback) {
  if (!present(name)) return fallback;
  std::vector<std::string> value;
  if (nh_.getParam(name, value)) return value;
  std::string single;  // one item given without the list's brackets
  if (nh_.getParam(name, single)) return {single};
  invalid(name, "is not a list of strings");
  return fallback;
}

Eigen::Vector3d ParamReader::vector3(const std::string& name, const Eigen::Vector3d& fallback) {
  if (!present(name)) return fallback;
  std::vector<double> values;
  if (!nh_.getParam(name, values) || values.size() != 3) {
    invalid(name, "must be a list of 3 numbers");
    return fallback;
  }
  const Eigen::Vector3d v(values[0], values[1], values[2]);
  if (!v.allFinite()) {
    invalid(name, "must be finite");
    return fallback;
  }
  return v;
}

void readGpis(ParamReader& r, gpatlas_core::GpisModel::Config* c) {
  c->kernel = r.text("gpis/kernel", c->kernel);
  // Their ordering (data < renormalise <= domain) and the kernel's range are checked by the model.
  c->data_radius = r.number("gpis/data_radius", c->data_radius, 1e-3, 100.0);
  c->renormalise_radius = r.number("gpis/renormalise_radius", c->renormalise_radius, 1e-3, 100.0);
  c->domain_radius = r.number("gpis/domain_radius", c->domain_radius, 1e-3, 100.0);
  c->num_outside_points = r.integer("gpis/num_outside_points", c->num_outside_points, 0, 10000);
  c->inside_point_at_centroid = r.flag("gpis/inside_point_at_centroid", c->inside_point_at_centroid);
  c->inside_point_min_clearance =
      r.number("gpis/inside_point_min_clearance", c->inside_point_min_clearance, 0.0, 100.0);
  c->noise_in_reported_units = r.flag("gpis/noise_in_reported_units", c->noise_in_reported_units);
  c->pseudo_point_sigma = r.number("gpis/pseudo_point_sigma", c->pseudo_point_sigma, 0.0, 10.0);
  c->reference_prior_variance = r.number("gpis/reference_prior_variance", c->reference_prior_variance, 1e-9, 1e9);
  // The model checks what no single parameter can (kernel name, radii ordering, the kernel's
  // valid range): every node falls back to the same defaults, so replicas stay exact.
  try {
    gpatlas_core::GpisModel check(*c);
  } catch (const std::exception& e) {
    r.invalid("gpis", std::string(e.what()) + " (all gpis/ defaults used)");
    *c = gpatlas_core::GpisModel::Config();
  }
}

void readNoise(ParamReader& r, ObservationNoise* n) {
  n->vision_sigma = r.number("gpis/vision_noise_sigma", n->vision_sigma, 0.0, 10.0);
  n->touch_sigma = r.number("gpis/touch_noise_sigma", n->touch_sigma, 0.0, 10.0);
  n->free_space_sigma = r.number("gpis/free_space_noise_sigma", n->free_space_sigma, 0.0, 10.0);
}

void readTuner(ParamReader& r, gpatlas_core::HyperparameterTuner::Config* c) {
  c->max_iterations = r.integer("tuning/max_iterations", c->max_iterations, 1, 10000);
  c->tune_noise = r.flag("tuning/tune_noise", c->tune_noise);
}

void readStrategy(ParamReader& r, gpatlas_core::StrategyConfig* c) {
  auto& chart = c->atlas.chart;
  chart.rho_gain = r.number("planner/rho_gain", chart.rho_gain, 1e-9, 10.0);
  chart.rho_min_m = r.number("planner/rho_min_m", chart.rho_min_m, 1e-5, 1.0);
  chart.rho_max_m = r.number("planner/rho_max_m", chart.rho_max_m, 1e-5, 1.0);
  chart.candidate_density = r.number("planner/candidate_density", chart.candidate_density, 1.0, 1000.0);
  c->atlas.depth_first_probability =
      r.number("planner/depth_first_probability", c->atlas.depth_first_probability, 0.0, 1.0);
  c->atlas.max_charts = r.integer("planner/max_charts", c->atlas.max_charts, 1, 1000000);
  c->atlas.max_time_s = r.number("planner/max_time_s", c->atlas.max_time_s, 1e-3, 3600.0);
  c->atlas.max_start_distance_m = r.number("planner/max_start_distance_m", c->atlas.max_start_distance_m, 0.0, 10.0);
  c->slide_extension_charts = r.integer("planner/slide_extension_charts", c->slide_extension_charts, 0, 100);
  c->atlas.keep_high_variance_candidates =
      r.flag("planner/keep_high_variance_candidates", c->atlas.keep_high_variance_candidates);
  c->sampler.num_seeds = r.integer("planner/surface_samples", c->sampler.num_seeds, 1, 1000000);
  c->seed = static_cast<std::uint64_t>(r.integer("planner/seed", static_cast<int>(c->seed), 0, 1 << 30));
  c->atlas.seed = c->seed;
  c->sampler.seed = c->seed;
}

void readMesher(ParamReader& r, gpatlas_core::SurfaceMesher::Config* c) {
  c->resolution_m = r.number("mesh/resolution_m", c->resolution_m, 1e-4, 1.0);
}

void readOccupancy(ParamReader& r, gpatlas_core::OccupancyGridBuilder::Config* c) {
  c->resolution_m = r.number("collision_map/resolution_m", c->resolution_m, 1e-3, 1.0);
}

void readViewFreeSpace(ParamReader& r, gpatlas_core::ViewFreeSpaceConfig* c, std::string* sensor_frame) {
  *sensor_frame = r.text("view_free_space/sensor_frame", *sensor_frame);
  c->max_rays = r.integer("view_free_space/max_rays", c->max_rays, 0, 5000);
  c->samples_per_ray = r.integer("view_free_space/samples_per_ray", c->samples_per_ray, 0, 10);
  c->min_offset_fraction = r.number("view_free_space/min_offset_fraction", c->min_offset_fraction, 1e-6, 10.0);
  c->max_offset_fraction = r.number("view_free_space/max_offset_fraction", c->max_offset_fraction, 1e-6, 10.0);
  if (c->max_offset_fraction < c->min_offset_fraction) {
    r.invalid("view_free_space/max_offset_fraction", "must be >= min_offset_fraction (both defaults used)");
    const gpatlas_core::ViewFreeSpaceConfig defaults;
    c->min_offset_fraction = defaults.min_offset_fraction;
    c->max_offset_fraction = defaults.max_offset_fraction;
  }
}

void readOccludedInterior(ParamReader& r, gpatlas_core::OccludedInteriorConfig* c) {
  c->max_points = r.integer("occluded_interior/max_points", c->max_points, 0, 2000);
  c->grid_cells = r.integer("occluded_interior/grid_cells", c->grid_cells, 2, 40);
  c->margin_fraction = r.number("occluded_interior/margin_fraction", c->margin_fraction, 0.0, 1.0);
  c->noise_sigma = r.number("occluded_interior/noise_sigma", c->noise_sigma, 1e-3, 100.0);
}

void readSupportPlane(ParamReader& r, bool* enabled, double* clearance_m, gpatlas_core::BelowSupportConfig* c) {
  *enabled = r.flag("support_plane/enabled", *enabled);
  *clearance_m = r.number("support_plane/clearance_m", *clearance_m, 0.0, 0.5);
  c->grid_cells = r.integer("support_plane/grid_cells", c->grid_cells, 1, 40);
  c->footprint_margin_fraction =
      r.number("support_plane/footprint_margin_fraction", c->footprint_margin_fraction, 0.0, 5.0);
}

void readSegmenter(ParamReader& r, gpatlas_core::ObjectSegmenter::Config* c) {
  c->crop_min_m = r.vector3("segmentation/crop_min_m", c->crop_min_m);
  c->crop_max_m = r.vector3("segmentation/crop_max_m", c->crop_max_m);
  c->voxel_leaf_m = r.number("segmentation/voxel_leaf_m", c->voxel_leaf_m, 0.0, 1.0);
  c->remove_plane = r.flag("segmentation/remove_plane", c->remove_plane);
  c->plane_distance_m = r.number("segmentation/plane_distance_m", c->plane_distance_m, 1e-5, 1.0);
  c->plane_max_tilt_deg = r.number("segmentation/plane_max_tilt_deg", c->plane_max_tilt_deg, 0.1, 90.0);
  c->plane_max_fraction_below =
      r.number("segmentation/plane_max_fraction_below", c->plane_max_fraction_below, 0.0, 1.0);
  c->plane_min_inliers = static_cast<std::size_t>(
      r.integer("segmentation/plane_min_inliers", static_cast<int>(c->plane_min_inliers), 1, 100000000));
  c->outlier_mean_k = r.integer("segmentation/outlier_mean_k", c->outlier_mean_k, 0, 1000);
  c->outlier_stddev_multiplier =
      r.number("segmentation/outlier_stddev_multiplier", c->outlier_stddev_multiplier, 1e-3, 100.0);
  c->cluster_tolerance_m = r.number("segmentation/cluster_tolerance_m", c->cluster_tolerance_m, 1e-5, 1.0);
  c->cluster_min_points = static_cast<std::size_t>(
      r.integer("segmentation/cluster_min_points", static_cast<int>(c->cluster_min_points), 1, 100000000));
  if (r.flag("segmentation/use_object_hint", false))
    c->object_hint_m = r.vector3("segmentation/object_hint_m", Eigen::Vector3d(0.7, 0.0, 0.1));
}

}  // namespace gpatlas_ros
