#pragma once

// gpatlas_bench's command line, and the configuration file it reads.

#include <gpatlas_core/common/parameters.h>
#include <probe_sim/pipeline_config.h>
#include <probe_sim/reachability.h>
#include <probe_sim/simulation_settings.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_bench {

// Share `index` (1-based) of `count`: the jobs j of the job list with j % count == index - 1.
struct Shard {
  int index{1};
  int count{1};
};

struct Options {
  struct ObjectSpec {
    std::string spec;
    double scale;  // the --scale in force when the --object was given
  };
  std::vector<ObjectSpec> objects;
  double scale{1.0};
  std::optional<double> procedural_size_m;  // --size-m; otherwise simulation/procedural_size_m
  std::vector<std::string> strategies;
  std::string probe;  // --probe; otherwise simulation/probe
  std::vector<int> seeds{0};
  std::optional<int> max_actions;  // otherwise the config's exploration/max_actions
  int jobs{1};
  std::string out{"bench_out"};
  std::string config_path;  // the build's config/pipeline.yaml unless --config
  std::string simulation_path;  // probe_sim's config/simulation.yaml unless --simulation
  std::vector<std::string> overlays;  // partial files over it, in order (e.g. config/paper.yaml)
  std::vector<std::string> overrides;  // --set key=value, in order
  // --neighbour: they replace the config's simulation/neighbours.
  std::optional<std::vector<probe_sim::NeighbourConfig>> neighbours;
  std::string urdf_path;  // the robot: its head camera and its arm (the build's vito.urdf unless --urdf)
  std::string urdf_xml;
  int curve_every{1};
  // The curve's points but the last are measured more cheaply than the final model, so that every
  // action can have one: a coarser mesh of the prediction (the final one: mesh/resolution_m) and
  // fewer samples of each surface (the final one: ShapeMetrics' 20000).
  double curve_resolution_m{0.01};
  int curve_samples{3000};
  // The curve's sampled variance (a third of a point's cost) at every K-th action only.
  int variance_every{5};
  bool reachability{true};
  int reach_directions{probe_sim::ReachabilityConfig().directions};
  bool verbose{false};
  bool plot{true};
  bool save_meshes{false};
  std::optional<Shard> shard;  // --shard K/N
  std::vector<std::string> merge_folders;  // --merge DIR...: merge shards' outputs, run nothing
  // The command line's arguments that decide what the runs compute (all but --shard, --out,
  // --jobs, --verbose, --no-plot, --save-meshes): the shards of one sweep must agree on them.
  std::vector<std::string> result_args;
  // Everything else comes from the config file: the pipeline's own Configs and the simulated
  // scene that probe_sim_node builds from the same file.
  probe_sim::PipelineConfig pipeline;
  probe_sim::SimulationSettings simulation;
  // The whole configuration (file, overlays, --set), from which each run's strategy reads its
  // settings when it is made (gpatlas_core::makeStrategy).
  std::shared_ptr<const gpatlas_core::YamlParameters> settings;
};

// The options of a command line over `defaults` (which give this build's config and URDF
// paths), with the configuration read and checked. Throws std::invalid_argument with the
// reason; --help prints the usage and exits. With --merge only --out and --no-plot may be given,
// and no configuration is read.
Options parseArgs(int argc, char** argv, Options defaults);

}  // namespace gpatlas_bench
