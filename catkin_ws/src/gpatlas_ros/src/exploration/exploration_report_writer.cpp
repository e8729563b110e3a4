#include "gpatlas_ros/exploration_report_writer.h"

#include <gpatlas_conversions/conversions.h>
#include <gpatlas_geometry/model_measurement.h>
#include <gpatlas_geometry/shape_metrics.h>
#include <gpatlas_geometry/surface_mesher.h>
#include <gpatlas_msgs/SaveMap.h>

#include <ros/package.h>
#include <ros/ros.h>

#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <sstream>
#include <system_error>

namespace gpatlas_ros {

using namespace gpatlas_conversions;
namespace fs = std::filesystem;

ExplorationReportWriter::ExplorationReportWriter(std::string results_dir, TimedServiceClient& client)
    : results_dir_(std::move(results_dir)), client_(client) {
  if (results_dir_.empty()) {
    std::time_t now = std::time(nullptr);
    char stamp[32];
    std::strftime(stamp, sizeof(stamp), "%Y%m%d_%H%M%S", std::localtime(&now));
    results_dir_ = (fs::current_path() / "results" / (std::string("exploration_") + stamp)).string();
  }
}

bool ExplorationReportWriter::createFolder() const {
  std::error_code ec;
  fs::create_directories(results_dir_, ec);
  if (ec) ROS_ERROR_STREAM("exploration: cannot create " << results_dir_ << ": " << ec.message());
  return !ec;
}

int ExplorationReportWriter::write(gpatlas_core::ExplorationReport report,
                                   const gpatlas_msgs::TrainingSet::ConstPtr& final_training,
                                   const TrainingSetMeasurer& measurement) {
  std::string surface_message = "no model";
  const bool has_surface = writeFinalSurface(final_training, measurement, &report, &surface_message);
  report.status = gpatlas_core::runStatus(report.result, has_surface, surface_message);
  saveCollisionMap();
  std::ofstream json(fs::path(results_dir_) / "report.json");
  json << gpatlas_core::toJson(report);
  json.close();
  plot();
  return logSummary(report);
}

bool ExplorationReportWriter::writeFinalSurface(const gpatlas_msgs::TrainingSet::ConstPtr& training,
                                                const TrainingSetMeasurer& measurement,
                                                gpatlas_core::ExplorationReport* report, std::string* message) const {
  const fs::path dir(results_dir_);
  const gpatlas_core::TriangleMesh& ground_truth = measurement.groundTruth();
  // The truth beside the prediction in exploration.png.
  if (!ground_truth.empty()) {
    const std::string write_error = gpatlas_core::writePly(ground_truth, (dir / "truth.ply").string());
    if (!write_error.empty()) ROS_WARN_STREAM("exploration: " << write_error);
  }
  bool has_surface = false;
  if (training) {
    std::unique_ptr<gpatlas_core::SurfaceModel> model;
    if (modelFromMsg(*training, measurement.modelConfig(), &model, message)) {
      // The bench's final measurement, when there is a truth: the shape and the position sd.
      gpatlas_geometry::MeasurementRequest request;
      request.sampled_max_variance = false;
      request.calibration = true;
      request.vertex_variances = true;    // surface.ply is coloured by them
      request.vertex_position_sd = true;  // and exploration.png by these
      gpatlas_geometry::ModelMeasurement measured;
      if (!ground_truth.empty()) {
        measured = gpatlas_geometry::measureModel(*model, ground_truth, measurement.mesherConfig(), request);
      } else {
        gpatlas_geometry::SurfaceMesher::Config mesher = measurement.mesherConfig();
        mesher.vertex_variances = request.vertex_variances;
        mesher.vertex_position_sd = request.vertex_position_sd;
        measured.surface = gpatlas_geometry::SurfaceMesher(mesher).mesh(*model);
      }
      const gpatlas_geometry::SurfaceMeshResult& surface = measured.surface;
      *message = surface.message;
      has_surface = surface.ok;
      if (surface.ok) {
        const std::string write_error = gpatlas_core::writePly(surface.mesh, (dir / "surface.ply").string());
        if (!write_error.empty()) ROS_WARN_STREAM("exploration: " << write_error);
      }
      if (measured.shape.ok) {
        const gpatlas_geometry::ShapeMetricsResult& metrics = measured.shape;
        report->final_shape = {true, metrics.rmse_predicted_to_truth, metrics.rmse_truth_to_predicted,
                               metrics.chamfer_l1, metrics.f_score};
        if (measured.calibration.ok) {
          report->final_shape.coverage_2sd = measured.calibration.coverage;
          report->final_shape.sharpness = measured.calibration.sharpness;
          report->final_shape.position_sd_m = measured.calibration.median_position_sd_m;
        }
      }
    }
  }
  return has_surface;
}

void ExplorationReportWriter::saveCollisionMap() {
  gpatlas_msgs::SaveMap save;
  save.request.path = (fs::path(results_dir_) / "collision_map.bt").string();
  if (client_.isOffered("save_map") && client_.callOptional("save_map", save) && !save.response.success)
    ROS_WARN_STREAM("exploration: " << save.response.message);
}

void ExplorationReportWriter::plot() const {
  const std::string script = ros::package::getPath("gpatlas_ros") + "/scripts/plot_exploration.py";
  const std::string command = "/usr/bin/python3 \"" + script + "\" \"" + results_dir_ + "\" >/dev/null";
  if (std::system(command.c_str()) != 0) ROS_WARN_STREAM("exploration: plotting failed: " << command);
}

int ExplorationReportWriter::logSummary(const gpatlas_core::ExplorationReport& report) const {
  std::ostringstream summary;
  summary << "exploration finished: " << report.status << gpatlas_core::outOfReachNote(report.result) << " after "
          << report.result.actions << " actions (" << report.result.contacts << " contacts)";
  if (report.final_shape.measured)
    summary << std::setprecision(3) << "; shape RMSE " << 1000 * report.final_shape.rmse_pred_to_gt_m
            << " mm (predicted->truth), " << 1000 * report.final_shape.rmse_gt_to_pred_m
            << " mm (truth->predicted), F-score@5mm " << report.final_shape.fscore_5mm;
  summary << "; results in " << results_dir_;
  if (report.status.rfind("error", 0) == 0) {
    ROS_ERROR_STREAM(summary.str());
    return 1;
  }
  ROS_INFO_STREAM(summary.str());
  return 0;
}

}  // namespace gpatlas_ros
