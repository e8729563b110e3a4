#include "gpatlas_core/config/config_readers.h"

#include <cmath>

namespace gpatlas_core {

namespace {
std::optional<std::size_t> optionalCount(ParamReader& r, const std::string& name, std::optional<std::size_t> fallback,
                                         int max) {
  const std::optional<int> value =
      r.optionalInteger(name, fallback ? std::optional<int>(static_cast<int>(*fallback)) : std::nullopt, max);
  return value ? std::optional<std::size_t>(static_cast<std::size_t>(*value)) : std::nullopt;
}
}  // namespace

void readFrames(ParamReader& r, PipelineFrames* c) {
  c->world_frame = r.text("world_frame", c->world_frame);
  if (c->world_frame.empty()) {
    r.invalid("world_frame", "must not be empty");
    c->world_frame = PipelineFrames().world_frame;
  }
  c->sensor_frame = r.text("sensor_frame", c->sensor_frame);
  c->tf_timeout_s = r.number("tf_timeout_s", c->tf_timeout_s, 0.0, 60.0);
}

std::uint64_t readSeed(ParamReader& r, std::uint64_t fallback) {
  return static_cast<std::uint64_t>(r.integer("seed", static_cast<int>(fallback), 0, 1 << 30));
}

void readSurfaceModel(ParamReader& r, SurfaceModelConfig* c) {
  c->type = r.text("model/type", c->type);
  // Checked when the model is built: a plugin library may register more names.
  if (c->type.empty()) {
    r.invalid("model/type", "must name a surface model");
    c->type = SurfaceModelConfig().type;
  }
  // Every registered model reads its settings now, not only model/type's: a replica is rebuilt
  // by the name its training set carries.
  for (const std::string& name : surfaceModelNames()) {
    try {
      c->makers[name] = surfaceModelMaker(name, r);
    } catch (const std::exception& e) {
      r.invalid(name, std::string("cannot read the surface model's settings: ") + e.what());
    }
  }
}

void readViewTraining(ParamReader& r, ViewTrainingConfig* c) {
  c->max_surface_points = r.integer("view/max_surface_points", c->max_surface_points, 4, 100000);
  c->vision_noise_sigma = r.number("view/vision_noise_sigma", c->vision_noise_sigma, 0.0, 10.0);
  ViewFreeSpaceConfig& free = c->free_space;
  free.max_rays = r.integer("view/free_space/max_rays", free.max_rays, 0, 100000);
  free.samples_per_ray = r.integer("view/free_space/samples_per_ray", free.samples_per_ray, 0, 10);
  NearSurfaceFreeSpaceConfig& near = c->near_surface_free_space;
  near.offset_m = r.number("view/near_surface_free_space/offset_m", near.offset_m, 1e-5, 0.1);
  near.max_points = r.integer("view/near_surface_free_space/max_points", near.max_points, 0, 1000000);
  OccludedInteriorConfig& inside = c->occluded_interior;
  inside.max_points = r.integer("view/occluded_interior/max_points", inside.max_points, 0, 100000);
  SupportFreeSpaceConfig& beside = c->support_free_space;
  // Beyond the fixed min_distance_m, where the band of table points begins.
  beside.max_distance_m = r.number("view/support_free_space/max_distance_m", beside.max_distance_m,
                                   std::nextafter(beside.min_distance_m, 1.0), 0.5);
  beside.max_points = r.integer("view/support_free_space/max_points", beside.max_points, 0, 1000000);
}

bool readUseSupportPlane(ParamReader& r) { return r.flag("use_support_plane", true); }

void readTouchObservations(ParamReader& r, TouchObservationConfig* c) {
  c->contact_noise_sigma = r.number("touch/contact_noise_sigma", c->contact_noise_sigma, 0.0, 10.0);
  c->free_space_noise_sigma = r.number("touch/free_space_noise_sigma", c->free_space_noise_sigma, 0.0, 10.0);
  c->min_point_spacing_m = r.number("touch/min_point_spacing_m", c->min_point_spacing_m, 0.0, 1.0);
  c->min_free_space_spacing_m = r.number("touch/min_free_space_spacing_m", c->min_free_space_spacing_m, 0.0, 1.0);
  c->contact_inside_depth_m = r.number("touch/contact_inside_depth_m", c->contact_inside_depth_m, 0.0, 0.1);
  c->contact_tangent_noise_sigma =
      r.optionalNumber("touch/contact_tangent_noise_sigma", c->contact_tangent_noise_sigma, 10.0);
  c->max_contacts_per_touch = optionalCount(r, "touch/max_contacts_per_touch", c->max_contacts_per_touch, 1000000);
  c->max_free_space_per_touch =
      optionalCount(r, "touch/max_free_space_per_touch", c->max_free_space_per_touch, 1000000);
  c->max_touch_observations = optionalCount(r, "touch/max_touch_observations", c->max_touch_observations, 10000000);
  c->gate.workspace_min_m = r.vector3("touch/gate/workspace_min_m", c->gate.workspace_min_m);
  c->gate.workspace_max_m = r.vector3("touch/gate/workspace_max_m", c->gate.workspace_max_m);
  c->gate.max_contact_distance_m =
      r.optionalNumber("touch/gate/max_contact_distance_m", c->gate.max_contact_distance_m, 100.0);
  c->gate.max_inconsistency_sigma =
      r.number("touch/gate/max_inconsistency_sigma", c->gate.max_inconsistency_sigma, 1e-3, 1e6);
}

void readPositionCalibration(ParamReader& r, PositionCalibrationConfig* c) {
  c->folds = r.integer("position_calibration/folds", c->folds, 0, 6);
  c->coverage = r.number("position_calibration/coverage", c->coverage, 0.01, 0.999);
  c->touches = r.flag("position_calibration/touches", c->touches);
}

double readVMax(ParamReader& r, double fallback) { return r.number("exploration/v_max", fallback, 1e-12, 1e12); }

std::optional<double> readMaxPositionSd(ParamReader& r, std::optional<double> fallback) {
  return r.optionalNumber("exploration/max_position_sd_m", fallback, 10.0);
}

void readExplorer(ParamReader& r, Explorer::Config* c) {
  c->v_max = readVMax(r, c->v_max);
  c->max_position_sd_m = readMaxPositionSd(r, c->max_position_sd_m);
  c->max_actions = r.integer("exploration/max_actions", c->max_actions, 0, 1000000);
  c->max_consecutive_failures = r.integer("exploration/max_consecutive_failures", c->max_consecutive_failures, 1, 1000000);
  c->max_approach_attempts = r.integer("exploration/max_approach_attempts", c->max_approach_attempts, 1, 1000);
  c->seed = readSeed(r, c->seed);
}

void readStrategyChoice(ParamReader& r, StrategyChoice* c) {
  c->name = r.text("strategy", c->name);
  c->libraries = r.texts("strategy_libraries", c->libraries);
}

void readCollisionMap(ParamReader& r, CollisionMapConfig* c) {
  c->grid.resolution_m = r.number("collision_map/resolution_m", c->grid.resolution_m, 1e-3, 1.0);
  c->grid.variance_stride = r.integer("collision_map/variance_stride", c->grid.variance_stride, 1, 16);
}

}  // namespace gpatlas_core
