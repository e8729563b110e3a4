#include "gpatlas_ros/shared_models.h"

#include "gpatlas_conversions/conversions.h"

#include <deque>
#include <map>
#include <mutex>
#include <utility>

namespace gpatlas_ros {
namespace {

struct Snapshot {
  std::uint32_t sequence{0};
  ros::Time stamp;
  std::shared_ptr<const gpatlas_core::SurfaceModel> model;
};

// A subscriber may still be on the previous training set when the next one is offered.
constexpr std::size_t kSnapshotsPerTopic = 2;

std::mutex& registryMutex() {
  static std::mutex mutex;
  return mutex;
}

std::map<std::string, std::deque<Snapshot>>& registry() {
  static std::map<std::string, std::deque<Snapshot>> snapshots;
  return snapshots;
}

}  // namespace

void SharedModels::offer(const std::string& topic, const gpatlas_msgs::TrainingSet& training,
                         std::shared_ptr<const gpatlas_core::SurfaceModel> model) {
  std::lock_guard<std::mutex> lock(registryMutex());
  std::deque<Snapshot>& kept = registry()[topic];
  kept.push_back(Snapshot{training.sequence, training.header.stamp, std::move(model)});
  while (kept.size() > kSnapshotsPerTopic) kept.pop_front();
}

std::shared_ptr<const gpatlas_core::SurfaceModel> SharedModels::find(const std::string& topic,
                                                                     const gpatlas_msgs::TrainingSet& training) {
  std::lock_guard<std::mutex> lock(registryMutex());
  const auto it = registry().find(topic);
  if (it == registry().end()) return nullptr;
  // Sequence and stamp together: a GP nodelet loaded again counts its sequence from the start.
  for (const Snapshot& s : it->second)
    if (s.sequence == training.sequence && s.stamp == training.header.stamp) return s.model;
  return nullptr;
}

void SharedModels::withdraw(const std::string& topic) {
  std::lock_guard<std::mutex> lock(registryMutex());
  registry().erase(topic);
}

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
