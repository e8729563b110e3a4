#pragma once

#include <gpatlas_core/surface_model.h>
#include <gpatlas_core/surface_model_factory.h>
#include <gpatlas_msgs/TrainingSet.h>

#include <cstdint>
#include <memory>
#include <string>

namespace gpatlas_ros {

// The GP nodelet's models, shared with the nodelets of its process. Every model goes out as a
// TrainingSet, from which a replica anywhere can be refitted (modelFromMsg); that refit costs
// as much as the GP's own fit, once per subscriber and per touch. Beside the message the GP
// nodelet leaves an immutable snapshot of the model here, under the training set's topic,
// sequence number and stamp, so that a planner or a collision map in the same nodelet manager
// takes the snapshot instead. The last few snapshots of each topic are kept.
class SharedModels {
 public:
  // Call before publishing the training set, with its resolved topic.
  static void offer(const std::string& topic, const gpatlas_msgs::TrainingSet& training,
                    std::shared_ptr<const gpatlas_core::SurfaceModel> model);
  // The snapshot the training set on this topic came from; null when it was published by
  // another process, or is no longer kept.
  static std::shared_ptr<const gpatlas_core::SurfaceModel> find(const std::string& topic,
                                                                const gpatlas_msgs::TrainingSet& training);
  // Drops every snapshot of the topic (a GP nodelet going away).
  static void withdraw(const std::string& topic);
};

// The model a received training set describes: the publisher's snapshot when it is in this
// process, otherwise a replica refitted from the message; `shared`, when given, says which.
bool modelForTrainingSet(const std::string& topic, const gpatlas_msgs::TrainingSet& training,
                         const gpatlas_core::SurfaceModelConfig& config,
                         std::shared_ptr<const gpatlas_core::SurfaceModel>* model, std::string* error,
                         bool* shared = nullptr);

}  // namespace gpatlas_ros
