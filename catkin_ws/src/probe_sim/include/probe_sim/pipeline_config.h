#pragma once

#include "gpatlas_core/config/config_readers.h"
#include "gpatlas_geometry/config_readers.h"
#include "gpatlas_motion/config_readers.h"

#include <cstdint>

namespace probe_sim {

// Every section of config/pipeline.yaml that the pipeline reads.
struct PipelineConfig {
  gpatlas_core::PipelineFrames frames;
  std::uint64_t seed{0};
  gpatlas_core::SurfaceModelConfig model;
  gpatlas_core::PositionCalibrationConfig position_calibration;
  gpatlas_core::ViewTrainingConfig view;
  bool use_support_plane{true};
  gpatlas_core::TouchObservationConfig touch;
  gpatlas_core::Explorer::Config exploration;
  gpatlas_core::StrategyChoice strategy_choice;
  // The built-in strategies' settings (planner/, score/, evidence/; planner/surface_samples;
  // frontier/), read here to check the file: a strategy reads its own from the same keys when a
  // run makes it (gpatlas_core::makeStrategy), and none is handed on.
  gpatlas_core::AtlasPlanner::Config atlas;
  gpatlas_core::SurfaceSampler::Config sampler;
  gpatlas_core::FrontierStrategy::Config frontier;
  gpatlas_geometry::SurfaceMesher::Config mesh;
  gpatlas_core::CollisionMapConfig collision_map;
  gpatlas_motion::SceneMapConfig scene_map;  // collision_map/scene_*: the camera's scene in the collision map, the bench's too
  gpatlas_motion::ApproachConfig approach;
  gpatlas_geometry::ObjectSegmenter::Config segmentation;
};
void readPipeline(gpatlas_core::ParamReader& r, PipelineConfig* c);

}  // namespace probe_sim
