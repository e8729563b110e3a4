#pragma once

#include <gpatlas_core/model/surface_model.h>
#include <gpatlas_core/model/surface_model_factory.h>
#include <gpatlas_msgs/TrainingSet.h>

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

namespace octomap {
class OcTree;
}

namespace gpatlas_ros {

// What a nodelet derives from a training set, shared with the nodelets of its process under
// the training set's topic, sequence number and stamp (sequence and stamp together: a GP nodelet
// loaded again counts its sequence from the start). The last few of each topic are kept.
template <typename T>
class SharedSnapshots {
 public:
  // Says that a nodelet of this process will offer snapshots of the topic (before the first),
  // so that a user knows to wait for them.
  static void attend(const std::string& topic) {
    std::lock_guard<std::mutex> lock(mutex());
    registry()[topic];
  }
  // `snapshot` may be null: there is none for this training set (its build failed). Offered
  // again for the same training set, it replaces the one offered before.
  static void offer(const std::string& topic, const gpatlas_msgs::TrainingSet& training,
                    std::shared_ptr<const T> snapshot) {
    std::lock_guard<std::mutex> lock(mutex());
    std::deque<Entry>& kept = registry()[topic];
    // A newer snapshot of the same training set (the collision map after a camera cloud)
    // replaces the one before.
    for (Entry& e : kept)
      if (e.sequence == training.sequence && e.stamp == training.header.stamp) {
        e.snapshot = std::move(snapshot);
        return;
      }
    kept.push_back(Entry{training.sequence, training.header.stamp, std::move(snapshot)});
    while (kept.size() > kPerTopic) kept.pop_front();
  }
  // The snapshot of the training set on this topic; null when none was offered (another
  // process, not built yet, no longer kept, or offered as null). `offered`, when given, says
  // whether one was offered for it, null or not.
  static std::shared_ptr<const T> find(const std::string& topic, const gpatlas_msgs::TrainingSet& training,
                                       bool* offered = nullptr) {
    return find(topic, training.sequence, training.header.stamp, offered);
  }
  static std::shared_ptr<const T> find(const std::string& topic, std::uint32_t sequence, const ros::Time& stamp,
                                       bool* offered = nullptr) {
    std::lock_guard<std::mutex> lock(mutex());
    if (offered) *offered = false;
    const auto it = registry().find(topic);
    if (it == registry().end()) return nullptr;
    for (const Entry& e : it->second)
      if (e.sequence == sequence && e.stamp == stamp) {
        if (offered) *offered = true;
        return e.snapshot;
      }
    return nullptr;
  }
  // Whether a nodelet of this process attends the topic (attend, offer; until withdraw).
  static bool attended(const std::string& topic) {
    std::lock_guard<std::mutex> lock(mutex());
    return registry().count(topic) > 0;
  }
  // Drops every snapshot of the topic (the offering nodelet going away).
  static void withdraw(const std::string& topic) {
    std::lock_guard<std::mutex> lock(mutex());
    registry().erase(topic);
  }

 private:
  struct Entry {
    std::uint32_t sequence{0};
    ros::Time stamp;
    std::shared_ptr<const T> snapshot;
  };
  // A user may still be on the previous training set when the next one is offered.
  static constexpr std::size_t kPerTopic = 2;
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static std::map<std::string, std::deque<Entry>>& registry() {
    static std::map<std::string, std::deque<Entry>> entries;
    return entries;
  }
};

// The GP nodelet's models. Every model goes out as a TrainingSet, from which a replica anywhere
// can be refitted (modelFromMsg); that refit costs as much as the GP's own fit, once per
// subscriber and per touch. Beside the message the GP nodelet leaves an immutable snapshot of
// the model here (offer before publishing), so that a planner or a collision map in the same
// nodelet manager takes the snapshot instead.
using SharedModels = SharedSnapshots<gpatlas_core::SurfaceModel>;
// The collision map nodelet's maps, for the planner nodelet's cheap reachability test.
using SharedCollisionMaps = SharedSnapshots<octomap::OcTree>;

// The model a received training set describes: the publisher's snapshot when it is in this
// process, otherwise a replica refitted from the message; `shared`, when given, says which.
bool modelForTrainingSet(const std::string& topic, const gpatlas_msgs::TrainingSet& training,
                         const gpatlas_core::SurfaceModelConfig& config,
                         std::shared_ptr<const gpatlas_core::SurfaceModel>* model, std::string* error,
                         bool* shared = nullptr);

}  // namespace gpatlas_ros
