#include "gpatlas_core/types.h"

namespace gpatlas_core {

const char* toString(PointSource source) {
  switch (source) {
    case PointSource::kVision: return "vision";
    case PointSource::kTouch: return "touch";
    case PointSource::kFreeSpace: return "free_space";
    case PointSource::kPseudo: return "pseudo";
  }
  return "unknown";
}

}  // namespace gpatlas_core
