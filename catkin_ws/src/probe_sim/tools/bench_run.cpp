#include "bench_run.h"

#include "bench_oracle.h"

#include <gpatlas_core/common/triangle_mesh.h>
#include <gpatlas_core/exploration/exploration_report.h>
#include <gpatlas_core/model/surface_model_factory.h>
#include <gpatlas_core/observations/view_training.h>
#include <gpatlas_core/observations/view_update.h>
#include <gpatlas_core/planning/strategy_registry.h>
#include <gpatlas_geometry/model_measurement.h>
#include <gpatlas_geometry/segmentation.h>
#include <gpatlas_motion/touch_approach.h>
#include <probe_sim/depth_camera.h>
#include <probe_sim/probe.h>
#include <probe_sim/scene.h>
#include <probe_sim/simulation_settings.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

namespace gpatlas_bench {

namespace {

using gpatlas_core::Vector3;

RunResult failedRun(RunResult r, const std::string& why) {
  r.error = why;
  r.stop_reason = "error";
  return r;
}

// The object as the pipeline sees it: the camera's cloud segmented, with its table, as the
// view's training data.
struct ObjectView {
  gpatlas_core::ViewTraining training;
  std::optional<gpatlas_core::SupportPlane> support;
  // The camera's origin and the object's points: what the view left unobserved (its shadow).
  gpatlas_core::CameraView camera;
  // The whole cloud (world frame): the collision map's scene.
  std::vector<Vector3> scene_points;
};

// The cloud as probe_sim_node publishes it (float32 coordinates in the camera's frame), moved to
// the world frame: the segmentation then sees what the pipeline's sees. The camera's noise follows
// the run's seed, as in probe_sim_node.
std::vector<Vector3> captureCloud(const probe_sim::Scene& scene, const Eigen::Isometry3d& camera_pose,
                                  const probe_sim::SimulationSettings& simulation, int seed) {
  probe_sim::DepthCamera camera(probe_sim::cameraConfig(simulation, static_cast<std::uint32_t>(seed + 1)), camera_pose);
  const probe_sim::DepthCloud cloud = camera.capture(scene);
  std::vector<Vector3> scene_points;
  for (Eigen::Index i = 0; i < cloud.points_camera.cols(); ++i)
    scene_points.push_back(camera_pose * Vector3(cloud.points_camera.col(i).cast<float>().cast<double>()));
  return scene_points;
}

void printSegmentation(const GroundTruth& gt, int seed, const gpatlas_geometry::SegmentationResult& segmented,
                       std::mutex& print_mutex) {
  const Eigen::AlignedBox3d box = gt.mesh.boundingBox();
  const gpatlas_geometry::SegmentationStats& n = segmented.stats;
  Eigen::AlignedBox3d kept;
  for (const Vector3& p : segmented.object_points) kept.extend(p);
  std::lock_guard<std::mutex> lock(print_mutex);
  std::cout << "  [" << gt.name << " seed " << seed << "] segmentation: " << segmented.message << "; "
            << n.input << " points, " << n.after_crop << " in the crop box, " << n.after_voxel << " after the voxel grid, "
            << n.plane_inliers << " on the " << (segmented.plane_found ? "support plane" : "plane (not a support)")
            << ", " << n.after_plane << " above it; kept from " << kept.min().transpose() << " to "
            << kept.max().transpose() << " (the truth: " << box.min().transpose() << " to " << box.max().transpose()
            << ")" << std::endl;
}

// What the pipeline does with a camera cloud: segmentation, then the view builder. False, with
// the reason in `why`, when the run cannot go on.
bool observeObject(const probe_sim::Scene& scene, const GroundTruth& gt, int seed, const Options& o,
                   std::mutex& print_mutex, ObjectView* view, std::string* why) {
  const std::optional<Eigen::Isometry3d> camera_pose = probe_sim::cameraPose(o.simulation, o.urdf_xml, why);
  if (!camera_pose) return false;
  gpatlas_geometry::ObjectSegmenter::Config segmentation = o.pipeline.segmentation;
  // Among neighbours the largest cluster need not be the object: the bench points at it, as a
  // user gives segmentation/object_hint_m or calls ~select_object.
  if (!o.simulation.neighbours.empty() && !segmentation.object_hint_m)
    segmentation.object_hint_m = gt.mesh.boundingBox().center();
  view->scene_points = captureCloud(scene, *camera_pose, o.simulation, seed);
  const gpatlas_geometry::SegmentationResult segmented =
      gpatlas_geometry::ObjectSegmenter(segmentation).segment(view->scene_points);
  if (!segmented.ok) {
    *why = "segmentation: " + segmented.message;
    return false;
  }
  if (o.verbose) printSegmentation(gt, seed, segmented, print_mutex);
  if (o.pipeline.use_support_plane && segmented.plane_found)
    view->support = gpatlas_core::SupportPlane{segmented.plane_normal, segmented.plane_offset};
  view->camera = {camera_pose->translation(), segmented.object_points};
  view->training = gpatlas_core::buildViewTraining(segmented.object_points, camera_pose->translation(), view->support,
                                                   o.pipeline.view, static_cast<std::uint64_t>(seed));
  if (!view->training.ok) {
    *why = "view: " + view->training.message;
    return false;
  }
  if (o.verbose) {
    std::lock_guard<std::mutex> lock(print_mutex);
    std::cout << "  [" << gt.name << " seed " << seed << "] view: " << view->training.message << std::endl;
  }
  return true;
}

// The initial model: the view fitted as the GP nodelet fits it.
bool fitInitialModel(const ObjectView& view, const probe_sim::PipelineConfig& pipeline, bool verbose,
                     std::unique_ptr<gpatlas_core::SurfaceModel>* model, std::string* why) {
  try {
    *model = gpatlas_core::makeSurfaceModel(pipeline.model);
  } catch (const std::exception& e) {
    *why = std::string("model/type: ") + e.what();
    return false;
  }
  const gpatlas_core::ViewUpdate fit = gpatlas_core::applyView(
      **model, view.training.points, pipeline.touch, &pipeline.position_calibration);
  if (!fit.ok) *why = "initial fit failed: " + fit.fit.message;
  if (fit.calibration && !fit.calibration->ok)
    std::cerr << "gpatlas_bench: position sd not calibrated: " << fit.calibration->message << std::endl;
  else if (fit.calibration && verbose)
    std::cout << "  calibration: " << fit.calibration->message << std::endl;
  return fit.ok;
}

// The simulated probe in the scene, moved by the robot's arm when the simulation has one; null,
// with the reason in `why`, when the arm cannot be built.
std::unique_ptr<probe_sim::SimulatedProber> makeProber(std::shared_ptr<probe_sim::Scene> scene, const Options& o,
                                                       std::string* why) {
  std::unique_ptr<probe_sim::SimulatedProber> prober =
      probe_sim::makeSimulatedProber(std::move(scene), o.simulation, o.pipeline.approach);
  if (!o.simulation.use_arm) return prober;
  gpatlas_motion::Arm::Config arm_config;
  arm_config.base_link = o.simulation.world_frame;
  arm_config.tip_link = o.simulation.tip_frame;
  try {
    prober->setArm(std::make_shared<const gpatlas_motion::Arm>(gpatlas_motion::Arm::fromUrdfString(o.urdf_xml, arm_config)));
  } catch (const std::exception& e) {
    *why = std::string("simulation/use_arm: ") + e.what();
    return nullptr;
  }
  return prober;
}

// The simulated prober, tallying the touches whose way there or back met a neighbour; with
// --verbose, a line saying what each collision on the way met.
class NeighbourTally : public gpatlas_core::Prober {
 public:
  NeighbourTally(probe_sim::SimulatedProber& prober, const Options& o, std::string label, std::mutex& print_mutex)
      : prober_(prober), verbose_(o.verbose), label_(std::move(label)), print_mutex_(print_mutex) {}
  gpatlas_core::ProbeResult probe(const gpatlas_core::Touch& touch) override {
    gpatlas_core::ProbeResult result = prober_.probe(touch);
    const unsigned met = prober_.lastWayCollisionKinds();
    if (met & static_cast<unsigned>(probe_sim::SurfaceKind::kObstacle)) ++touches;
    if (verbose_ && met != 0) {
      std::string what;
      for (const auto kind : {probe_sim::SurfaceKind::kObject, probe_sim::SurfaceKind::kTable, probe_sim::SurfaceKind::kObstacle})
        if (met & static_cast<unsigned>(kind)) what += std::string(what.empty() ? "" : ", ") + probe_sim::toString(kind);
      std::lock_guard<std::mutex> lock(print_mutex_);
      std::cout << "  [" << label_ << "] the way there and back met: " << what << std::endl;
    }
    return result;
  }
  int touches{0};

