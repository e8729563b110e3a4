#include "gpatlas_ros/shared_models.h"

#include "gpatlas_conversions/conversions.h"

#include <utility>

#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace gpatlas_ros {

using namespace gpatlas_conversions;

void releaseFreedMemory() {
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}

std::shared_ptr<const gpatlas_core::SurfaceModel> modelSnapshot(std::unique_ptr<gpatlas_core::SurfaceModel> model) {
  return std::shared_ptr<const gpatlas_core::SurfaceModel>(model.release(), [](const gpatlas_core::SurfaceModel* m) {
    delete m;
    releaseFreedMemory();
  });
}

ModelSource modelForTrainingSet(const std::string& topic, const gpatlas_msgs::TrainingSet& training,
                                const gpatlas_core::SurfaceModelConfig& config,
                                std::shared_ptr<const gpatlas_core::SurfaceModel>* model, std::string* error) {
  if (auto snapshot = SharedModels::find(topic, training)) {
    *model = std::move(snapshot);
    return ModelSource::kShared;
  }
  if (SharedModels::superseded(topic, training)) return ModelSource::kSuperseded;
  std::unique_ptr<gpatlas_core::SurfaceModel> rebuilt;
  if (!modelFromMsg(training, config, &rebuilt, error)) return ModelSource::kFailed;
  *model = std::move(rebuilt);
  return ModelSource::kRefitted;
}

}  // namespace gpatlas_ros
