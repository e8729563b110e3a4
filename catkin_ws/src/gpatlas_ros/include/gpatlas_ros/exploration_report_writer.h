#pragma once

#include <gpatlas_core/exploration/exploration_report.h>
#include <gpatlas_msgs/TrainingSet.h>
#include <gpatlas_ros/exploration_measurements.h>
#include <gpatlas_ros/timed_service_client.h>

#include <string>

namespace gpatlas_ros {

// The exploration's results folder: report.json, the final surface (surface.ply, with each
// vertex's variance and position sd), the truth when there is one (truth.ply), the collision
// map (collision_map.bt, from the save_map service when there is one) and the plots
// (scripts/plot_exploration.py), and the summary in the log.
class ExplorationReportWriter {
 public:
  // `results_dir` empty: ./results/exploration_DATE_TIME.
  ExplorationReportWriter(std::string results_dir, TimedServiceClient& client);
  const std::string& resultsDir() const { return results_dir_; }
  // Creates the folder; false (and logged) when it cannot.
  bool createFolder() const;
  // Completes `report` with the final model's shape and the run's status (from the newest
  // training set), writes the folder and logs the summary. Returns the node's exit code: 1
  // when the run ended in an error, otherwise 0.
  int write(gpatlas_core::ExplorationReport report, const gpatlas_msgs::TrainingSet::ConstPtr& final_training,
            const TrainingSetMeasurer& measurement);

 private:
  // The final model's surface, written to surface.ply and measured into report->final_shape
  // when there is a ground truth. Whether there is one; why not in *message.
  bool writeFinalSurface(const gpatlas_msgs::TrainingSet::ConstPtr& training, const TrainingSetMeasurer& measurement,
                         gpatlas_core::ExplorationReport* report, std::string* message) const;
  void saveCollisionMap();
  void plot() const;
  int logSummary(const gpatlas_core::ExplorationReport& report) const;

  std::string results_dir_;
  TimedServiceClient& client_;
};

}  // namespace gpatlas_ros
