#pragma once

#include <gpatlas_core/model/surface_model.h>
#include <gpatlas_core/model/surface_model_factory.h>
#include <gpatlas_msgs/TrainingSet.h>

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <vector>
#include <string>
#include <utility>

namespace octomap {
class OcTree;
}

namespace gpatlas_ros {

// What a nodelet derives from a training set, shared with the nodelets of its process under
// the training set's topic, sequence number and stamp (sequence and stamp together: a GP nodelet
// loaded again counts its sequence from the start). The newest kHeld of each topic are held; the
// few before them stay findable only while a user still holds them: a snapshot can be as large
// as a whole model, and the registry must not be what keeps a superseded one in memory.
template <typename T, std::size_t kHeld>
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
    // What the registry lets go is freed after the lock: freeing a model, and giving its memory
    // back, takes milliseconds that every find() would wait for.
    std::vector<std::shared_ptr<const T>> released;
    std::lock_guard<std::mutex> lock(mutex());
    std::deque<Entry>& kept = registry()[topic];
    // A newer snapshot of the same training set (the collision map after a camera cloud)
    // replaces the one before.
    for (std::size_t i = 0; i < kept.size(); ++i)
      if (Entry& e = kept[i]; e.sequence == training.sequence && e.stamp == training.header.stamp) {
        released.push_back(std::move(e.held));
        e.held = kept.size() - i <= kHeld ? snapshot : nullptr;  // only the newest kHeld are held
        e.watched = snapshot;
        e.offered_null = snapshot == nullptr;
        return;
      }
    kept.push_back(Entry{training.sequence, training.header.stamp, snapshot, snapshot, snapshot == nullptr});
    for (; kept.size() > kPerTopic; kept.pop_front()) released.push_back(std::move(kept.front().held));
    if (kept.size() > kHeld) released.push_back(std::move(kept[kept.size() - kHeld - 1].held));
  }
  // The snapshot of the training set on this topic; null when none was offered (another
  // process, not built yet, no longer kept, or offered as null). `offered`, when given, says
  // whether one was offered for it and is still kept, null or not.
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
        std::shared_ptr<const T> snapshot = e.held ? e.held : e.watched.lock();
        if (offered) *offered = snapshot != nullptr || e.offered_null;
        return snapshot;
      }
    return nullptr;
  }
  // Whether a newer training set than this one has been offered on the topic: its message is on
  // the way, so a user that missed this one's snapshot can wait for it instead of rebuilding.
  static bool superseded(const std::string& topic, const gpatlas_msgs::TrainingSet& training) {
    std::lock_guard<std::mutex> lock(mutex());
    const auto it = registry().find(topic);
    if (it == registry().end()) return false;
    for (const Entry& e : it->second)
      if (e.sequence > training.sequence && e.stamp >= training.header.stamp) return true;
    return false;
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
    std::shared_ptr<const T> held;   // the newest kHeld only
    std::weak_ptr<const T> watched;  // every kept one, while some user holds it
    bool offered_null{false};
  };
  // A user may still be on an earlier training set when the next ones are offered.
  static constexpr std::size_t kPerTopic = 4;
  static_assert(kHeld >= 1 && kHeld <= kPerTopic, "the newest snapshot is held");
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
// nodelet manager takes the snapshot instead. Only the newest is held: a model is tens to hundreds
// of MB, and the planner and the collision map hold the one they use themselves.
using SharedModels = SharedSnapshots<gpatlas_core::SurfaceModel, 1>;
// The collision map nodelet's maps, for the planner nodelet's cheap reachability test (the
// planner may ask for the map of the model before the newest).
using SharedCollisionMaps = SharedSnapshots<octomap::OcTree, 2>;

// Gives the free pages of the process's heap back to the system (glibc's malloc_trim). glibc
// keeps freed memory for reuse and returns only the top of a heap on its own: a model of tens
// to hundreds of MB freed below live data (the next model, allocated meanwhile) stays resident.
void releaseFreedMemory();

// The GP nodelet's snapshot of a model: immutable, and its memory goes back to the system
// (releaseFreedMemory) as soon as its last user lets it go, in whichever thread that is.
std::shared_ptr<const gpatlas_core::SurfaceModel> modelSnapshot(std::unique_ptr<gpatlas_core::SurfaceModel> model);

// Where the model of a received training set came from.
enum class ModelSource {
  kShared,      // the publisher's snapshot, in this process
  kRefitted,    // a replica refitted from the message (the publisher is in another process)
  kSuperseded,  // none: its snapshot is gone and a newer training set was offered since (its
                // message follows; refitting this one would cost a whole fit for a stale model)
  kFailed,      // none: the message describes no model (`error` says why)
};

// The model a received training set describes (ModelSource says which kind, or why none).
ModelSource modelForTrainingSet(const std::string& topic, const gpatlas_msgs::TrainingSet& training,
                                const gpatlas_core::SurfaceModelConfig& config,
                                std::shared_ptr<const gpatlas_core::SurfaceModel>* model, std::string* error);

}  // namespace gpatlas_ros
