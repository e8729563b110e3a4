#pragma once

// The readers of the geometry package's Configs (config/pipeline.yaml's mesh/ and segmentation/).

#include "gpatlas_core/common/parameters.h"
#include "gpatlas_geometry/segmentation.h"
#include "gpatlas_geometry/surface_mesher.h"

namespace gpatlas_geometry {

void readMesher(gpatlas_core::ParamReader& r, SurfaceMesher::Config* c);
void readSegmenter(gpatlas_core::ParamReader& r, ObjectSegmenter::Config* c);

}  // namespace gpatlas_geometry
