// gpatlas_bench: the paper's simulated exploration protocol without ROS.
//
// For every (object, strategy, seed): place the object on the table, take one simulated depth
// view from a fixed camera pose (a partial view), downsample it to the initial training set,
// fit the GPIS, then run the exploration loop (Algorithm 2) with the chosen strategy against the
// simulated probe on the ground-truth mesh, and measure the predicted shape against the mesh.
// Writes runs.csv, history.csv, reachability.csv, summary.md and one PNG per object into --out.

#include <probe_sim/pipeline_config.h>
#include <gpatlas_core/config/config_readers.h>
#include <gpatlas_core/exploration/exploration_report.h>
#include <gpatlas_core/planning/exploration_strategy.h>
#include <gpatlas_core/model/model_calibration.h>
#include <gpatlas_core/exploration/explorer.h>
#include <gpatlas_motion/touch_approach.h>
#include <gpatlas_geometry/shape_metrics.h>
#include <gpatlas_core/planning/strategy_library.h>
#include <gpatlas_core/planning/surface_sampler.h>
#include <gpatlas_geometry/surface_mesher.h>
#include <gpatlas_core/common/triangle_mesh.h>
#include <gpatlas_core/config/parameters.h>
#include <gpatlas_geometry/segmentation.h>
#include <gpatlas_core/observations/view_training.h>
#include <probe_sim/depth_camera.h>
#include <probe_sim/object_mesh.h>
#include <probe_sim/probe.h>
#include <probe_sim/reachability.h>
#include <probe_sim/scene.h>
#include <probe_sim/simulation_settings.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

namespace fs = std::filesystem;
using gpatlas_core::Vector3;

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
  int max_actions{-1};  // < 0: the config's exploration/max_actions
  int jobs{1};
  std::string out{"bench_out"};
  std::string config_path{GPATLAS_DEFAULT_CONFIG};
  std::vector<std::string> overlays;  // partial files over it, in order (e.g. config/paper.yaml)
  std::vector<std::string> overrides;  // --set key=value, in order
  std::string urdf_path{GPATLAS_VITO_URDF};  // the robot: its head camera and its arm
  std::string urdf_xml;
  int curve_every{5};
  bool reachability{true};
  int reach_directions{probe_sim::ReachabilityConfig().directions};
  bool verbose{false};
  bool plot{true};
  bool save_meshes{false};
  // Everything else comes from the config file: the pipeline's own Configs and the simulated
  // scene that probe_sim_node builds from the same file.
  probe_sim::PipelineConfig pipeline;
  probe_sim::SimulationSettings simulation;
};

void printUsage() {
  std::cout <<
      R"(usage: gpatlas_bench [options]
Runs the pipeline's exploration (segmentation of a simulated depth view, the GPIS, Algorithm 2
with a strategy, the simulated probe) on objects with a known truth, and measures the shape.
  --config FILE                  the pipeline's parameters [the repository's config/pipeline.yaml]
  --overlay FILE                 a partial file whose parameters replace the config's (repeatable),
                                 e.g. config/paper.yaml: the paper's global GPIS
  --set KEY=VALUE                override one of them, e.g. --set exploration/v_max=0.05 (repeatable)
  --object FILE|procedural:NAME  object to explore (repeatable); procedural names: )"
            << [] {
                 std::string names;
                 for (const auto& n : probe_sim::proceduralObjectNames()) names += n + " ";
                 return names;
               }() << R"(
                                 [the config's simulation/object]
  --scale S                      scale of the mesh files given after it (0.001 for mm) [1]
  --size-m S                     size of procedural objects in metres [simulation/procedural_size_m]
  --strategy NAME                random | max_variance | atlas_poke | atlas_slide (repeatable)
                                 [the config's strategy], or one from a --strategy-library
  --strategy-library FILE        a shared library that registers strategies of your own
                                 (GPATLAS_REGISTER_STRATEGY, gpatlas_core/planning/strategy_library.h) (repeatable)
  --probe ray|sphere|patch       simulated probe model [simulation/probe]
  --seeds 0,1,2                  seeds (camera noise, the view's subset, the planner) [the config's seed]
  --max-actions N                cap on tactile actions per run [the config's exploration/max_actions]
  --jobs N                       runs in parallel [1]
  --out DIR                      output folder [bench_out]
  --urdf FILE                    the robot (head camera, arm) [vito_description's vito.urdf]
  --curve-every K                measure the shape error every K actions (0: only at the end) [5]
  --no-reachability              skip the truth's reachable part (reachability.csv, the floor)
  --reach-directions N           escape lines tried per truth triangle for it [256]
  --save-meshes                  write each run's final predicted surface as OBJECT_STRATEGY_seedS.ply
                                 and each object as OBJECT_truth.ply
  --verbose                      one line per action
  --no-plot                      skip the PNG plots
)";
}

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) if (!item.empty()) out.push_back(item);
  return out;
}

double parseDouble(const std::string& flag, const std::string& value) {
  char* end = nullptr;
  const double v = std::strtod(value.c_str(), &end);
  if (end == value.c_str() || *end != '\0' || !std::isfinite(v))
    throw std::invalid_argument(flag + " needs a number, got '" + value + "'");
  return v;
}

int parseInt(const std::string& flag, const std::string& value) {
  const double v = parseDouble(flag, value);
  if (v != std::floor(v)) throw std::invalid_argument(flag + " needs an integer, got '" + value + "'");
  return static_cast<int>(v);
}

