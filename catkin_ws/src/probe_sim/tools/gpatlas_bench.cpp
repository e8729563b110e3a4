// gpatlas_bench: the paper's simulated exploration protocol without ROS.
//
// For every (object, strategy, seed): place the object on the table, take one simulated depth
// view from a fixed camera pose (a partial view), downsample it to the initial training set,
// fit the GPIS, then run the exploration loop (Algorithm 2) with the chosen strategy against the
// simulated probe on the ground-truth mesh, and measure the predicted shape against the mesh.
// Writes runs.csv, history.csv, reachability.csv, summary.md, one PNG per object and anytime.png
// into --out.
// With --shard K/N it runs a share of the runs, and --merge joins the shards' folders (for a
// cluster's job array: scripts/slurm_bench.sh).
// The command line: bench_options.h; the objects: bench_truth.h; one run: bench_run.h; the
// files: bench_outputs.h; shards and their merge: bench_shards.h; oracle_poke, an analysis that
// reads the truth: bench_oracle.h.

#include "bench_options.h"
#include "bench_outputs.h"
#include "bench_run.h"
#include "bench_shards.h"
#include "bench_truth.h"

#include <gpatlas_core/common/triangle_mesh.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace gpatlas_bench {

namespace {

namespace fs = std::filesystem;

// Runs `work(i)` for i in [0, count) on up to `workers` threads.
template <typename Work>
void forEachOnWorkers(std::size_t count, int workers, const Work& work) {
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    for (std::size_t i = next++; i < count; i = next++) work(i);
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < std::min<int>(workers, static_cast<int>(count)); ++t) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
}

// Once per object that `jobs` runs, before the runs, on the same workers (40-60 s per
// 40k-triangle scan, so a shard skips the objects it does not run; an object's numbers do not
// depend on the others).
void measureReachabilityOfObjectsRun(std::vector<GroundTruth>& objects, const std::vector<Job>& jobs,
                                     const Options& o) {
  std::vector<std::size_t> needed;
  for (std::size_t i = 0; i < objects.size(); ++i)
    if (std::any_of(jobs.begin(), jobs.end(), [&](const Job& job) { return job.object == i; })) needed.push_back(i);
  std::mutex print_mutex;
  forEachOnWorkers(needed.size(), o.jobs, [&](std::size_t n) {
    GroundTruth& gt = objects[needed[n]];
    const auto started = std::chrono::steady_clock::now();
    try {
      measureReachability(gt, o.simulation, o.reach_directions);
    } catch (const std::exception& e) {
      // The runs do not need it: they go on without the reachable-truth numbers.
      gt.reachability_measured = false;
      std::lock_guard<std::mutex> lock(print_mutex);
      std::cerr << "gpatlas_bench: " << gt.name << ": reachability not measured: " << e.what() << std::endl;
      return;
    }
    std::lock_guard<std::mutex> lock(print_mutex);
    std::cout << "gpatlas_bench: " << gt.name << ": " << std::setprecision(3) << 100.0 * gt.reachable_area_fraction
              << " % of the truth's area is reachable from outside; the rest sets a floor of "
              << 1000.0 * gt.floor_rmse_gt_to_pred << " mm under truth->predicted RMSE ("
              << std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count() << " s)"
              << std::defaultfloat << std::endl;
  });
}

