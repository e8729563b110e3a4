#pragma once

// The readers of the motion package's Configs (config/pipeline.yaml's approach/ and
// collision_map/scene_*).

#include "gpatlas_motion/approach_config.h"
#include "gpatlas_motion/scene_map.h"

#include <gpatlas_core/common/parameters.h>

namespace gpatlas_motion {

void readApproach(gpatlas_core::ParamReader& r, ApproachConfig* c);
// The scene map's part of the collision map's section (its voxel is collision_map/resolution_m,
// gpatlas_core::readCollisionMap's).
void readSceneMap(gpatlas_core::ParamReader& r, SceneMapConfig* c);

}  // namespace gpatlas_motion
