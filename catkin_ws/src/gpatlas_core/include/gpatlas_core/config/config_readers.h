#pragma once

// The one reader of each Config. The YAML (config/pipeline.yaml) mirrors them: each reader reads
// its Config's section, and a test checks that the file sets every name the readers read and
// nothing else. The strategies' Configs have their readers beside them (readAtlasPlanner,
// readSurfaceSampler, readFrontier, readEvidence): a strategy reads its own settings when the
// registry makes it (strategy_registry.h), as a surface model does (readGpis, readMultiscale:
// surface_model_factory.h). A Config field no reader reads is a constant of its
// component's design (tests vary it), not a setting: a grid's cell count, a sampling fraction, a
// guess's noise. The nodelets read them from the ROS parameter server, gpatlas_bench from the
// file itself.

#include "gpatlas_core/planning/atlas_planner.h"
#include "gpatlas_core/planning/frontier_strategy.h"
#include "gpatlas_core/planning/strategy_registry.h"
#include "gpatlas_core/planning/surface_sampler.h"
#include "gpatlas_core/exploration/explorer.h"
#include "gpatlas_core/model/surface_model_factory.h"
#include "gpatlas_core/model/occupancy_grid.h"
#include "gpatlas_core/model/position_uncertainty.h"
#include "gpatlas_core/common/parameters.h"
#include "gpatlas_core/observations/surface_evidence.h"
#include "gpatlas_core/observations/view_training.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

// Frames and the run's seed, shared by every stage.
struct PipelineFrames {
  std::string world_frame{"world"};
  // The depth camera's optical frame in tf: the view's free space and occluded interior need
  // its origin ("" disables them).
  std::string sensor_frame{"camera_optical_frame"};
  double tf_timeout_s{0.5};
};

// The collision map's settings (paper section 4.1). Its obstacle threshold is the approach
// planner's (approach/occupied_probability), which plans on it.
struct CollisionMapConfig {
  OccupancyGridBuilder::Config grid;
};

// The exploration strategy and its plugins.
struct StrategyChoice {
  std::string name{"atlas_poke"};
  std::vector<std::string> libraries;  // shared libraries registering strategies of your own
};

void readFrames(ParamReader& r, PipelineFrames* c);
// The run's seed ("seed"): the view's subset and samples, the strategy and every plan.
std::uint64_t readSeed(ParamReader& r, std::uint64_t fallback = 0);
// model/type, and the settings of every registered model, each read by its factory
// (surface_model_factory.h, with readGpis and readMultiscale).
void readSurfaceModel(ParamReader& r, SurfaceModelConfig* c);
void readPositionCalibration(ParamReader& r, PositionCalibrationConfig* c);
void readViewTraining(ParamReader& r, ViewTrainingConfig* c);
// Whether the table found by segmentation is used (the view's below-support points, no guesses
// in it, the evidence rule's approach test).
bool readUseSupportPlane(ParamReader& r);
void readTouchObservations(ParamReader& r, TouchObservationConfig* c);
void readExplorer(ParamReader& r, Explorer::Config* c);
// The variance threshold V_max (exploration/v_max), for the loop (readExplorer) and for whoever
// else needs it alone (the planner's default, the displayed colour scale).
double readVMax(ParamReader& r, double fallback = Explorer::Config().v_max);
// The stop rule in metres (exploration/max_position_sd_m; off: V_max alone), likewise.
std::optional<double> readMaxPositionSd(ParamReader& r,
                                        std::optional<double> fallback = Explorer::Config().max_position_sd_m);
void readStrategyChoice(ParamReader& r, StrategyChoice* c);
void readCollisionMap(ParamReader& r, CollisionMapConfig* c);

}  // namespace gpatlas_core
