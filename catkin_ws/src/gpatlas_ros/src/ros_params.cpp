#include "gpatlas_ros/ros_params.h"

#include <gpatlas_core/planning/strategy_library.h>

#include <ros/console.h>

namespace gpatlas_ros {

void readExplorationNode(gpatlas_core::ParamReader& r, ExplorationNodeConfig* c) {
  c->service_timeout_s = r.number("service_timeout_s", c->service_timeout_s, 0.1, 3600.0);
  c->call_timeout_s = r.number("call_timeout_s", c->call_timeout_s, 0.1, 86400.0);
  c->capture = r.flag("capture", c->capture);
  c->republish_view_after_s = r.optionalNumber("republish_view_after_s", c->republish_view_after_s, 3600.0);
  c->metrics_every = r.optionalInteger("metrics_every", c->metrics_every, 100000);
  c->results_dir = r.text("results_dir", c->results_dir);
}

ServerPreamble readServerPreamble(gpatlas_core::ParamReader& reader, const std::string& who) {
  ServerPreamble preamble;
  readFrames(reader, &preamble.frames);
  preamble.seed = readSeed(reader);
  preamble.use_support_plane = readUseSupportPlane(reader);
  readStrategyChoice(reader, &preamble.strategy_choice);
  // Before the model's settings: a library's surface model reads its own.
  loadPluginLibraries(preamble.strategy_choice.libraries, reader, who);
  gpatlas_core::readSurfaceModel(reader, &preamble.model);
  return preamble;
}

void RosParamReader::report(const std::string& who) const {
  if (!ok()) ROS_ERROR_STREAM(who << ": invalid parameters, defaults used instead: " << errors());
  if (!defaultedNames().empty())
    ROS_INFO_STREAM(who << ": parameters not set in " << ns() << ", defaults used: " << defaulted());
}

void loadPluginLibraries(const std::vector<std::string>& libraries, gpatlas_core::ParamReader& reader,
                         const std::string& who) {
  for (const std::string& library : libraries) {
    const gpatlas_core::StrategyLibraryLoad load = gpatlas_core::loadStrategyLibrary(library);
    if (!load.ok) {
      reader.invalid("strategy_libraries", load.message);
      continue;
    }
    std::string names;
    for (const std::string& name : load.added) names += " " + name;
    for (const std::string& name : load.added_models) names += " " + name + " (surface model)";
    ROS_INFO_STREAM(who << ": " << library << " adds" << names);
  }
}

}  // namespace gpatlas_ros