Options parseArgs(int argc, char** argv) {
  Options o;
  bool seeds_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "-h" || a == "--help") {
      printUsage();
      std::exit(0);
    } else if (a == "--config") o.config_path = next();
    else if (a == "--overlay") o.overlays.push_back(next());
    else if (a == "--set") o.overrides.push_back(next());
    else if (a == "--object") o.objects.push_back({next(), o.scale});
    else if (a == "--scale") {
      o.scale = parseDouble(a, next());
      if (!(o.scale > 0.0)) throw std::invalid_argument("--scale must be > 0");
    }
    else if (a == "--size-m") {
      o.procedural_size_m = parseDouble(a, next());
      if (!(*o.procedural_size_m > 0.0)) throw std::invalid_argument("--size-m must be > 0");
    }
    else if (a == "--strategy") {
      for (const auto& s : splitList(next())) o.strategies.push_back(s);
    } else if (a == "--strategy-library") {
      const std::string file = next();
      const auto load = gpatlas_core::loadStrategyLibrary(file);
      if (!load.ok) throw std::invalid_argument(load.message);
      std::string names;
      for (const auto& name : load.added) names += " " + name;
      std::cout << "gpatlas_bench: " << file << " adds the strategies:" << names << std::endl;
    } else if (a == "--probe") o.probe = next();
    else if (a == "--seeds") {
      o.seeds.clear();
      for (const auto& s : splitList(next())) o.seeds.push_back(parseInt(a, s));
      seeds_given = true;
    } else if (a == "--max-actions") o.max_actions = parseInt(a, next());
    else if (a == "--jobs") o.jobs = parseInt(a, next());
    else if (a == "--out") o.out = next();
    else if (a == "--urdf") o.urdf_path = next();
    else if (a == "--curve-every") o.curve_every = parseInt(a, next());
    else if (a == "--no-reachability") o.reachability = false;
    else if (a == "--reach-directions") o.reach_directions = parseInt(a, next());
    else if (a == "--verbose") o.verbose = true;
    else if (a == "--no-plot") o.plot = false;
    else if (a == "--save-meshes") o.save_meshes = true;
    else throw std::invalid_argument("unknown argument '" + a + "' (see --help)");
  }

  std::string error;
  const std::unique_ptr<gpatlas_core::YamlParameters> params = gpatlas_core::YamlParameters::fromFile(o.config_path, &error);
  if (!params) throw std::invalid_argument("--config: " + error);
  std::vector<std::string> overlaid;
  for (const std::string& path : o.overlays) {
    const std::unique_ptr<gpatlas_core::YamlParameters> overlay = gpatlas_core::YamlParameters::fromFile(path, &error);
    if (!overlay || !params->overlay(*overlay, &error)) throw std::invalid_argument("--overlay " + path + ": " + error);
    for (const std::string& name : overlay->leafNames()) overlaid.push_back(name + " (" + path + ")");
  }
  for (const std::string& assignment : o.overrides)
    if (!params->set(assignment, &error)) throw std::invalid_argument("--set: " + error);
  gpatlas_core::ParamReader reader(*params);
  probe_sim::readPipeline(reader, &o.pipeline);
  probe_sim::readSimulation(reader, &o.simulation);
  if (!reader.ok()) throw std::invalid_argument(o.config_path + ": " + reader.errors());
  if (!o.probe.empty()) o.simulation.probe = o.probe;
  if (o.procedural_size_m) o.simulation.procedural_size_m = *o.procedural_size_m;
  if (const std::string problem = probe_sim::validate(o.simulation); !problem.empty())
    throw std::invalid_argument(o.config_path + ": " + problem);
  std::ifstream urdf(o.urdf_path);
  if (!urdf) throw std::invalid_argument("--urdf: cannot read " + o.urdf_path);
  o.urdf_xml.assign(std::istreambuf_iterator<char>(urdf), std::istreambuf_iterator<char>());
  // A --set or an overlay of a name no reader knows is a typo, not a setting.
  std::vector<std::string> given = overlaid;
  for (const std::string& assignment : o.overrides) given.push_back(assignment);
  for (const std::string& setting : given) {
    const std::string key = setting.substr(0, setting.find_first_of("= "));
    const auto& read = reader.readNames();
    if (std::find(read.begin(), read.end(), key) == read.end())
      throw std::invalid_argument(setting + ": no such parameter (see " + o.config_path + ")");
  }
  for (const std::string& library : o.pipeline.strategy_choice.libraries) {
    const auto load = gpatlas_core::loadStrategyLibrary(library);
    if (!load.ok) throw std::invalid_argument(load.message);
  }

  if (o.objects.empty()) o.objects.push_back({o.simulation.object, o.simulation.object_scale});
  if (o.strategies.empty()) o.strategies.push_back(o.pipeline.strategy_choice.name);
  if (!seeds_given) o.seeds = {static_cast<int>(o.pipeline.seed)};
  if (o.max_actions >= 0) o.pipeline.exploration.max_actions = o.max_actions;
  if (o.reach_directions < 1) throw std::invalid_argument("--reach-directions must be >= 1");
  if (o.jobs < 1) throw std::invalid_argument("--jobs must be >= 1");
  if (o.seeds.empty()) throw std::invalid_argument("--seeds needs at least one seed");
  const auto known = gpatlas_core::strategyNames();
  for (const auto& s : o.strategies)
    if (std::find(known.begin(), known.end(), s) == known.end()) {
      std::string list;
      for (const auto& k : known) list += " " + k;
      throw std::invalid_argument("unknown strategy '" + s + "'; known:" + list);
    }
  return o;
}

// A ground-truth object placed as the simulator places it (simulation/object_position_xy_m).
struct GroundTruth {
  std::string name;
  probe_sim::TriangleMesh mesh;
  // Which of the shape metrics' truth samples lie on the part of the surface a camera or a ray
  // probe outside the object can reach (probe_sim::splitReachableSurface), and the floor the
  // rest sets: the truth-to-predicted RMSE of a prediction that is exactly the reachable
  // surface (a prediction that also guesses hidden layers could come closer).
  bool reachability_measured{false};
  double reachable_area_fraction{1.0};
  double floor_rmse_gt_to_pred{0.0};
  std::vector<bool> sample_reachable;
  // Which of the same samples the camera sees (samplesSeenFrom); empty without a camera.
  std::vector<bool> sample_seen;
  // The truth samples of the calibration (surfaceCalibration).
  std::vector<gpatlas_core::Vector3> calibration_samples;
};

void measureReachability(GroundTruth& gt, const probe_sim::SimulationSettings& simulation, int directions) {
  const probe_sim::Scene scene(gt.mesh, probe_sim::sceneConfig(simulation));
  probe_sim::ReachabilityConfig config;
  config.directions = directions;
  const probe_sim::ReachableSurface split = probe_sim::splitReachableSurface(scene, config);
  gt.reachable_area_fraction = split.reachable_area_fraction;
  gt.sample_reachable.clear();
  // The very points ShapeMetrics::compare measures truth-to-predicted on, with their triangles.
  const gpatlas_geometry::ShapeMetrics::Config metrics;
  std::vector<std::size_t> owners;
  const std::vector<gpatlas_core::Vector3> samples = gpatlas_geometry::sampleMeshSurface(
      gt.mesh, metrics.samples_per_mesh, gpatlas_geometry::truthSampleSeed(metrics.seed), &owners);
  if (split.reachable.triangles.empty() || samples.empty()) {
    gt.floor_rmse_gt_to_pred = std::nan("");
    gt.reachability_measured = true;
    return;
  }
  const gpatlas_geometry::MeshDistanceIndex onto_reachable(split.reachable, metrics.index);
  if (!onto_reachable.ok()) throw std::runtime_error("reachable surface index: " + onto_reachable.message());
  double sum_squared = 0.0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    gt.sample_reachable.push_back(split.triangle_reachable[owners[i]]);
    if (!gt.sample_reachable.back()) sum_squared += std::pow(onto_reachable.distance(samples[i]), 2);
  }
  gt.floor_rmse_gt_to_pred = std::sqrt(sum_squared / static_cast<double>(samples.size()));
  gt.reachability_measured = true;
}


