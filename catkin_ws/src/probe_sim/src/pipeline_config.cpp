#include "probe_sim/pipeline_config.h"

namespace probe_sim {

void readPipeline(gpatlas_core::ParamReader& r, PipelineConfig* c) {
  using namespace gpatlas_core;
  using gpatlas_geometry::readMesher;
  using gpatlas_geometry::readSegmenter;
  readFrames(r, &c->frames);
  c->seed = readSeed(r, c->seed);
  readSurfaceModel(r, &c->model);
  readPositionCalibration(r, &c->position_calibration);
  readViewTraining(r, &c->view);
  c->use_support_plane = readUseSupportPlane(r);
  readTouchObservations(r, &c->touch);
  readExplorer(r, &c->exploration);
  readStrategyChoice(r, &c->strategy_choice);
  readAtlasPlanner(r, &c->atlas);
  readSurfaceSampler(r, &c->sampler);
  readFrontier(r, &c->frontier);
  readMesher(r, &c->mesh);
  readCollisionMap(r, &c->collision_map);
  gpatlas_motion::readSceneMap(r, &c->scene_map);
  gpatlas_motion::readApproach(r, &c->approach);
  readSegmenter(r, &c->segmentation);
}

}  // namespace probe_sim
