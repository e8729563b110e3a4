#pragma once

#include <gpatlas_core/common/triangle_mesh.h>
#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_core/model/surface_model_factory.h>
#include <gpatlas_geometry/surface_mesher.h>
#include <gpatlas_msgs/TrainingSet.h>

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

namespace gpatlas_ros {

// Rebuilds the pipeline's model from a training set and measures it as the bench does
// (gpatlas_geometry::measureModel).
class TrainingSetMeasurer {
 public:
  TrainingSetMeasurer(gpatlas_core::SurfaceModelConfig model_config, gpatlas_geometry::SurfaceMesher::Config mesher_config)
      : model_config_(std::move(model_config)), mesher_config_(std::move(mesher_config)) {}

  // The object's true shape (simulation's ground_truth), for the shape error; empty: none.
  void setGroundTruth(gpatlas_core::TriangleMesh mesh) { ground_truth_ = std::move(mesh); }
  const gpatlas_core::TriangleMesh& groundTruth() const { return ground_truth_; }
  const gpatlas_core::SurfaceModelConfig& modelConfig() const { return model_config_; }
  const gpatlas_geometry::SurfaceMesher::Config& mesherConfig() const { return mesher_config_; }

  // Rebuilds the GP from a training set and measures it as the bench does: the largest variance
  // of a fixed surface sample and, with a ground truth, the shape error.
  // Returns the rebuilt model (null when the message gives none).
  std::unique_ptr<gpatlas_core::SurfaceModel> measure(const gpatlas_msgs::TrainingSet& training,
                                                      gpatlas_core::ExplorationRecord& record) const;
  void measureModel(const gpatlas_core::SurfaceModel& model, gpatlas_core::ExplorationRecord& record) const;

 private:
  gpatlas_core::SurfaceModelConfig model_config_;
  gpatlas_geometry::SurfaceMesher::Config mesher_config_;
  gpatlas_core::TriangleMesh ground_truth_;
};

// The models after the actions, measured off the loop's thread: a measurement refits the model
// and meshes it, which takes longer than an action, and the robot should not wait for a number
// only the report needs. The newest request wins; one still waiting when a newer one comes is
// skipped and counted.
class BackgroundMeasurements {
 public:
  // `measurement` must outlive this.
  explicit BackgroundMeasurements(const TrainingSetMeasurer& measurement) : measurement_(measurement) {}
  ~BackgroundMeasurements() { stop(); }

  void start();
  void request(int action_index, gpatlas_msgs::TrainingSet::ConstPtr training);
  // Waits for the measurement in progress and the one waiting, then copies every measurement
  // into the action's record; `metrics_every` is for the log.
  void mergeInto(gpatlas_core::ExplorationResult* result, std::optional<int> metrics_every);
  void stop();

 private:
  void measureLoop();
  void measureJob(const std::pair<int, gpatlas_msgs::TrainingSet::ConstPtr>& job);

  const TrainingSetMeasurer& measurement_;
  std::thread measurer_;  // measureLoop
  std::mutex measure_mutex_;
  std::condition_variable measure_wake_;
  std::optional<std::pair<int, gpatlas_msgs::TrainingSet::ConstPtr>> measure_pending_;
  bool measure_busy_{false};
  bool measure_stopping_{false};
  std::map<int, gpatlas_core::ExplorationRecord> measurements_;  // by action index
  int measurements_skipped_{0};
};

}  // namespace gpatlas_ros