 private:
  probe_sim::SimulatedProber& prober_;
  bool verbose_;
  std::string label_;
  std::mutex& print_mutex_;
};

// Approach planning on the model (approach/enabled), for the arm's links with approach/use_arm,
// with the camera's scene in its map as the collision map nodelet has it (collision_map/scene_*).
bool makeApproacher(const gpatlas_core::SurfaceModel& model, const ObjectView& view, const Options& o,
                    std::unique_ptr<gpatlas_motion::ModelTouchApproacher>* approacher, std::string* why) {
  const gpatlas_motion::ApproachConfig& approach = o.pipeline.approach;
  if (!approach.enabled) return true;
  try {
    std::shared_ptr<const gpatlas_motion::Arm> planned_arm;
    if (approach.use_arm) {
      gpatlas_motion::Arm::Config arm_config;
      arm_config.base_link = approach.arm_base_link;
      arm_config.tip_link = approach.arm_tip_link;
      arm_config.link_radius_m = approach.arm_link_radius_m;
      planned_arm = std::make_shared<const gpatlas_motion::Arm>(gpatlas_motion::Arm::fromUrdfString(o.urdf_xml, arm_config));
    }
    *approacher = std::make_unique<gpatlas_motion::ModelTouchApproacher>(model, approach, o.pipeline.collision_map.grid,
                                                                         view.support, planned_arm);
    if (o.pipeline.scene_map.enabled) {
      auto scene = std::make_shared<gpatlas_motion::SceneMap>(o.pipeline.scene_map, o.pipeline.collision_map.grid.resolution_m);
      scene->insertCloud(view.scene_points, view.camera.origin);
      (*approacher)->setScene(std::move(scene), view.camera.points);
    }
  } catch (const std::exception& e) {
    *why = std::string("approach/use_arm: ") + e.what();
    return false;
  }
  return true;
}

// Truth-to-predicted RMSE over parts of the truth (GroundTruth's masks); NaN where not measured.
struct TruthSubsetRmse {
  double reachable{std::nan("")};
  double seen{std::nan("")};
  double unseen{std::nan("")};
};

// The model measured against the object's truth; with `subsets`, also over the parts of the
// truth the object's masks mark.
gpatlas_geometry::ModelMeasurement measure(const gpatlas_core::SurfaceModel& model, const GroundTruth& gt,
                                           const Options& o, const gpatlas_geometry::SurfaceMesher::Config& mesher,
                                           gpatlas_geometry::MeasurementRequest request,
                                           TruthSubsetRmse* subsets = nullptr) {
  request.truth_distances = subsets && (gt.reachability_measured || !gt.sample_seen.empty());
  gpatlas_geometry::ModelMeasurement measured = gpatlas_geometry::measureModel(model, gt.mesh, mesher, request);
  if (o.verbose) {
    std::cout << "  [" << gt.name << "] mesh: " << measured.surface.mesh.triangles.size() << " triangles on a "
              << measured.surface.grid_size.transpose() << " grid in " << measured.mesh_s << " s (the variance's sample: "
              << measured.sample_s << " s)" << std::endl;
    if (measured.surface.ok && !measured.surface.mesh.empty())
      std::cout << "  [" << gt.name << "] shape metrics in " << measured.metrics_s << " s" << std::endl;
  }
  const std::vector<double>& distances = measured.shape.truth_to_predicted_distances;
  if (measured.shape.ok && subsets && gt.reachability_measured && distances.size() == gt.sample_reachable.size())
    subsets->reachable = gpatlas_geometry::maskedRmse(distances, gt.sample_reachable, true);
  if (measured.shape.ok && subsets && distances.size() == gt.sample_seen.size()) {
    subsets->seen = gpatlas_geometry::maskedRmse(distances, gt.sample_seen, true);
    subsets->unseen = gpatlas_geometry::maskedRmse(distances, gt.sample_seen, false);
  }
  measured.shape.truth_to_predicted_distances = {};  // 20000 numbers per run, not needed after this
  return measured;
}

// A point of the shape's curve (history.csv): the shape error at the curve's quality
// (Options::curve_resolution_m, curve_samples; the final model is measured again at full quality)
// and every --variance-every actions the sampled variance.
gpatlas_geometry::SurfaceMesher::Config curveMesher(const Options& o) {
  gpatlas_geometry::SurfaceMesher::Config mesher = o.pipeline.mesh;
  mesher.resolution_m = o.curve_resolution_m;
  return mesher;
}

gpatlas_geometry::MeasurementRequest curveRequest(const Options& o) {
  gpatlas_geometry::MeasurementRequest request;
  request.shape.samples_per_mesh = static_cast<std::size_t>(o.curve_samples);
  // The distance indices shrink with the samples, as many index samples per surface sample as the
  // final measurement has (ShapeMetrics' defaults).
  const gpatlas_geometry::ShapeMetrics::Config full;
  request.shape.index.index_samples = full.index.index_samples * request.shape.samples_per_mesh / full.samples_per_mesh;
  return request;
}

void measureInto(const gpatlas_core::SurfaceModel& model, const GroundTruth& gt, const Options& o,
                 gpatlas_core::ExplorationRecord& record) {
  gpatlas_geometry::MeasurementRequest request = curveRequest(o);
  request.sampled_max_variance = (record.index + 1) % o.variance_every == 0;
  const gpatlas_geometry::ModelMeasurement measured = measure(model, gt, o, curveMesher(o), request);
  record.sampled_max_variance = measured.sampled_max_variance;
  if (measured.shape.ok) {
    record.rmse_pred_to_gt_m = measured.shape.rmse_predicted_to_truth;
    record.rmse_gt_to_pred_m = measured.shape.rmse_truth_to_predicted;
    record.fscore_5mm = measured.shape.f_score;
  }
}

// After each action: the curve's point every --curve-every actions, and with --verbose one line
// that says how far the touch's target was from the true surface.
gpatlas_core::Explorer::Progress progressOf(const gpatlas_core::SurfaceModel& model, const GroundTruth& gt,
                                            const std::string& strategy_name, int seed, const Options& o,
                                            std::mutex& print_mutex) {
  std::shared_ptr<const gpatlas_geometry::MeshDistanceIndex> gt_index;
  if (o.verbose) gt_index = std::make_shared<const gpatlas_geometry::MeshDistanceIndex>(gt.mesh);
  return [&model, &gt, strategy_name, seed, &o, &print_mutex, gt_index](gpatlas_core::ExplorationRecord& rec) {
    if (o.curve_every > 0 && (rec.index + 1) % o.curve_every == 0) measureInto(model, gt, o, rec);
    if (!o.verbose) return;
    std::ostringstream line;
    line << "  [" << gt.name << " " << strategy_name << " seed " << seed << "] " << gpatlas_core::describeAction(rec);
    if (!rec.touch.points.empty()) {
      // How far the planned target is from the real surface: a touch aimed far from it
      // tells the prediction (not the planner) is wrong there.
      const Vector3& target = rec.touch.points.back();
      line << ", target (" << std::setprecision(3) << target.x() << ", " << target.y() << ", " << target.z() << ") m, "
           << 1000.0 * gt_index->distance(target) << " mm from the true surface";
    }
    std::lock_guard<std::mutex> lock(print_mutex);
    std::cout << line.str() << std::endl;
  };
}

// The loop's counts and timings.
void recordLoop(const gpatlas_core::ExplorationResult& result, const gpatlas_core::SurfaceModel& model, RunResult& r) {
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
  // 0, not NaN, for a run without an action: runs.csv's columns are numbers.
  r.plan_ms_median = plan_ms.empty() ? 0.0 : gpatlas_core::median(plan_ms);
  r.update_ms_median = update_ms.empty() ? 0.0 : gpatlas_core::median(update_ms);
  r.approach_plan_ms_median = gpatlas_core::approachPlanMsMedian(result);
  r.recent_target_error_m = gpatlas_core::recentTargetError(result);
  r.unreachable_touches = result.unreachable_touches;
  r.unreachable_candidates = result.unreachable_candidates;
  r.final_unreachable_candidates = result.final_unreachable_candidates;
  r.final_unreachable_area_fraction = result.final_unreachable_area_fraction;
  r.out_of_reach_note = gpatlas_core::outOfReachNote(result);
  r.approach_collisions = result.approach_collisions;
  r.retreat_collisions = result.retreat_collisions;
  r.guarded_entries = result.guarded_entries;
}

// The contacts the model took, one line each: action (1-based), x, y, z in metres (world frame),
// for the per-object plot's views. Empty string on success, else the reason.
std::string writeContacts(const gpatlas_core::ExplorationResult& result, const std::string& path) {
  std::ofstream out(path);
  if (!out) return "cannot open '" + path + "' for writing";
  out << "action,x,y,z\n" << std::setprecision(9);
  for (const gpatlas_core::ExplorationRecord& record : result.records)
    for (const Vector3& p : record.contact_positions)
      out << record.index + 1 << ',' << p.x() << ',' << p.y() << ',' << p.z() << '\n';
  out.flush();
  return out ? std::string() : "write to '" + path + "' failed";
}

// The final model against the truth: the run's shape metrics, calibration and status, saved
// with --save-meshes (the mesh and the contacts); the last action's record gets the same numbers.
void measureFinalModel(const gpatlas_core::SurfaceModel& model, const GroundTruth& gt, const Options& o,
                       gpatlas_core::ExplorationResult& result, RunResult& r) {
  const std::string run_stem =
      (std::filesystem::path(o.out) / (r.object + "_" + r.strategy + "_seed" + std::to_string(r.seed))).string();
  const std::string mesh_file = o.save_meshes ? run_stem + ".ply" : std::string();
  gpatlas_geometry::MeasurementRequest request;
  // The final model's sampled variance does not depend on the curve's schedule.
  request.sampled_max_variance = !result.records.empty() && std::isnan(result.records.back().sampled_max_variance);
  request.vertex_variances = !mesh_file.empty();  // they only colour a saved mesh
  request.vertex_position_sd = !mesh_file.empty();
  request.calibration = true;
  TruthSubsetRmse subsets;
  const gpatlas_geometry::ModelMeasurement measured = measure(model, gt, o, o.pipeline.mesh, request, &subsets);
  if (!mesh_file.empty() && measured.surface.ok && !measured.surface.mesh.empty()) {
    const std::string error = gpatlas_core::writePly(measured.surface.mesh, mesh_file);
    if (!error.empty()) std::cerr << "gpatlas_bench: --save-meshes: " << error << std::endl;
  }
  if (o.save_meshes) {
    const std::string error = writeContacts(result, run_stem + "_contacts.csv");
    if (!error.empty()) std::cerr << "gpatlas_bench: --save-meshes: " << error << std::endl;
  }
  r.metrics = measured.shape;
  r.rmse_gt_to_pred_reachable = subsets.reachable;
  r.rmse_gt_to_pred_seen = subsets.seen;
  r.rmse_gt_to_pred_unseen = subsets.unseen;
  if (measured.calibration.ok) {
    r.calibration = measured.calibration.fraction;
    r.position_sd_m = measured.calibration.median_position_sd_m;
    r.coverage = measured.calibration.coverage;
    r.sharpness = measured.calibration.sharpness;
  }
  // A run that leaves no predicted surface is an error whatever the loop said.
  r.status = gpatlas_core::runStatus(result, r.metrics.ok, r.metrics.message);
  r.converged = r.status == "converged";
  if (!r.metrics.ok) r.error = r.metrics.message;
  if (result.records.empty()) return;
  gpatlas_core::ExplorationRecord& last = result.records.back();
  if (std::isnan(last.sampled_max_variance)) last.sampled_max_variance = measured.sampled_max_variance;
  if (r.metrics.ok) {
    last.rmse_pred_to_gt_m = r.metrics.rmse_predicted_to_truth;
    last.rmse_gt_to_pred_m = r.metrics.rmse_truth_to_predicted;
    last.fscore_5mm = r.metrics.f_score;
  }
}

// oracle_poke (bench_oracle.h): its own prober on the run's scene, F@5mm against the truth as the
// curve's points measure it, and a line per plan.
std::unique_ptr<gpatlas_core::ExplorationStrategy> makeOracle(std::shared_ptr<probe_sim::Scene> scene,
                                                              const GroundTruth& gt, const Options& o,
                                                              gpatlas_core::ParamReader& settings, std::uint64_t seed,
                                                              const std::string& label, std::mutex& print_mutex,
                                                              std::string* why) {
  std::shared_ptr<probe_sim::SimulatedProber> prober = makeProber(std::move(scene), o, why);
  if (!prober) return nullptr;
  OracleStrategy::Config config;
  auto score = [&gt, &o](const gpatlas_core::SurfaceModel& model) {
    const gpatlas_geometry::ModelMeasurement measured = measure(model, gt, o, curveMesher(o), curveRequest(o));
    return measured.shape.ok ? measured.shape.f_score : std::nan("");
  };
  auto plans = std::make_shared<int>(0);
  auto report = [label, &print_mutex, plans](const OraclePlan& plan) {
    const OracleCandidate& best = plan.candidates[plan.best];
    std::ostringstream line;
    line << std::setprecision(3) << "  [" << label << "] oracle plan " << ++*plans << ": " << plan.candidates.size()
         << " candidates, F@5mm " << plan.score_before << " -> best " << best.score << " (" << describe(best)
         << "); atlas_poke's " << plan.candidates.front().score;
    for (const OracleCandidate& c : plan.candidates)
      if (c.source == "max_variance 1") line << ", max_variance's " << c.score;
    line << "; " << plan.seconds << " s";
    std::lock_guard<std::mutex> lock(print_mutex);
    std::cout << line.str() << std::endl;
  };
  return std::make_unique<OracleStrategy>(
      config, settings, seed, [prober](const gpatlas_core::Touch& touch) { return prober->probe(touch); }, score, report);
}

}  // namespace

RunResult runIdentity(const GroundTruth& gt, const std::string& strategy_name, int seed, const Options& o) {
  RunResult r;
  r.object = gt.name;
  r.strategy = strategy_name;
  r.probe = o.simulation.probe;
  r.seed = seed;
  r.v_max = o.pipeline.exploration.v_max;
  r.max_position_sd_m = o.pipeline.exploration.max_position_sd_m;
  r.curve_every = o.curve_every;
  return r;
}

RunResult runOne(const GroundTruth& gt, const std::string& strategy_name, int seed, const Options& o,
                 std::mutex& print_mutex) {
  const auto start = std::chrono::steady_clock::now();
  const probe_sim::PipelineConfig& pipeline = o.pipeline;
  RunResult r = runIdentity(gt, strategy_name, seed, o);
  std::string why;
  // The scene probe_sim_node simulates, from the same simulation section.
  std::shared_ptr<probe_sim::Scene> scene;
  try {
    scene = probe_sim::makeSimulatedScene(o.simulation, gt.mesh);
  } catch (const std::exception& e) {
    return failedRun(r, e.what());
  }
  ObjectView view;
  std::unique_ptr<gpatlas_core::SurfaceModel> model;
  if (!observeObject(*scene, gt, seed, o, print_mutex, &view, &why) || !fitInitialModel(view, pipeline, o.verbose, &model, &why))
    return failedRun(r, why);

  const std::string label = gt.name + " " + strategy_name + " seed " + std::to_string(seed);
  std::unique_ptr<gpatlas_core::ExplorationStrategy> strategy;
  {
    // The strategy reads its settings from the configuration, whose YAML tree is not safe to
    // read from several runs' threads at once.
    static std::mutex settings_mutex;
    const std::lock_guard<std::mutex> lock(settings_mutex);
    gpatlas_core::ParamReader settings(*o.settings);
    const auto run_seed = static_cast<std::uint64_t>(seed);
    strategy = strategy_name == kOracleStrategy
                   ? makeOracle(scene, gt, o, settings, run_seed, label, print_mutex, &why)
                   : gpatlas_core::makeStrategy(strategy_name, settings, run_seed);
    if (!settings.ok()) return failedRun(r, settings.errors());
  }
  if (!strategy) return failedRun(r, why);
  const std::unique_ptr<probe_sim::SimulatedProber> prober = makeProber(scene, o, &why);
  if (!prober) return failedRun(r, why);
  gpatlas_core::Explorer::Config loop = pipeline.exploration;
  loop.seed = static_cast<std::uint64_t>(seed);
  gpatlas_core::EvidenceState known;  // the planner's own: the table and the view
  known.support_plane = view.support;
  known.views = {view.camera};

  gpatlas_core::ExplorationRecord initial;
  initial.index = -1;
  initial.n_train = model->observations().size();
  if (o.curve_every > 0) {
    const auto measure_start = std::chrono::steady_clock::now();
    measureInto(*model, gt, o, initial);
    initial.progress_ms = 1000.0 * std::chrono::duration<double>(std::chrono::steady_clock::now() - measure_start).count();
  }
  std::unique_ptr<gpatlas_motion::ModelTouchApproacher> approacher;
  if (!makeApproacher(*model, view, o, &approacher, &why)) return failedRun(r, why);
  NeighbourTally tally(*prober, o, label, print_mutex);
  gpatlas_core::ExplorationResult result =
      gpatlas_core::Explorer(loop).run(*model, *strategy, tally, pipeline.touch, known,
                                       progressOf(*model, gt, strategy_name, seed, o, print_mutex), approacher.get());

  recordLoop(result, *model, r);
  r.neighbour_collision_touches = tally.touches;
  r.position_sd_scale = model->positionSdScale();
  measureFinalModel(*model, gt, o, result, r);
  r.history.push_back(initial);
  r.history.insert(r.history.end(), result.records.begin(), result.records.end());
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

std::string measuredAs(const RunResult& r, std::size_t i) {
  if (i + 1 == r.history.size() && r.history[i].index >= 0) return "final";  // measureFinalModel's
  const int action = r.history[i].index + 1;
  return r.curve_every > 0 && action % r.curve_every == 0 ? "curve" : "";
}

}  // namespace gpatlas_bench
