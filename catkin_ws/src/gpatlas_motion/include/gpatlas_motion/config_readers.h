#pragma once

// The reader of the motion package's Config (config/pipeline.yaml's approach/).

#include "gpatlas_motion/approach_config.h"

#include <gpatlas_core/config/parameters.h>

namespace gpatlas_motion {

void readApproach(gpatlas_core::ParamReader& r, ApproachConfig* c);

}  // namespace gpatlas_motion
