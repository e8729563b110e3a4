#include "gpatlas_ros/shared_models.h"

#include "gpatlas_conversions/conversions.h"

#include <utility>

namespace gpatlas_ros {

using namespace gpatlas_conversions;

bool modelForTrainingSet(const std::string& topic, const gpatlas_msgs::TrainingSet& training,
                         const gpatlas_core::SurfaceModelConfig& config,
                         std::shared_ptr<const gpatlas_core::SurfaceModel>* model, std::string* error, bool* shared) {
  auto snapshot = SharedModels::find(topic, training);
  if (shared) *shared = snapshot != nullptr;
  if (snapshot) {
    *model = std::move(snapshot);
    return true;
  }
  std::unique_ptr<gpatlas_core::SurfaceModel> rebuilt;
  if (!modelFromMsg(training, config, &rebuilt, error)) return false;
  *model = std::move(rebuilt);
  return true;
}

}  // namespace gpatlas_ros