// The truth samples of the calibration (surfaceCalibration): the same for every run of an object.
constexpr std::size_t kCalibrationSamples = 2000;
constexpr std::uint64_t kCalibrationSeed = 11;

// Which of the shape metrics' truth samples the camera at `eye` sees: the first hit of its ray
// to the sample is the sample itself.
std::vector<bool> samplesSeenFrom(const probe_sim::Scene& scene, const probe_sim::TriangleMesh& mesh,
                                  const Eigen::Vector3d& eye) {
  const gpatlas_geometry::ShapeMetrics::Config metrics;
  const std::vector<gpatlas_core::Vector3> samples =
      gpatlas_geometry::sampleMeshSurface(mesh, metrics.samples_per_mesh, gpatlas_geometry::truthSampleSeed(metrics.seed));
  Eigen::Matrix3Xd from(3, static_cast<Eigen::Index>(samples.size())), to(3, from.cols());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    from.col(static_cast<Eigen::Index>(i)) = eye;
    // A millimetre beyond the sample, so that the sample's own triangle is hit.
    to.col(static_cast<Eigen::Index>(i)) = samples[i] + 1e-3 * (samples[i] - eye).normalized();
  }
  const std::vector<probe_sim::RayHit> hits = scene.castRays(from, to);
  std::vector<bool> seen(samples.size(), false);
  for (std::size_t i = 0; i < samples.size(); ++i)
    seen[i] = hits[i].hit && hits[i].distance >= (samples[i] - eye).norm() - 1e-3;
  return seen;
}

GroundTruth loadObject(const std::string& spec, double scale, const Options& o) {
  GroundTruth gt;
  const std::string prefix = "procedural:";
  gt.name = spec.rfind(prefix, 0) == 0 ? spec.substr(prefix.size()) : fs::path(spec).stem().string();
  probe_sim::SimulationSettings simulation = o.simulation;
  simulation.object = spec;
  simulation.object_scale = scale;
  gt.mesh = probe_sim::loadSimulatedObject(simulation);
  gt.calibration_samples = gpatlas_geometry::sampleMeshSurface(gt.mesh, kCalibrationSamples, kCalibrationSeed);
  // A camera the settings cannot place fails every run of the object, with the reason.
  std::string camera_error;
  if (const std::optional<Eigen::Isometry3d> camera = probe_sim::cameraPose(simulation, o.urdf_xml, &camera_error))
    gt.sample_seen = samplesSeenFrom(probe_sim::Scene(gt.mesh, probe_sim::sceneConfig(simulation)), gt.mesh,
                                     camera->translation());
  return gt;
}

struct RunResult {
  std::string object, strategy, probe, stop_reason;
  // "converged", "stopped: ..." or "error: ..." (gpatlas_core::runStatus): no surface is an error.
  std::string status;
  int seed{0};
  double v_max{0.0};
  int actions{0};
  int contacts{0};
  bool converged{false};
  std::size_t n_train{0};
  gpatlas_geometry::ShapeMetricsResult metrics;
  // Truth-to-predicted RMSE over the reachable truth only (GroundTruth::sample_reachable).
  double rmse_gt_to_pred_reachable{std::nan("")};
  // Truth-to-predicted RMSE over the truth the camera saw, and over the rest (touch's part).
  double rmse_gt_to_pred_seen{std::nan("")};
  double rmse_gt_to_pred_unseen{std::nan("")};
  // The share of true-surface samples whose predicted f is within 2 sd of 0 (0.95 is calibrated).
  double calibration{std::nan("")};
  // Its sharpness: the median sd of the surface's position along the normal there (m).
  double position_sd_m{std::nan("")};
  double max_evaluated_variance{0.0};
  double wall_s{0.0};
  double plan_ms_median{0.0};
  double update_ms_median{0.0};
  // Approach planning (approach/): touches refused for want of a safe approach, the probe's
  // contacts with the true scene on the way to the touches and back, and the planner's time.
  int unreachable_touches{0};
  int unreachable_candidates{0};
  int final_unreachable_candidates{0};  // in the plan that ended the run
  int approach_collisions{0};
  int retreat_collisions{0};
  double approach_plan_ms_median{std::nan("")};
  // How far from their targets the last touches found the surface (recentTargetError).
  double recent_target_error_m{std::nan("")};
  // The initial model (action 0) and every action, as the ROS exploration node records them.
  std::vector<gpatlas_core::ExplorationRecord> history;
  std::string error;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

// The largest variance over one fixed surface sample (SurfaceSampler's defaults: 600 seeds, seed
// 7); NaN when the surface cannot be sampled.
double sampledMaxVariance(const gpatlas_core::SurfaceModel& model) {
  const gpatlas_core::SurfaceSample sample = gpatlas_core::SurfaceSampler().sample(model);
  return sample.ok ? sample.maxVariance() : std::nan("");
}

// The RMSE of the distances whose mask entry equals `in`; NaN when there are none.
double maskedRmse(const std::vector<double>& distances, const std::vector<bool>& mask, bool in) {
  double sum_squared = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < distances.size() && i < mask.size(); ++i)
    if (mask[i] == in) {
      sum_squared += distances[i] * distances[i];
      ++n;
    }
  return n > 0 ? std::sqrt(sum_squared / static_cast<double>(n)) : std::nan("");
}

// Truth-to-predicted RMSE over parts of the truth (GroundTruth's masks); NaN where not measured.
struct TruthSubsetRmse {
  double reachable{std::nan("")};
  double seen{std::nan("")};
  double unseen{std::nan("")};
};