// The run's line on the console, the n-th of `total` to finish.
void printRun(const RunResult& r, std::size_t finished, std::size_t total) {
  std::cout << "[" << finished << "/" << total << "] " << r.object << " " << r.strategy << " seed " << r.seed << ": "
            << r.actions << " actions, " << r.contacts << " contacts, " << r.status;
  std::cout << r.out_of_reach_note;
  if (r.metrics.ok)
    std::cout << ", RMSE " << std::setprecision(3) << r.metrics.rmse_predicted_to_truth * 1000 << " / "
              << r.metrics.rmse_truth_to_predicted * 1000 << " mm, F@5mm " << r.metrics.f_score;
  if (std::isfinite(r.rmse_gt_to_pred_reachable))
    std::cout << ", reachable truth->predicted " << r.rmse_gt_to_pred_reachable * 1000 << " mm";
  if (std::isfinite(r.rmse_gt_to_pred_seen))
    std::cout << " (seen by the camera " << r.rmse_gt_to_pred_seen * 1000 << " mm, unseen "
              << r.rmse_gt_to_pred_unseen * 1000 << " mm)";
  if (std::isfinite(r.calibration))
    std::cout << ", calibration " << r.calibration << " (median position sd " << r.position_sd_m * 1000
              << " mm, coverage " << r.coverage << ", sharpness " << r.sharpness << ", scale " << r.position_sd_scale << ")";
  std::cout << ", plan median " << std::setprecision(4) << r.plan_ms_median << " ms, " << std::setprecision(3)
            << r.wall_s << " s";
  // The curve's cost: its measurements' share of the run's wall time.
  double curve_ms = 0.0;
  int curve_points = 0;
  for (const auto& h : r.history) {
    curve_ms += h.progress_ms;
    curve_points += r.curve_every > 0 && (h.index + 1) % r.curve_every == 0 ? 1 : 0;
  }
  if (r.curve_every > 0 && r.wall_s > 0.0)
    std::cout << " (the curve's " << curve_points << " measurements " << std::setprecision(3) << curve_ms / 1000.0
              << " s of it, " << std::setprecision(2) << 100.0 * curve_ms / 1000.0 / r.wall_s << " %)";
  if (!r.error.empty()) std::cout << " (" << r.error << ")";
  std::cout << std::defaultfloat << std::endl;
}

// The jobs on o.jobs workers, in their order in the result.
std::vector<RunResult> runAll(const std::vector<GroundTruth>& objects, const std::vector<Job>& jobs, const Options& o) {
  std::vector<RunResult> runs(jobs.size());
  std::atomic<std::size_t> done{0};
  std::mutex print_mutex;
  std::cout << "gpatlas_bench: " << jobs.size() << " run(s) on " << o.jobs << " worker(s), output in " << o.out
            << std::endl;
  forEachOnWorkers(jobs.size(), o.jobs, [&](std::size_t j) {
    const GroundTruth& gt = objects[jobs[j].object];
    RunResult r;
    try {
      r = runOne(gt, jobs[j].strategy, jobs[j].seed, o, print_mutex);
    } catch (const std::exception& e) {
      r = runIdentity(gt, jobs[j].strategy, jobs[j].seed, o);
      r.stop_reason = "error";
      r.status = std::string("error: ") + e.what();
      r.error = e.what();
    }
    runs[j] = r;
    std::lock_guard<std::mutex> lock(print_mutex);
    printRun(r, ++done, jobs.size());
  });
  return runs;
}

// The objects of the command line; false (said on stderr) when one cannot be loaded.
bool loadObjects(const Options& o, std::vector<GroundTruth>* objects) {
  for (const auto& object : o.objects) {
    try {
      objects->push_back(loadObject(object.spec, object.scale, o));
    } catch (const std::exception& e) {
      std::cerr << "gpatlas_bench: cannot load object '" << object.spec << "': " << e.what() << std::endl;
      return false;
    }
  }
  return true;
}

// The truth as the runs saw it (scaled and placed on the table), to compare with the saved
// predictions in other tools.
void saveTruths(const std::vector<GroundTruth>& objects, const Options& o) {
  for (const auto& gt : objects) {
    const std::string error = gpatlas_core::writePly(gt.mesh, (fs::path(o.out) / (gt.name + "_truth.ply")).string());
    if (!error.empty()) std::cerr << "gpatlas_bench: --save-meshes: " << error << std::endl;
  }
}

// summary.md from the CSV files of `out`, the planning times on the console, and the plots.
void summarizeFolder(const fs::path& out, const std::string& settings, bool plot,
                     const std::vector<std::string>& missing_jobs = {}) {
  for (const auto& p : writeSummaryOfFolder(out, settings, missing_jobs))
    std::cout << "planning time, " << describePlanTimes(p) << std::endl;
#ifdef GPATLAS_PLOT_SCRIPT
  if (plot) {
    const std::string cmd = "/usr/bin/python3 \"" GPATLAS_PLOT_SCRIPT "\" \"" + out.string() + "\"";
    if (std::system(cmd.c_str()) != 0) std::cerr << "gpatlas_bench: plotting failed (" << cmd << ")" << std::endl;
  }
#else
  (void)plot;
#endif
}

