#include "bench_options.h"

#include "bench_oracle.h"

#include <gpatlas_core/common/parameters.h>
#include <gpatlas_core/planning/strategy_library.h>
#include <gpatlas_core/planning/strategy_registry.h>
#include <probe_sim/object_mesh.h>
#include <probe_sim/procedural_objects.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <iterator>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <system_error>

namespace gpatlas_bench {

namespace {

void printUsage() {
  std::cout <<
      R"(usage: gpatlas_bench [options]
Runs the pipeline's exploration (segmentation of a simulated depth view, the GPIS, Algorithm 2
with a strategy, the simulated probe) on objects with a known truth, and measures the shape.
  --config FILE                  the pipeline's parameters [the repository's config/pipeline.yaml]
  --simulation FILE              the simulated scene, probe and camera [probe_sim's config/simulation.yaml]
  --overlay FILE                 a partial file whose parameters replace the config's (repeatable),
                                 e.g. config/paper.yaml: the paper's global GPIS
  --set KEY=VALUE                override one of them, e.g. --set exploration/v_max=0.05 or
                                 --set simulation/table=false (repeatable)
  --object FILE|procedural:NAME  object to explore (repeatable); procedural names: )"
            << [] {
                 std::string names;
                 for (const auto& n : probe_sim::proceduralObjectNames()) names += n + " ";
                 return names;
               }() << R"(
                                 [the config's simulation/object]
  --scale S                      scale of the mesh files given after it (0.001 for mm) [1]
  --size-m S                     size of procedural objects in metres [simulation/procedural_size_m]
  --strategy NAME                random | max_variance | atlas_poke | atlas_slide | atlas_frontier (repeatable)
                                 [the config's strategy], or one from a --strategy-library, or
                                 oracle_poke: an analysis that reads the truth (tools/bench_oracle.h)
  --strategy-library FILE        a shared library that registers strategies of your own
                                 (GPATLAS_REGISTER_STRATEGY, gpatlas_core/planning/strategy_library.h) (repeatable)
  --neighbour OBJECT@DX,DY[,YAW_RAD[,SCALE]]
                                 an object beside the explored one, its centre DX, DY metres from
                                 the explored object's (repeatable; replaces simulation/neighbours);
                                 segmentation then picks the explored object as a user's hint would
  --probe ray|sphere|patch       simulated probe model [simulation/probe]
  --seeds 0,1,2                  seeds (camera noise, the view's subset, the planner) [the config's seed]
  --max-actions N                cap on tactile actions per run [the config's exploration/max_actions]
  --jobs N                       runs in parallel [1]
  --out DIR                      output folder [bench_out]
  --urdf FILE                    the robot (head camera, arm) [vito_description's vito.urdf]
  --curve-every K                measure the shape error every K actions (0: only at the end) [1]
  --curve-resolution-m R         the mesh of those measurements (the final one: mesh/resolution_m) [0.01]
  --curve-samples N              samples of each surface in those measurements (the final one: 20000) [3000]
  --variance-every K             of those, sample the surface's largest variance every K actions [5]
  --no-reachability              skip the truth's reachable part (reachability.csv, the floor)
  --reach-directions N           escape lines tried per truth triangle for it [256]
  --save-meshes                  write each run's final predicted surface as OBJECT_STRATEGY_seedS.ply
                                 (x y z variance position_sd_m), its contacts as
                                 OBJECT_STRATEGY_seedS_contacts.csv and each object as OBJECT_truth.ply
  --verbose                      one line per action
  --no-plot                      skip the PNG plots
  --shard K/N                    run share K of N of the (object, strategy, seed) job list: the jobs
                                 j (0-based, in that order) with j % N == K - 1; writes its outputs
                                 and shard.txt (the job list, the settings) into --out
  --merge DIR...                 merge the folders of shards of one sweep into --out (runs.csv,
                                 history.csv, reachability.csv, summary.md, plots) in the job order
                                 of a one-process run; besides --out and --no-plot it takes no
                                 setting (the shards' shard.txt hold them)
)";
}

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) if (!item.empty()) out.push_back(item);
  return out;
}

// A numeric flag's range is that of the config parameter it overrides, where there is one (the
// config readers' ranges), so that no flag runs what the config file would refuse; the others are
// bounded past any use, which refuses a typo's extra digits.
constexpr double kMaxScale = 1e9;      // simulation/object_scale
constexpr double kMaxSizeM = 100.0;    // simulation/procedural_size_m
constexpr int kMaxSeed = 1 << 30;      // seed
constexpr int kMaxActions = 1000000;   // exploration/max_actions
constexpr double kMinCurveResolutionM = 1e-4, kMaxCurveResolutionM = 1.0;  // mesh/resolution_m
constexpr int kMaxEveryActions = kMaxActions;  // --curve-every, --variance-every: a count of actions
constexpr int kMaxJobs = 1024;
constexpr int kMaxCurveSamples = 1000000;
constexpr int kMaxReachDirections = 65536;

std::string formatNumber(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// A decimal number from `min` (exclusive when min_open) to `max`; else the flag, the value and the range.
double parseNumber(const std::string& flag, const std::string& value, double min, bool min_open, double max) {
  char* end = nullptr;
  const double v = std::strtod(value.c_str(), &end);
  const bool number = end != value.c_str() && *end == '\0' && std::isfinite(v);
  if (!number || (min_open ? v <= min : v < min) || v > max)
    throw std::invalid_argument(flag + " needs a number " + (min_open ? "> " : ">= ") + formatNumber(min) + " and <= " +
                                formatNumber(max) + ", got '" + value + "'");
  return v;
}

// A decimal integer (digits, an optional minus) from `min` to `max`; else the flag, the value and the range.
int parseInt(const std::string& flag, const std::string& value, int min, int max) {
  long long v = 0;
  const char* end = value.data() + value.size();
  const auto [ptr, ec] = std::from_chars(value.data(), end, v);
  if (value.empty() || ec != std::errc() || ptr != end || v < min || v > max)
    throw std::invalid_argument(flag + " needs an integer from " + std::to_string(min) + " to " + std::to_string(max) +
                                ", got '" + value + "'");
  return static_cast<int>(v);
}

Shard parseShard(const std::string& value) {
  const std::string usage =
      "--shard needs K/N with 1 <= K <= N, integers, N <= 999999999 (e.g. --shard 2/8), got '" + value + "'";
  const std::size_t slash = value.find('/');
  if (slash == std::string::npos) throw std::invalid_argument(usage);
  auto positive = [&](const std::string& digits) {
    if (digits.empty() || digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos)
      throw std::invalid_argument(usage);
    return std::stoi(digits);
  };
  Shard shard{positive(value.substr(0, slash)), positive(value.substr(slash + 1))};
  if (shard.index < 1 || shard.count < 1 || shard.index > shard.count) throw std::invalid_argument(usage);
  return shard;
}

// Flags that do not change what a run computes (where it goes, how many workers, what it prints).
bool leavesResultsAlone(const std::string& flag) {
  for (const char* f : {"--shard", "--out", "--jobs", "--verbose", "--no-plot", "--save-meshes"})
    if (flag == f) return true;
  return false;
}

void loadStrategyLibraryAnnounced(const std::string& file) {
  const auto load = gpatlas_core::loadStrategyLibrary(file);
  if (!load.ok) throw std::invalid_argument(load.message);
  std::string names;
  for (const auto& name : load.added) names += " " + name;
  std::cout << "gpatlas_bench: " << file << " adds the strategies:" << names << std::endl;
}

// The flags, in order; returns whether --seeds was given.
bool parseFlags(int argc, char** argv, Options& o) {
  bool seeds_given = false;
  // A --scale scales the --object meshes after it: one after the last --object would scale
  // nothing, and the run would go on at the config's scale as if it had been taken.
  std::string unused_scale;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const int first = i;
    // A flag where the value should be is a value left out ("--set --out DIR" would set "--out"
    // and then call DIR an unknown argument); no value of these flags starts with "--".
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      const std::string value = argv[++i];
      if (value.rfind("--", 0) == 0) throw std::invalid_argument(a + " needs a value, got the flag '" + value + "'");
      return value;
    };
    if (a == "-h" || a == "--help") {
      printUsage();
      std::exit(0);
    } else if (a == "--config") o.config_path = next();
    else if (a == "--simulation") o.simulation_path = next();
    else if (a == "--overlay") o.overlays.push_back(next());
    else if (a == "--set") o.overrides.push_back(next());
    else if (a == "--object") {
      o.objects.push_back({next(), o.scale});
      unused_scale.clear();
    } else if (a == "--scale") {
      o.scale = parseNumber(a, next(), 0.0, true, kMaxScale);
      unused_scale = argv[i];
    }
    else if (a == "--size-m") o.procedural_size_m = parseNumber(a, next(), 0.0, true, kMaxSizeM);
    else if (a == "--strategy") {
      for (const auto& s : splitList(next())) o.strategies.push_back(s);
    } else if (a == "--strategy-library") loadStrategyLibraryAnnounced(next());
    else if (a == "--probe") o.probe = next();
    else if (a == "--neighbour") {
      std::string error;
      const std::optional<probe_sim::NeighbourConfig> neighbour = probe_sim::parseNeighbour(next(), &error);
      if (!neighbour) throw std::invalid_argument("--neighbour: " + error);
      if (!o.neighbours) o.neighbours.emplace();
      o.neighbours->push_back(*neighbour);
    }
    else if (a == "--seeds") {
      o.seeds.clear();
      for (const auto& s : splitList(next())) o.seeds.push_back(parseInt(a, s, 0, kMaxSeed));
      if (o.seeds.empty()) throw std::invalid_argument("--seeds needs at least one seed");
      seeds_given = true;
    } else if (a == "--max-actions") o.max_actions = parseInt(a, next(), 0, kMaxActions);
    else if (a == "--jobs") o.jobs = parseInt(a, next(), 1, kMaxJobs);
    else if (a == "--out") o.out = next();
    else if (a == "--urdf") o.urdf_path = next();
    else if (a == "--curve-every") o.curve_every = parseInt(a, next(), 0, kMaxEveryActions);
    else if (a == "--curve-resolution-m")
      o.curve_resolution_m = parseNumber(a, next(), kMinCurveResolutionM, false, kMaxCurveResolutionM);
    else if (a == "--curve-samples") o.curve_samples = parseInt(a, next(), 1, kMaxCurveSamples);
    else if (a == "--variance-every") o.variance_every = parseInt(a, next(), 1, kMaxEveryActions);
    else if (a == "--no-reachability") o.reachability = false;
    else if (a == "--reach-directions") o.reach_directions = parseInt(a, next(), 1, kMaxReachDirections);
    else if (a == "--verbose") o.verbose = true;
    else if (a == "--no-plot") o.plot = false;
    else if (a == "--save-meshes") o.save_meshes = true;
    else if (a == "--shard") o.shard = parseShard(next());
    else if (a == "--merge") {
      while (i + 1 < argc && std::string(argv[i + 1]).rfind("--", 0) != 0) o.merge_folders.push_back(argv[++i]);
      if (o.merge_folders.empty()) throw std::invalid_argument("--merge needs the shards' folders");
    }
    else throw std::invalid_argument("unknown argument '" + a + "' (see --help)");
    if (!leavesResultsAlone(a)) o.result_args.insert(o.result_args.end(), argv + first, argv + i + 1);
  }
  if (!unused_scale.empty())
    throw std::invalid_argument("--scale " + unused_scale +
                                " comes after every --object: it scales the meshes given after it, so put it before "
                                "the --object it is for (the config's object: simulation/object_scale, --set)");
  return seeds_given;
}

// The config file with its overlays and --set overrides, read into o.pipeline and o.simulation;
// the config's strategy libraries; the robot's URDF.
void readConfiguration(Options& o) {
  std::string error;
  const std::shared_ptr<gpatlas_core::YamlParameters> params = gpatlas_core::YamlParameters::fromFile(o.config_path, &error);
  if (!params) throw std::invalid_argument("--config: " + error);
  // The scene's file joins the pipeline's, so that overlays and --set reach both alike.
  const std::unique_ptr<gpatlas_core::YamlParameters> scene = gpatlas_core::YamlParameters::fromFile(o.simulation_path, &error);
  if (!scene || !params->overlay(*scene, &error)) throw std::invalid_argument("--simulation: " + error);
  std::vector<std::string> overlaid;
  for (const std::string& path : o.overlays) {
    const std::unique_ptr<gpatlas_core::YamlParameters> overlay = gpatlas_core::YamlParameters::fromFile(path, &error);
    if (!overlay || !params->overlay(*overlay, &error)) throw std::invalid_argument("--overlay " + path + ": " + error);
    for (const std::string& name : overlay->leafNames()) overlaid.push_back(name + " (" + path + ")");
  }
  for (const std::string& assignment : o.overrides)
    if (!params->set(assignment, &error)) throw std::invalid_argument("--set: " + error);
  {
    // The config's libraries first: a library's surface model reads its settings with the
    // pipeline's (readPipeline reports a bad strategy_libraries).
    gpatlas_core::ParamReader libraries_reader(*params);
    gpatlas_core::StrategyChoice choice;
    gpatlas_core::readStrategyChoice(libraries_reader, &choice);
    for (const std::string& library : choice.libraries) {
      const auto load = gpatlas_core::loadStrategyLibrary(library);
      if (!load.ok) throw std::invalid_argument(load.message);
    }
  }
  gpatlas_core::ParamReader reader(*params);
  probe_sim::readPipeline(reader, &o.pipeline);
  probe_sim::readSimulation(reader, &o.simulation);
  o.simulation.world_frame = o.pipeline.frames.world_frame;
  if (!reader.ok()) throw std::invalid_argument(o.config_path + ", " + o.simulation_path + ": " + reader.errors());
  if (!o.probe.empty()) o.simulation.probe = o.probe;
  if (o.neighbours) o.simulation.neighbours = *o.neighbours;
  if (o.procedural_size_m) o.simulation.procedural_size_m = *o.procedural_size_m;
  if (const std::string problem = probe_sim::validate(o.simulation); !problem.empty())
    throw std::invalid_argument(o.simulation_path + ": " + problem);
  std::ifstream urdf(o.urdf_path);
  if (!urdf) throw std::invalid_argument("--urdf: cannot read " + o.urdf_path);
  o.urdf_xml.assign(std::istreambuf_iterator<char>(urdf), std::istreambuf_iterator<char>());
  // The runs' strategies read their settings now as each run will, so that a bad value, or a
  // setting only a library's strategy reads, is known before any run (unknown names are
  // reported with the command line's checks).
  const std::vector<std::string> known = gpatlas_core::strategyNames();
  for (const std::string& name :
       o.strategies.empty() ? std::vector<std::string>{o.pipeline.strategy_choice.name} : o.strategies)
    if (std::find(known.begin(), known.end(), name) != known.end()) gpatlas_core::makeStrategy(name, reader, 0);
  if (!reader.ok()) throw std::invalid_argument(o.config_path + ": " + reader.errors());
  o.settings = params;
  // A --set or an overlay of a name no reader knows is a typo, not a setting.
  std::vector<std::string> given = overlaid;
  for (const std::string& assignment : o.overrides) given.push_back(assignment);
  for (const std::string& setting : given) {
    const std::string key = setting.substr(0, setting.find_first_of("= "));
    const auto& read = reader.readNames();
    if (std::find(read.begin(), read.end(), key) == read.end())
      throw std::invalid_argument(setting + ": no such parameter (see " + o.config_path + " and " + o.simulation_path + ")");
  }
}

// What the command line left to the config, and the checks of the whole.
void completeAndCheck(Options& o, bool seeds_given) {
  if (o.objects.empty()) o.objects.push_back({o.simulation.object, o.simulation.object_scale});
  if (o.strategies.empty()) o.strategies.push_back(o.pipeline.strategy_choice.name);
  if (!seeds_given) o.seeds = {static_cast<int>(o.pipeline.seed)};
  if (o.max_actions) o.pipeline.exploration.max_actions = *o.max_actions;
  const auto known = gpatlas_core::strategyNames();
  for (const auto& s : o.strategies)
    if (s != kOracleStrategy && std::find(known.begin(), known.end(), s) == known.end()) {
      std::string list;
      for (const auto& k : known) list += " " + k;
      list += std::string(" ") + kOracleStrategy + " (an analysis)";
      throw std::invalid_argument("unknown strategy '" + s + "'; known:" + list);
    }
}

}  // namespace

Options parseArgs(int argc, char** argv, Options defaults) {
  Options o = std::move(defaults);
  const bool seeds_given = parseFlags(argc, argv, o);
  if (!o.merge_folders.empty()) {
    // A merge takes its settings from the shards' folders.
    for (const std::string& arg : o.result_args)
      if (arg.rfind("--", 0) == 0 && arg != "--merge")
        throw std::invalid_argument("--merge runs nothing, so it takes no run setting (the shards' folders hold them): " + arg);
    if (o.shard) throw std::invalid_argument("--merge and --shard exclude each other");
    return o;
  }
  readConfiguration(o);
  completeAndCheck(o, seeds_given);
  return o;
}

}  // namespace gpatlas_bench