gpatlas_geometry::ShapeMetricsResult measure(const gpatlas_core::SurfaceModel& model, const GroundTruth& gt,
                                         const Options& o, const std::string& save_as = "",
                                         TruthSubsetRmse* subsets = nullptr) {
  const auto mesh_start = std::chrono::steady_clock::now();
  // The variances only colour a saved mesh.
  gpatlas_geometry::SurfaceMesher::Config mesh_config = o.pipeline.mesh;
  mesh_config.vertex_variances = !save_as.empty();
  const auto surface = gpatlas_geometry::SurfaceMesher(mesh_config).mesh(model);
  const double mesh_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - mesh_start).count();
  if (o.verbose)
    std::cout << "  [" << gt.name << "] mesh: " << surface.mesh.triangles.size() << " triangles on a "
              << surface.grid_size.transpose() << " grid in " << mesh_s << " s" << std::endl;
  if (!surface.ok || surface.mesh.empty()) {
    gpatlas_geometry::ShapeMetricsResult failed;
    failed.message = "no predicted surface: " + surface.message;
    return failed;
  }
  if (!save_as.empty()) {
    const std::string error = gpatlas_core::writePly(surface.mesh, save_as);
    if (!error.empty()) std::cerr << "gpatlas_bench: --save-meshes: " << error << std::endl;
  }
  gpatlas_geometry::ShapeMetrics::Config metrics_config;
  metrics_config.keep_truth_distances = subsets && (gt.reachability_measured || !gt.sample_seen.empty());
  const auto metrics_start = std::chrono::steady_clock::now();
  gpatlas_geometry::ShapeMetricsResult metrics = gpatlas_geometry::ShapeMetrics(metrics_config).compare(surface.mesh, gt.mesh);
  if (o.verbose)
    std::cout << "  [" << gt.name << "] shape metrics in "
              << std::chrono::duration<double>(std::chrono::steady_clock::now() - metrics_start).count() << " s"
              << std::endl;
  const std::vector<double>& distances = metrics.truth_to_predicted_distances;
  if (metrics.ok && subsets && gt.reachability_measured && distances.size() == gt.sample_reachable.size())
    subsets->reachable = maskedRmse(distances, gt.sample_reachable, true);
  if (metrics.ok && subsets && distances.size() == gt.sample_seen.size()) {
    subsets->seen = maskedRmse(distances, gt.sample_seen, true);
    subsets->unseen = maskedRmse(distances, gt.sample_seen, false);
  }
  metrics.truth_to_predicted_distances = {};  // 20000 numbers per run, not needed after this
  return metrics;
}

