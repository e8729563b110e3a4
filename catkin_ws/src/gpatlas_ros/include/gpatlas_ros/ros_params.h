#pragma once

// The one place where ROS parameters become Configs: the packages' readers
// (gpatlas_core/config/config_readers.h, gpatlas_geometry/config_readers.h,
// gpatlas_motion/config_readers.h) on the parameter server. Every reader starts from the
// Config's defaults, overrides what the parameter server has, and collects every invalid value
// (with the parameter's full name) into one error message.

#include <gpatlas_core/config/config_readers.h>
#include <gpatlas_core/common/parameters.h>
#include <gpatlas_conversions/ros_parameters.h>
#include <gpatlas_geometry/config_readers.h>
#include <gpatlas_motion/config_readers.h>

#include <ros/node_handle.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_ros {

using gpatlas_core::readCollisionMap;
using gpatlas_core::readEvidence;
using gpatlas_core::readExplorer;
using gpatlas_core::readFrames;
using gpatlas_core::readGpis;
using gpatlas_geometry::readMesher;
using gpatlas_motion::readApproach;
using gpatlas_core::readSeed;
using gpatlas_geometry::readSegmenter;
using gpatlas_core::readStrategyChoice;
using gpatlas_core::readTouchObservations;
using gpatlas_core::readPositionCalibration;
using gpatlas_core::readUseSupportPlane;
using gpatlas_core::readViewTraining;
using gpatlas_core::readVMax;
using gpatlas_core::readMaxPositionSd;

// The exploration node's own settings (launch parameters, not config/pipeline.yaml's: the file
// holds what the pipeline and the bench share).
struct ExplorationNodeConfig {
  double service_timeout_s{60.0};  // for a service to appear
  double call_timeout_s{600.0};    // for a call to answer (a touch on a slow arm takes minutes)
  bool capture{true};              // ask ~capture for the first view (false: wait for a cloud)
  // No model this long after the capture: publish the captured cloud again (a message lost on
  // its way through segmentation and the GP must not end the run); off: never.
  std::optional<double> republish_view_after_s{20.0};
  std::optional<int> metrics_every{1};  // measure the model every k actions (off: only at the end)
  std::string results_dir;         // empty: ./results/exploration_DATE_TIME
};

namespace detail {
// Constructed before the reader that refers to it.
struct SourceHolder {
  explicit SourceHolder(const ros::NodeHandle& nh) : source(nh) {}
  gpatlas_conversions::RosParameterSource source;
};
}  // namespace detail

// The core's ParamReader on a node's private parameters (the parameter server as its source).
class RosParamReader : private detail::SourceHolder, public gpatlas_core::ParamReader {
 public:
  explicit RosParamReader(const ros::NodeHandle& nh) : detail::SourceHolder(nh), gpatlas_core::ParamReader(source) {}
  // Logs the invalid parameters (error) and the defaulted ones (info) under `who`.
  void report(const std::string& who) const;
  const std::string& ns() const { return source.ns(); }
};

void readExplorationNode(gpatlas_core::ParamReader& r, ExplorationNodeConfig* c);

// What the servers that hold or rebuild the surface model (gp_model, atlas_planner,
// collision_map) read first, alike: the frames, the seed, whether the table is used, the model,
// and the plugin libraries (strategy_libraries: strategies and surface models of your own).
struct ServerPreamble {
  gpatlas_core::PipelineFrames frames;
  std::uint64_t seed{0};
  bool use_support_plane{true};
  gpatlas_core::SurfaceModelConfig model;
  gpatlas_core::StrategyChoice strategy_choice;
};
// Reads the preamble and loads its plugin libraries (loadPluginLibraries), so that a model or a
// strategy of your own can be built after it.
ServerPreamble readServerPreamble(gpatlas_core::ParamReader& reader, const std::string& who);

// Loads `libraries` (strategy_libraries: strategies and surface models of your own,
// strategy_library.h), logging what each adds under `who`; a library that fails is an invalid
// `strategy_libraries` of `reader`. Every node that builds or plans on a model loads them first.
void loadPluginLibraries(const std::vector<std::string>& libraries, gpatlas_core::ParamReader& reader,
                         const std::string& who);

}  // namespace gpatlas_ros
