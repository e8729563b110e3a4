#pragma once

// The one place where ROS parameters become core Configs. Every reader starts from the
// Config's defaults, overrides what the parameter server has, logs the values it uses, and
// collects every invalid value (with the parameter's full name) into one error message.

#include <gpatlas_core/exploration_strategy.h>
#include <gpatlas_core/gpis_model.h>
#include <gpatlas_core/hyperparameter_tuner.h>
#include <gpatlas_core/occupancy_grid.h>
#include <gpatlas_core/segmentation.h>
#include <gpatlas_core/surface_mesher.h>
#include <gpatlas_core/view_free_space.h>

#include <ros/node_handle.h>

#include <string>
#include <vector>

namespace gpatlas_ros {

// Collects problems while reading; `ok()` is false as soon as one parameter is invalid.
class ParamReader {
 public:
  explicit ParamReader(const ros::NodeHandle& nh) : nh_(nh) {}

  double number(const std::string& name, double fallback, double min, double max);
  int integer(const std::string& name, int fallback, int min, int max);
  bool flag(const std::string& name, bool fallback);
  std::string text(const std::string& name, const std::string& fallback);
  std::vector<std::string> texts(const std::string& name, const std::vector<std::string>& fallback);
  Eigen::Vector3d vector3(const std::string& name, const Eigen::Vector3d& fallback);

  // Records a problem found by the caller's own check (e.g. an unknown plugin name).
  void invalid(const std::string& name, const std::string& why);

  bool ok() const { return errors_.empty(); }
  std::string errors() const;
  // The parameters that were not set, so their defaults apply (reported at start).
  std::string defaulted() const;
  // Logs the invalid parameters (error) and the defaulted ones (info) under `who`.
  void report(const std::string& who) const;
  const std::string& ns() const { return nh_.getNamespace(); }

 private:
  bool present(const std::string& name);

  ros::NodeHandle nh_;
  std::vector<std::string> errors_;
  std::vector<std::string> defaulted_;
};

// Noise sigmas (units of f) given to each kind of observation.
struct ObservationNoise {
  double vision_sigma{0.3162};  // sqrt(0.1): the paper's noise variance on every point
  double touch_sigma{0.3162};
  double free_space_sigma{0.3162};
};

void readGpis(ParamReader& reader, gpatlas_core::GpisModel::Config* config);
void readNoise(ParamReader& reader, ObservationNoise* noise);
void readTuner(ParamReader& reader, gpatlas_core::HyperparameterTuner::Config* config);
void readStrategy(ParamReader& reader, gpatlas_core::StrategyConfig* config);
void readMesher(ParamReader& reader, gpatlas_core::SurfaceMesher::Config* config);
void readOccupancy(ParamReader& reader, gpatlas_core::OccupancyGridBuilder::Config* config);
void readSegmenter(ParamReader& reader, gpatlas_core::ObjectSegmenter::Config* config);
// view_free_space/...: the camera's free space as outside points; `sensor_frame` is the depth
// camera's optical frame (empty: the view's free space is not used).
void readViewFreeSpace(ParamReader& reader, gpatlas_core::ViewFreeSpaceConfig* config, std::string* sensor_frame);
// occluded_interior/...: inside points behind the view, within its hull (needs the sensor
// frame above; max_points 0 disables them).
void readOccludedInterior(ParamReader& reader, gpatlas_core::OccludedInteriorConfig* config);
// support_plane/...: the table under the object, from segmentation (`support_plane` topic).
void readSupportPlane(ParamReader& reader, bool* enabled, double* clearance_m, gpatlas_core::BelowSupportConfig* config);

}  // namespace gpatlas_ros