void writeOutputs(const std::vector<RunResult>& runs, const std::vector<GroundTruth>& objects, const Options& o,
                  std::chrono::steady_clock::time_point bench_start) {
  const fs::path out(o.out);
  writeRunsCsv(runs, out / "runs.csv");
  writeHistoryCsv(runs, out / "history.csv");
  writeReachabilityCsv(runs, objects, out / "reachability.csv");
  summarizeFolder(out, summarySettings(o), o.plot);
  const double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - bench_start).count();
  std::cout << "gpatlas_bench: done in " << std::setprecision(4) << total_s << " s; wrote " << (out / "runs.csv").string()
            << ", " << (out / "history.csv").string() << ", " << (out / "reachability.csv").string() << ", "
            << (out / "summary.md").string() << std::endl;
}

// --merge: the shards' folders into o.out; 2 when refused, 1 when jobs are missing or runs
// ended in an error (as a one-process run), else 0.
int mergeMain(const Options& o) {
  MergeResult merged;
  try {
    merged = mergeShards(o.merge_folders, o.out);
    summarizeFolder(o.out, merged.summary_settings, o.plot, merged.missing_jobs);
  } catch (const std::exception& e) {
    std::cerr << "gpatlas_bench: --merge: " << e.what() << std::endl;
    return 2;
  }
  std::cout << "gpatlas_bench: merged " << merged.merged_runs << " run(s) of " << o.merge_folders.size()
            << " shard folder(s) into " << o.out << std::endl;
  if (!merged.missing_jobs.empty()) {
    std::cerr << "gpatlas_bench: --merge: " << merged.missing_jobs.size() << " of "
              << merged.missing_jobs.size() + merged.merged_runs << " jobs are missing (no shard folder given ran them):";
    for (const std::string& job : merged.missing_jobs) std::cerr << "\n  " << job;
    std::cerr << std::endl;
  }
  if (merged.error_runs > 0)
    std::cerr << "gpatlas_bench: " << merged.error_runs << " run(s) ended in an error (runs.csv: status)" << std::endl;
  return merged.missing_jobs.empty() && merged.error_runs == 0 ? 0 : 1;
}

}  // namespace

}  // namespace gpatlas_bench

int main(int argc, char** argv) {
  using namespace gpatlas_bench;
  Options o;
  try {
    Options defaults;
    defaults.config_path = GPATLAS_DEFAULT_CONFIG;
    defaults.simulation_path = GPATLAS_DEFAULT_SIMULATION;
    defaults.urdf_path = GPATLAS_VITO_URDF;
    o = parseArgs(argc, argv, std::move(defaults));
  } catch (const std::exception& e) {
    std::cerr << "gpatlas_bench: " << e.what() << std::endl;
    return 2;
  }
  if (!o.merge_folders.empty()) return mergeMain(o);
  std::vector<GroundTruth> objects;
  if (!loadObjects(o, &objects)) return 2;
  const std::vector<Job> all_jobs = jobList(objects.size(), o);
  std::vector<Job> jobs;
  for (std::size_t j = 0; j < all_jobs.size(); ++j)
    if (!o.shard || inShard(j, *o.shard)) jobs.push_back(all_jobs[j]);
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) {
    std::cerr << "gpatlas_bench: cannot create output folder '" << o.out << "': " << ec.message() << std::endl;
    return 2;
  }
  // A shard.txt says the folder holds a finished shard: not while this one runs.
  if (o.shard) fs::remove(fs::path(o.out) / "shard.txt", ec);
  if (o.save_meshes) saveTruths(objects, o);
  if (o.reachability) measureReachabilityOfObjectsRun(objects, jobs, o);
  const auto bench_start = std::chrono::steady_clock::now();
  const std::vector<RunResult> runs = runAll(objects, jobs, o);
  try {
    writeOutputs(runs, objects, o, bench_start);
    // Last: a shard's folder with a shard.txt holds all of its runs.
    if (o.shard) writeShardFile(o.out, *o.shard, all_jobs, objects, o);
  } catch (const std::exception& e) {
    std::cerr << "gpatlas_bench: " << e.what() << std::endl;
    return 2;
  }
  int errors = 0;
  for (const auto& r : runs) errors += r.status.rfind("error", 0) == 0 ? 1 : 0;
  if (errors > 0) std::cerr << "gpatlas_bench: " << errors << " run(s) ended in an error (runs.csv: status)" << std::endl;
  return errors > 0 ? 1 : 0;
}