RunResult runOne(const GroundTruth& gt, const std::string& strategy_name, int seed, const Options& o,
                 std::mutex& print_mutex) {
  const auto start = std::chrono::steady_clock::now();
  const probe_sim::PipelineConfig& pipeline = o.pipeline;
  RunResult r;
  r.object = gt.name;
  r.strategy = strategy_name;
  r.probe = o.simulation.probe;
  r.seed = seed;
  r.v_max = pipeline.exploration.v_max;
  const auto failed = [&r](const std::string& what) {
    r.error = what;
    r.stop_reason = "error";
    return r;
  };

  const Eigen::AlignedBox3d box = gt.mesh.boundingBox();
  // The scene probe_sim_node simulates, from the same simulation section.
  const probe_sim::SimulationSettings& simulation = o.simulation;
  auto scene = std::make_shared<probe_sim::Scene>(gt.mesh, probe_sim::sceneConfig(simulation));
  std::string camera_error;
  const std::optional<Eigen::Isometry3d> camera_pose = probe_sim::cameraPose(simulation, o.urdf_xml, &camera_error);
  if (!camera_pose) return failed(camera_error);
  const Eigen::Vector3d eye = camera_pose->translation();
  // The camera's noise follows the run's seed, as in probe_sim_node.
  probe_sim::DepthCamera camera(probe_sim::cameraConfig(simulation, static_cast<std::uint32_t>(seed + 1)), *camera_pose);
  const probe_sim::DepthCloud cloud = camera.capture(*scene);
  // The cloud as probe_sim_node publishes it (float32 coordinates in the camera's frame), moved
  // to the world frame: the segmentation then sees what the pipeline's sees.
  std::vector<Vector3> scene_points;
  for (Eigen::Index i = 0; i < cloud.points_camera.cols(); ++i)
    scene_points.push_back(*camera_pose * Vector3(cloud.points_camera.col(i).cast<float>().cast<double>()));

  // What the pipeline does with a camera cloud: segmentation, then the view builder.
  const gpatlas_geometry::SegmentationResult segmented =
      gpatlas_geometry::ObjectSegmenter(pipeline.segmentation).segment(scene_points);
  if (!segmented.ok) return failed("segmentation: " + segmented.message);
  if (o.verbose) {
    const gpatlas_geometry::SegmentationStats& n = segmented.stats;
    Eigen::AlignedBox3d kept;
    for (const Vector3& p : segmented.object_points) kept.extend(p);
    std::lock_guard<std::mutex> lock(print_mutex);
    std::cout << "  [" << gt.name << " seed " << seed << "] segmentation: " << segmented.message << "; "
              << n.input << " points, " << n.after_crop << " in the crop box, " << n.after_voxel << " after the voxel grid, "
              << n.plane_inliers << " on the " << (segmented.plane_found ? "support plane" : "plane (not a support)")
              << ", " << n.after_outliers << " after outlier removal; kept from " << kept.min().transpose() << " to "
              << kept.max().transpose() << " (the truth: " << box.min().transpose() << " to " << box.max().transpose()
              << ")" << std::endl;
  }
  std::optional<gpatlas_core::SupportPlane> support;
  if (pipeline.use_support_plane && segmented.plane_found)
    support = gpatlas_core::SupportPlane{segmented.plane_normal, segmented.plane_offset};
  const gpatlas_core::ViewTraining view = gpatlas_core::buildViewTraining(
      segmented.object_points, eye, support, pipeline.view, static_cast<std::uint64_t>(seed));
  if (!view.ok) return failed("view: " + view.message);
  if (o.verbose) {
    std::lock_guard<std::mutex> lock(print_mutex);
    std::cout << "  [" << gt.name << " seed " << seed << "] view: " << view.message << std::endl;
  }
  std::unique_ptr<gpatlas_core::SurfaceModel> model_ptr;
  try {
    model_ptr = gpatlas_core::makeSurfaceModel(pipeline.model);
  } catch (const std::exception& e) {
    return failed(std::string("model/type: ") + e.what());
  }
  gpatlas_core::SurfaceModel& model = *model_ptr;
  const auto fit = model.fit(view.points);
  if (!fit.ok) return failed("initial fit failed: " + fit.message);
  if (pipeline.tuning.enabled) model.tune(pipeline.tuning.tuner);

  gpatlas_core::StrategyConfig strategy_config = pipeline.strategy;
  strategy_config.seed = static_cast<std::uint64_t>(seed);
  const auto strategy = gpatlas_core::makeStrategy(strategy_name, strategy_config);
  const std::unique_ptr<probe_sim::SimulatedProber> prober_ptr =
      probe_sim::makeSimulatedProber(scene, simulation, pipeline.approach);
  probe_sim::SimulatedProber& prober = *prober_ptr;
  if (simulation.use_arm) {
    gpatlas_motion::Arm::Config arm_config;
    arm_config.base_link = simulation.world_frame;
    arm_config.tip_link = simulation.tip_frame;
    try {
      prober.setArm(std::make_shared<const gpatlas_motion::Arm>(gpatlas_motion::Arm::fromUrdfString(o.urdf_xml, arm_config)));
    } catch (const std::exception& e) {
      return failed(std::string("simulation/use_arm: ") + e.what());
    }
  }
  gpatlas_core::Explorer::Config loop = pipeline.exploration;
  loop.seed = static_cast<std::uint64_t>(seed);
  gpatlas_core::EvidenceState known;  // the planner's own: the table
  known.support_plane = support;
  const gpatlas_core::Explorer explorer(loop);

  const auto measureInto = [&](const gpatlas_core::SurfaceModel& m, gpatlas_core::ExplorationRecord& record) {
    record.sampled_max_variance = sampledMaxVariance(m);
    const auto metrics = measure(m, gt, o);
    if (metrics.ok) {
      record.rmse_pred_to_gt_m = metrics.rmse_predicted_to_truth;
      record.rmse_gt_to_pred_m = metrics.rmse_truth_to_predicted;
    }
  };
  std::unique_ptr<gpatlas_geometry::MeshDistanceIndex> gt_index;
  if (o.verbose) gt_index = std::make_unique<gpatlas_geometry::MeshDistanceIndex>(gt.mesh);
  gpatlas_core::ExplorationRecord initial;
  initial.index = -1;
  initial.n_train = model.observations().size();
  if (o.curve_every > 0) measureInto(model, initial);
  const auto progress = [&](gpatlas_core::ExplorationRecord& rec) {
    if (o.curve_every > 0 && (rec.index + 1) % o.curve_every == 0) measureInto(model, rec);
    if (!o.verbose) return;
    std::ostringstream line;
    line << "  [" << gt.name << " " << strategy_name << " seed " << seed << "] " << gpatlas_core::describeAction(rec);
    if (!rec.touch.points.empty()) {
      // How far the planned target is from the real surface: a touch aimed far from it
      // tells the prediction (not the planner) is wrong there.
      const gpatlas_core::Vector3& target = rec.touch.points.back();
      line << ", target (" << std::setprecision(3) << target.x() << ", " << target.y() << ", " << target.z() << ") m, "
           << 1000.0 * gt_index->distance(target) << " mm from the true surface";
    }
    std::lock_guard<std::mutex> lock(print_mutex);
    std::cout << line.str() << std::endl;
  };
  std::unique_ptr<gpatlas_motion::ModelTouchApproacher> approacher;
  if (pipeline.approach.enabled) {
    try {
      std::shared_ptr<const gpatlas_motion::Arm> planned_arm;
      if (pipeline.approach.use_arm) {
        gpatlas_motion::Arm::Config arm_config;
        arm_config.base_link = pipeline.approach.arm_base_link;
        arm_config.tip_link = pipeline.approach.arm_tip_link;
        arm_config.link_radius_m = pipeline.approach.arm_link_radius_m;
        planned_arm = std::make_shared<const gpatlas_motion::Arm>(gpatlas_motion::Arm::fromUrdfString(o.urdf_xml, arm_config));
      }
      approacher = std::make_unique<gpatlas_motion::ModelTouchApproacher>(
          model, pipeline.approach, pipeline.collision_map.grid, support, planned_arm);
    } catch (const std::exception& e) {
      return failed(std::string("approach/use_arm: ") + e.what());
    }
  }
  gpatlas_core::ExplorationResult result =
      explorer.run(model, *strategy, prober, pipeline.touch, known, progress, approacher.get());

  r.actions = result.actions;
  r.contacts = result.contacts;
  r.stop_reason = result.stop_reason;
  r.n_train = model.observations().size();
  r.max_evaluated_variance = result.final_max_evaluated_variance;
  std::vector<double> plan_ms, update_ms;
  for (const auto& rec : result.records) {
    plan_ms.push_back(rec.plan_ms);
    update_ms.push_back(rec.update_ms);
  }
  r.plan_ms_median = median(plan_ms);
  r.update_ms_median = median(update_ms);
  r.approach_plan_ms_median = gpatlas_core::approachPlanMsMedian(result);
  r.recent_target_error_m = gpatlas_core::recentTargetError(result);
  r.unreachable_touches = result.unreachable_touches;
  r.unreachable_candidates = result.unreachable_candidates;
  r.final_unreachable_candidates = result.final_unreachable_candidates;
  r.approach_collisions = result.approach_collisions;
  r.retreat_collisions = result.retreat_collisions;
  const std::string mesh_file =
      o.save_meshes ? (fs::path(o.out) / (gt.name + "_" + strategy_name + "_seed" + std::to_string(seed) + ".ply")).string()
                    : std::string();
  TruthSubsetRmse subsets;
  r.metrics = measure(model, gt, o, mesh_file, &subsets);
  r.rmse_gt_to_pred_reachable = subsets.reachable;
  r.rmse_gt_to_pred_seen = subsets.seen;
  r.rmse_gt_to_pred_unseen = subsets.unseen;
  const gpatlas_core::CalibrationResult calibration = gpatlas_core::surfaceCalibration(model, gt.calibration_samples);
  if (calibration.ok) {
    r.calibration = calibration.fraction;
    r.position_sd_m = calibration.median_position_sd_m;
  }
  // A run that leaves no predicted surface is an error whatever the loop said.
  r.status = gpatlas_core::runStatus(result, r.metrics.ok, r.metrics.message);
  r.converged = r.status == "converged";
  if (!r.metrics.ok) r.error = r.metrics.message;
  if (!result.records.empty()) {
    // The final model's numbers do not depend on the curve's schedule.
    gpatlas_core::ExplorationRecord& last = result.records.back();
    if (std::isnan(last.sampled_max_variance)) last.sampled_max_variance = sampledMaxVariance(model);
    if (r.metrics.ok) {
      last.rmse_pred_to_gt_m = r.metrics.rmse_predicted_to_truth;
      last.rmse_gt_to_pred_m = r.metrics.rmse_truth_to_predicted;
    }
  }
  r.history.push_back(initial);
  r.history.insert(r.history.end(), result.records.begin(), result.records.end());
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

std::string num(double v, int precision = 6) {
  if (!std::isfinite(v)) return "nan";
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

// A CSV field: quoted when it holds a comma or a quote.
std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

void writeRunsCsv(const std::vector<RunResult>& runs, const fs::path& path) {
  std::ofstream f(path);
  f << "object,strategy,probe,seed,vmax,actions,contacts,converged,status,stop_reason,n_train,rmse_pred_to_gt_m,"
       "rmse_gt_to_pred_m,rmse_gt_to_pred_seen_m,rmse_gt_to_pred_unseen_m,chamfer_l1_m,fscore_5mm,calibration_2sd,"
       "position_sd_m,max_evaluated_variance,wall_s,plan_ms_median,"
       "update_ms_median,unreachable_touches,unreachable_candidates,final_unreachable_candidates,approach_collisions,"
       "retreat_collisions,approach_plan_ms_median,recent_target_error_m\n";
  for (const auto& r : runs) {
    const bool ok = r.metrics.ok;
    f << r.object << ',' << r.strategy << ',' << r.probe << ',' << r.seed << ',' << num(r.v_max) << ',' << r.actions
      << ',' << r.contacts << ',' << (r.converged ? 1 : 0) << ',' << csvField(r.status) << ',' << csvField(r.stop_reason)
      << ',' << r.n_train << ','
      << (ok ? num(r.metrics.rmse_predicted_to_truth) : "nan") << ','
      << (ok ? num(r.metrics.rmse_truth_to_predicted) : "nan") << ',' << num(r.rmse_gt_to_pred_seen) << ','
      << num(r.rmse_gt_to_pred_unseen) << ',' << (ok ? num(r.metrics.chamfer_l1) : "nan")
      << ',' << (ok ? num(r.metrics.f_score) : "nan") << ',' << num(r.calibration) << ',' << num(r.position_sd_m) << ','
      << num(r.max_evaluated_variance) << ','
      << num(r.wall_s, 4) << ',' << num(r.plan_ms_median, 4) << ',' << num(r.update_ms_median, 4) << ','
      << r.unreachable_touches << ',' << r.unreachable_candidates << ',' << r.final_unreachable_candidates << ','
      << r.approach_collisions << ',' << r.retreat_collisions << ',' << num(r.approach_plan_ms_median, 4) << ','
      << num(r.recent_target_error_m) << '\n';
  }
}

void writeHistoryCsv(const std::vector<RunResult>& runs, const fs::path& path) {
  std::ofstream f(path);
  f << "object,strategy,seed,action,contacts_total,max_evaluated_variance,rmse_pred_to_gt_m,rmse_gt_to_pred_m,"
       "plan_ms,probe_ms,update_ms,n_train,sampled_max_variance,unreachable_touches,unreachable_candidates,approach_collisions,"
       "retreat_collisions,approach_ms,approach_plan_ms,target_error_m\n";
  for (const auto& r : runs)
    for (const auto& h : r.history) {
      const bool initial = h.index < 0;
      f << r.object << ',' << r.strategy << ',' << r.seed << ',' << h.index + 1 << ',' << h.contacts_total << ','
        << (initial ? "nan" : num(h.max_evaluated_variance)) << ',' << num(h.rmse_pred_to_gt_m) << ','
        << num(h.rmse_gt_to_pred_m) << ',' << num(h.plan_ms, 4) << ',' << num(h.probe_ms, 4) << ','
        << num(h.update_ms, 4) << ',' << h.n_train << ',' << num(h.sampled_max_variance) << ','
        << h.approach_refusals << ',' << h.unreachable_candidates << ',' << h.approach_collisions << ',' << h.retreat_collisions << ','
        << num(h.approach_ms, 4) << ',' << num(h.approach_compute_ms, 4) << ',' << num(h.target_error_m) << '\n';
    }
}

void writeReachabilityCsv(const std::vector<RunResult>& runs, const std::vector<GroundTruth>& objects,
                          const fs::path& path) {
  std::ofstream f(path);
  f << "object,strategy,seed,reachable_area_fraction,floor_rmse_gt_to_pred_m,rmse_gt_to_pred_reachable_m\n";
  for (const auto& r : runs) {
    const auto gt = std::find_if(objects.begin(), objects.end(), [&](const GroundTruth& g) { return g.name == r.object; });
    if (gt == objects.end() || !gt->reachability_measured) continue;
    f << r.object << ',' << r.strategy << ',' << r.seed << ',' << num(gt->reachable_area_fraction) << ','
      << num(gt->floor_rmse_gt_to_pred) << ',' << num(r.rmse_gt_to_pred_reachable) << '\n';
  }
}

// Planning time grows with the model's size and a run's median mixes plans made on models of
// very different sizes, so the plans are also pooled by model size: those at n_train of about 1000.
constexpr std::size_t kPlanBandLow = 800, kPlanBandHigh = 1200;

struct PlanTimes {
  std::string strategy;
  std::vector<double> all_ms, band_ms;  // every plan; the plans made at n_train in the band
};

std::vector<PlanTimes> planTimesByStrategy(const std::vector<RunResult>& runs) {
  std::vector<PlanTimes> out;
  for (const auto& r : runs) {
    auto it = std::find_if(out.begin(), out.end(), [&](const PlanTimes& p) { return p.strategy == r.strategy; });
    if (it == out.end()) it = out.insert(out.end(), PlanTimes{r.strategy, {}, {}});
    for (const auto& h : r.history) {
      if (h.index < 0) continue;  // the initial model has no plan
      it->all_ms.push_back(h.plan_ms);
      if (h.n_train >= kPlanBandLow && h.n_train <= kPlanBandHigh) it->band_ms.push_back(h.plan_ms);
    }
  }
  return out;
}

std::string describePlanTimes(const PlanTimes& p) {
  std::ostringstream s;
  s << p.strategy << ": " << std::fixed << std::setprecision(1);
  if (p.all_ms.empty()) s << "no plans";
  else s << "median " << median(p.all_ms) << " ms over " << p.all_ms.size() << " plans";
  s << "; at n_train " << kPlanBandLow << "-" << kPlanBandHigh << ": ";
  if (p.band_ms.empty()) s << "no plans";
  else s << "median " << median(p.band_ms) << " ms over " << p.band_ms.size() << " plans";
  return s.str();
}

void writeSummary(const std::vector<RunResult>& runs, const std::vector<GroundTruth>& truths,
                  const std::vector<PlanTimes>& plan_times, const Options& o, const fs::path& path) {
  std::vector<std::string> objects, strategies;
  for (const auto& r : runs) {
    if (std::find(objects.begin(), objects.end(), r.object) == objects.end()) objects.push_back(r.object);
    if (std::find(strategies.begin(), strategies.end(), r.strategy) == strategies.end())
      strategies.push_back(r.strategy);
  }
  // A run that failed (an error, or no predicted surface) is counted, not averaged in.
  struct Acc {
    double actions = 0, rmse_p = 0, rmse_g = 0, mean_nn = 0, conv = 0, f_score = 0, calibration = 0;
    int n = 0, failed = 0, calibrated = 0;
  };
  std::map<std::pair<std::string, std::string>, Acc> acc;
  std::map<std::string, Acc> mean_of_strategy;
  for (const auto& r : runs) {
    const bool failed = r.status.rfind("error", 0) == 0 || !r.metrics.ok;
    for (Acc* a : {&acc[{r.object, r.strategy}], &mean_of_strategy[r.strategy]}) {
      if (failed) {
        ++a->failed;
        continue;
      }
      a->actions += r.actions;
      a->conv += r.converged ? 1 : 0;
      ++a->n;
      a->rmse_p += r.metrics.rmse_predicted_to_truth;
      a->rmse_g += r.metrics.rmse_truth_to_predicted;
      a->mean_nn += r.metrics.chamfer_l1;
      a->f_score += r.metrics.f_score;
      if (std::isfinite(r.calibration)) {
        a->calibration += r.calibration;
        ++a->calibrated;
      }
    }
  }
  std::ofstream f(path);
  f << "# gpatlas_bench summary\n\n";
  f << "config `" << o.config_path << "`";
  for (const auto& overlay : o.overlays) f << " --overlay " << overlay;
  for (const auto& assignment : o.overrides) f << " --set " << assignment;
  f << ", probe `" << o.simulation.probe << "`, V_max " << o.pipeline.exploration.v_max << ", seeds";
  for (int s : o.seeds) f << ' ' << s;
  f << ", max actions " << o.pipeline.exploration.max_actions << (o.simulation.table ? ", on a table" : ", no table") << ".\n";
  f << "Per cell, over the runs that left a predicted surface: mean actions, mean RMSE predicted->truth / "
       "truth->predicted (m), the mean nearest-neighbour distance over both directions (chamfer_l1_m, the "
       "paper's kind of number; m), the F-score at 5 mm, the calibration (the share of true-surface samples whose "
       "predicted f is within 2 sd of 0; 0.95 is calibrated), converged runs / runs; failed runs (errors, no surface) are counted after "
       "a '+' and left out of the means.\n\n";
  f << "| object |";
  for (const auto& s : strategies)
    f << ' ' << s << " steps | " << s << " RMSE p->g / g->p | " << s << " mean NN | " << s << " F@5mm | " << s
      << " calibration | " << s << " conv |";
  f << "\n|---|";
  for (std::size_t i = 0; i < strategies.size(); ++i) f << "---|---|---|---|---|---|";
  f << '\n';
  auto cells = [&](const Acc& a) {
    std::ostringstream s;
    if (a.n == 0) {
      s << " - | - | - | - | - | 0/0 +" << a.failed << " failed |";
      return s.str();
    }
    const double n = a.n;
    s << ' ' << std::fixed << std::setprecision(1) << a.actions / n << " | " << std::setprecision(4) << a.rmse_p / n
      << " / " << a.rmse_g / n << " | " << a.mean_nn / n << " | " << std::setprecision(3) << a.f_score / n << " | ";
    if (a.calibrated > 0) s << a.calibration / a.calibrated;
    else s << '-';
    s << " | " << static_cast<int>(a.conv) << '/' << a.n;
    if (a.failed > 0) s << " +" << a.failed << " failed";
    s << " |";
    return s.str();
  };
  for (const auto& obj : objects) {
    f << "| " << obj << " |";
    for (const auto& s : strategies) f << cells(acc[{obj, s}]);
    f << '\n';
  }
  f << "| **mean** |";
  for (const auto& s : strategies) f << cells(mean_of_strategy[s]);
  f << '\n';

  f << "\nPlanning time per touch (history.csv: plan_ms, and n_train, the model size each plan saw):\n\n";
  for (const auto& p : plan_times) f << "- " << describePlanTimes(p) << '\n';

  if (std::none_of(truths.begin(), truths.end(), [](const GroundTruth& g) { return g.reachability_measured; })) return;
  f << "\nThe truth a camera or a ray probe outside the object can reach (reachability.csv): its share of "
       "the truth's area, the floor under truth->predicted RMSE that the rest sets (m), and per strategy "
       "the mean truth->predicted RMSE over the reachable truth only (m).\n\n| object | reachable area | floor g->p |";
  for (const auto& s : strategies) f << ' ' << s << " g->p reachable |";
  f << "\n|---|---|---|";
  for (std::size_t i = 0; i < strategies.size(); ++i) f << "---|";
  f << '\n';
  std::map<std::string, std::pair<double, int>> strategy_mean;
  double fraction_sum = 0.0, floor_sum = 0.0;
  int measured_objects = 0, floor_objects = 0;
  for (const auto& gt : truths) {
    if (!gt.reachability_measured) continue;
    ++measured_objects;
    fraction_sum += gt.reachable_area_fraction;
    if (std::isfinite(gt.floor_rmse_gt_to_pred)) {
      floor_sum += gt.floor_rmse_gt_to_pred;
      ++floor_objects;
    }
    f << "| " << gt.name << " | " << std::fixed << std::setprecision(2) << gt.reachable_area_fraction << " | "
      << std::setprecision(4) << gt.floor_rmse_gt_to_pred << " |";
    for (const auto& s : strategies) {
      double sum = 0.0;
      int n = 0;
      for (const auto& r : runs)
        if (r.object == gt.name && r.strategy == s && std::isfinite(r.rmse_gt_to_pred_reachable)) {
          sum += r.rmse_gt_to_pred_reachable;
          ++n;
          strategy_mean[s].first += r.rmse_gt_to_pred_reachable;
          ++strategy_mean[s].second;
        }
      if (n) f << ' ' << sum / n << " |";
      else f << " - |";
    }
    f << '\n';
  }
  f << "| **mean** | " << std::setprecision(2) << fraction_sum / std::max(1, measured_objects) << " | "
    << std::setprecision(4) << floor_sum / std::max(1, floor_objects) << " |";
  for (const auto& s : strategies) {
    const auto& m = strategy_mean[s];
    if (m.second) f << ' ' << m.first / m.second << " |";
    else f << " - |";
  }
  f << '\n';
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  try {
    o = parseArgs(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "gpatlas_bench: " << e.what() << std::endl;
    return 2;
  }
  std::vector<GroundTruth> objects;
  for (const auto& object : o.objects) {
    try {
      objects.push_back(loadObject(object.spec, object.scale, o));
    } catch (const std::exception& e) {
      std::cerr << "gpatlas_bench: cannot load object '" << object.spec << "': " << e.what() << std::endl;
      return 2;
    }
  }
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) {
    std::cerr << "gpatlas_bench: cannot create output folder '" << o.out << "': " << ec.message() << std::endl;
    return 2;
  }
  if (o.save_meshes) {
    // The truth as the runs saw it (scaled and placed on the table), to compare with the saved
    // predictions in other tools.
    for (const auto& gt : objects) {
      const std::string error = gpatlas_core::writePly(gt.mesh, (fs::path(o.out) / (gt.name + "_truth.ply")).string());
      if (!error.empty()) std::cerr << "gpatlas_bench: --save-meshes: " << error << std::endl;
    }
  }

  if (o.reachability) {
    // Once per object, before the runs, on the same workers (40-60 s per 40k-triangle scan).
    std::atomic<std::size_t> next_object{0};
    std::mutex reach_print_mutex;
    auto reach_worker = [&] {
      for (std::size_t i = next_object++; i < objects.size(); i = next_object++) {
        GroundTruth& gt = objects[i];
        const auto started = std::chrono::steady_clock::now();
        try {
          measureReachability(gt, o.simulation, o.reach_directions);
        } catch (const std::exception& e) {
          // The runs do not need it: they go on without the reachable-truth numbers.
          gt.reachability_measured = false;
          std::lock_guard<std::mutex> lock(reach_print_mutex);
          std::cerr << "gpatlas_bench: " << gt.name << ": reachability not measured: " << e.what() << std::endl;
          continue;
        }
        std::lock_guard<std::mutex> lock(reach_print_mutex);
        std::cout << "gpatlas_bench: " << gt.name << ": " << std::setprecision(3) << 100.0 * gt.reachable_area_fraction
                  << " % of the truth's area is reachable from outside; the rest sets a floor of "
                  << 1000.0 * gt.floor_rmse_gt_to_pred << " mm under truth->predicted RMSE ("
                  << std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count() << " s)"
                  << std::defaultfloat << std::endl;
      }
    };
    std::vector<std::thread> reach_threads;
    for (int t = 0; t < std::min<int>(o.jobs, static_cast<int>(objects.size())); ++t) reach_threads.emplace_back(reach_worker);
    for (auto& t : reach_threads) t.join();
  }

  struct Job {
    std::size_t object;
    std::string strategy;
    int seed;
  };
  std::vector<Job> jobs;
  for (std::size_t i = 0; i < objects.size(); ++i)
    for (const auto& s : o.strategies)
      for (int seed : o.seeds) jobs.push_back({i, s, seed});
  std::vector<RunResult> runs(jobs.size());
  std::atomic<std::size_t> next{0};
  std::atomic<std::size_t> done{0};
  std::mutex print_mutex;
  const auto bench_start = std::chrono::steady_clock::now();
  std::cout << "gpatlas_bench: " << jobs.size() << " run(s) on " << o.jobs << " worker(s), output in " << o.out
            << std::endl;

  auto worker = [&] {
    for (std::size_t j = next++; j < jobs.size(); j = next++) {
      RunResult r;
      try {
        r = runOne(objects[jobs[j].object], jobs[j].strategy, jobs[j].seed, o, print_mutex);
      } catch (const std::exception& e) {
        r.object = objects[jobs[j].object].name;
        r.strategy = jobs[j].strategy;
        r.probe = o.simulation.probe;
        r.seed = jobs[j].seed;
        r.v_max = o.pipeline.exploration.v_max;
        r.stop_reason = "error";
        r.status = std::string("error: ") + e.what();
        r.error = e.what();
      }
      runs[j] = r;
      std::lock_guard<std::mutex> lock(print_mutex);
      const std::size_t finished = ++done;
      std::cout << "[" << finished << "/" << jobs.size() << "] " << r.object << " " << r.strategy << " seed "
                << r.seed << ": " << r.actions << " actions, " << r.contacts << " contacts, " << r.status;
      if (r.final_unreachable_candidates > 0)
        std::cout << " (" << r.final_unreachable_candidates << " candidates left out of reach)";
      if (r.metrics.ok)
        std::cout << ", RMSE " << std::setprecision(3) << r.metrics.rmse_predicted_to_truth * 1000 << " / "
                  << r.metrics.rmse_truth_to_predicted * 1000 << " mm, F@5mm " << r.metrics.f_score;
      if (std::isfinite(r.rmse_gt_to_pred_reachable))
        std::cout << ", reachable truth->predicted " << r.rmse_gt_to_pred_reachable * 1000 << " mm";
      if (std::isfinite(r.rmse_gt_to_pred_seen))
        std::cout << " (seen by the camera " << r.rmse_gt_to_pred_seen * 1000 << " mm, unseen "
                  << r.rmse_gt_to_pred_unseen * 1000 << " mm)";
      if (std::isfinite(r.calibration))
        std::cout << ", calibration " << r.calibration << " (median position sd " << r.position_sd_m * 1000 << " mm)";
      std::cout << ", plan median " << std::setprecision(4) << r.plan_ms_median << " ms, " << std::setprecision(3)
                << r.wall_s << " s";
      if (!r.error.empty()) std::cout << " (" << r.error << ")";
      std::cout << std::defaultfloat << std::endl;
    }
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < std::min<int>(o.jobs, static_cast<int>(jobs.size())); ++t) threads.emplace_back(worker);
  for (auto& t : threads) t.join();

  const fs::path out(o.out);
  writeRunsCsv(runs, out / "runs.csv");
  writeHistoryCsv(runs, out / "history.csv");
  writeReachabilityCsv(runs, objects, out / "reachability.csv");
  const std::vector<PlanTimes> plan_times = planTimesByStrategy(runs);
  writeSummary(runs, objects, plan_times, o, out / "summary.md");
  for (const auto& p : plan_times) std::cout << "planning time, " << describePlanTimes(p) << std::endl;
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - bench_start).count();
  std::cout << "gpatlas_bench: done in " << std::setprecision(4) << total_s << " s; wrote " << (out / "runs.csv").string()
            << ", " << (out / "history.csv").string() << ", " << (out / "reachability.csv").string() << ", "
            << (out / "summary.md").string() << std::endl;
#ifdef GPATLAS_PLOT_SCRIPT
  if (o.plot) {
    const std::string cmd = "/usr/bin/python3 \"" GPATLAS_PLOT_SCRIPT "\" \"" + out.string() + "\"";
    if (std::system(cmd.c_str()) != 0) std::cerr << "gpatlas_bench: plotting failed (" << cmd << ")" << std::endl;
  }
#endif
  int errors = 0;
  for (const auto& r : runs) errors += r.status.rfind("error", 0) == 0 ? 1 : 0;
  if (errors > 0) std::cerr << "gpatlas_bench: " << errors << " run(s) ended in an error (runs.csv: status)" << std::endl;
  return errors > 0 ? 1 : 0;
}
