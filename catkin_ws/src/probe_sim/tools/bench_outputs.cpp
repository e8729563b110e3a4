#include "bench_outputs.h"

#include "bench_tables.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <ostream>
#include <sstream>
#include <utility>

namespace gpatlas_bench {

using gpatlas_core::median;
using gpatlas_core::quantile;

namespace {

namespace fs = std::filesystem;

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


// "median m / p95 p / max x ms (n)", or "none".
std::string distribution(const std::vector<double>& v) {
  if (v.empty()) return "none";
  std::ostringstream s;
  s << std::fixed << std::setprecision(1) << "median " << median(v) << " / p95 " << quantile(v, 0.95) << " / max "
    << quantile(v, 1.0) << " ms (" << v.size() << ")";
  return s.str();
}

// One cell of the summary's table: sums over the runs that left a predicted surface; a run that
// failed (an error, or no predicted surface) is counted, not averaged in.
struct CellSums {
  double actions = 0, rmse_p = 0, rmse_g = 0, mean_nn = 0, conv = 0, f_score = 0, coverage = 0, sharpness = 0;
  int n = 0, failed = 0, calibrated = 0;

  void add(const RunResult& r) {
    if (r.status.rfind("error", 0) == 0 || !r.metrics.ok) {
      ++failed;
      return;
    }
    actions += r.actions;
    conv += r.converged ? 1 : 0;
    ++n;
    rmse_p += r.metrics.rmse_predicted_to_truth;
    rmse_g += r.metrics.rmse_truth_to_predicted;
    mean_nn += r.metrics.chamfer_l1;
    f_score += r.metrics.f_score;
    if (std::isfinite(r.coverage) && std::isfinite(r.sharpness)) {
      coverage += r.coverage;
      sharpness += r.sharpness;
      ++calibrated;
    }
  }

  // The cell's columns: mean actions, RMSEs, mean NN, F-score, coverage / sharpness, converged runs.
  std::string columns() const {
    std::ostringstream s;
    if (n == 0) {
      s << " - | - | - | - | - | 0/0 +" << failed << " failed |";
      return s.str();
    }
    const double count = n;
    s << ' ' << std::fixed << std::setprecision(1) << actions / count << " | " << std::setprecision(4)
      << rmse_p / count << " / " << rmse_g / count << " | " << mean_nn / count << " | " << std::setprecision(3)
      << f_score / count << " | ";
    if (calibrated > 0) s << coverage / calibrated << " / " << std::setprecision(2) << sharpness / calibrated;
    else s << '-';
    s << " | " << static_cast<int>(conv) << '/' << n;
    if (failed > 0) s << " +" << failed << " failed";
    s << " |";
    return s.str();
  }
};

void writeSummaryHeader(std::ostream& f, const std::string& settings) {
  f << "# gpatlas_bench summary\n\n";
  f << settings << "\n";
  f << "Per cell, over the runs that left a predicted surface: mean actions, mean RMSE predicted->truth / "
       "truth->predicted (m), the mean nearest-neighbour distance over both directions (chamfer_l1_m, the "
       "paper's kind of number; m), the F-score at 5 mm, the position sd's coverage (the share of true-surface samples "
       "within 2 position sd of the predicted surface; 0.90-0.99 is calibrated) / sharpness (the median position sd "
       "over the median distance; 1 is sharp, 10 ten times too vague), converged runs / runs; failed runs (errors, no surface) are counted after "
       "a '+' and left out of the means.\n\n";
}

void writeShapeTable(std::ostream& f, const std::vector<RunResult>& runs, const std::vector<std::string>& objects,
                     const std::vector<std::string>& strategies) {
  std::map<std::pair<std::string, std::string>, CellSums> cell;
  std::map<std::string, CellSums> mean_of_strategy;
  for (const auto& r : runs) {
    cell[{r.object, r.strategy}].add(r);
    mean_of_strategy[r.strategy].add(r);
  }
  f << "| object |";
  for (const auto& s : strategies)
    f << ' ' << s << " steps | " << s << " RMSE p->g / g->p | " << s << " mean NN | " << s << " F@5mm | " << s
      << " coverage / sharpness | " << s << " conv |";
  f << "\n|---|";
  for (std::size_t i = 0; i < strategies.size(); ++i) f << "---|---|---|---|---|---|";
  f << '\n';
  for (const auto& obj : objects) {
    f << "| " << obj << " |";
    for (const auto& s : strategies) f << cell[{obj, s}].columns();
    f << '\n';
  }
  f << "| **mean** |";
  for (const auto& s : strategies) f << mean_of_strategy[s].columns();
  f << '\n';
}

void writeReachabilityTable(std::ostream& f, const std::vector<RunResult>& runs, const std::vector<GroundTruth>& truths,
                            const std::vector<std::string>& strategies) {
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

// The anytime table's touch counts, and the F-score it counts the touches to.
constexpr int kAnytimeTouches[] = {5, 10, 20};
constexpr double kFscoreGoal = 0.9;

// A run's shape error after `touches` touches: its last measured point at or before them, which is
// its final measurement when it stopped earlier; NaN when it has none.
gpatlas_core::ExplorationRecord curveAt(const RunResult& r, int touches) {
  gpatlas_core::ExplorationRecord point;
  for (const auto& h : r.history)
    if (h.index + 1 <= touches && std::isfinite(h.rmse_gt_to_pred_m) && std::isfinite(h.fscore_5mm)) point = h;
  return point;
}

// The touches after which the run's curve first reached kFscoreGoal; -1 when it never did.
int touchesToGoal(const RunResult& r) {
  for (const auto& h : r.history)
    if (std::isfinite(h.fscore_5mm) && h.fscore_5mm >= kFscoreGoal) return h.index + 1;
  return -1;
}

// One cell of the anytime table: the means over the runs with a measured point, in mm.
std::string anytimeCell(const std::vector<const RunResult*>& runs, int touches) {
  double g = 0.0, p = 0.0, f = 0.0;
  int n = 0, reached = 0;
  for (const RunResult* r : runs) {
    reached += r->actions >= touches ? 1 : 0;
    const gpatlas_core::ExplorationRecord point = curveAt(*r, touches);
    if (!std::isfinite(point.rmse_gt_to_pred_m)) continue;
    g += point.rmse_gt_to_pred_m;
    p += point.rmse_pred_to_gt_m;
    f += point.fscore_5mm;
    ++n;
  }
  std::ostringstream cell;
  if (n == 0) cell << " - | - | - |";
  else
    cell << std::fixed << std::setprecision(2) << ' ' << 1000.0 * g / n << " | " << 1000.0 * p / n << " | "
         << std::setprecision(3) << f / n << " |";
  cell << ' ' << reached << '/' << runs.size() << " |";
  return cell.str();
}

// Per strategy, over its runs (every object and seed): the shape error after 5, 10 and 20
// touches, and the touches it took to reach F@5mm >= 0.9.
void writeAnytimeTable(std::ostream& f, const std::vector<RunResult>& runs, const std::vector<std::string>& strategies) {
  f << "\nAnytime: per strategy, over its runs (every object and seed), the mean shape error after 5, 10 and 20 "
       "touches (history.csv: RMSE truth->predicted g->p and predicted->truth p->g in mm, F@5mm), with the runs that "
       "made that many touches / its runs; a run that stopped earlier contributes its final value, and a run "
       "measured every K actions (--curve-every) its last measured point before. Points before the last are "
       "measured at the curve's cheaper quality (history.csv: measured). Then the touches after which F@5mm first "
       "reached 0.9: the median over the runs that reached it, and the runs that never did.\n\n| strategy |";
  for (int k : kAnytimeTouches)
    f << " g->p @" << k << " | p->g @" << k << " | F@5mm @" << k << " | reached " << k << " |";
  f << " touches to F@5mm 0.9 | never |\n|---|";
  for (std::size_t i = 0; i < std::size(kAnytimeTouches); ++i) f << "---|---|---|---|";
  f << "---|---|\n";
  for (const auto& s : strategies) {
    std::vector<const RunResult*> of_strategy;
    for (const auto& r : runs)
      if (r.strategy == s) of_strategy.push_back(&r);
    f << "| " << s << " |";
    for (int k : kAnytimeTouches) f << anytimeCell(of_strategy, k);
    std::vector<double> to_goal;
    for (const RunResult* r : of_strategy)
      if (const int t = touchesToGoal(*r); t >= 0) to_goal.push_back(t);
    if (to_goal.empty()) f << " - |";
    else f << ' ' << std::fixed << std::setprecision(1) << median(to_goal) << " |";
    f << ' ' << of_strategy.size() - to_goal.size() << " |\n";
  }
}

}  // namespace

std::string summarySettings(const Options& o) {
  std::ostringstream f;
  f << "config `" << o.config_path << "`";
  for (const auto& overlay : o.overlays) f << " --overlay " << overlay;
  for (const auto& assignment : o.overrides) f << " --set " << assignment;
  f << ", probe `" << o.simulation.probe << "`, V_max " << o.pipeline.exploration.v_max << ", max position sd ";
  if (o.pipeline.exploration.max_position_sd_m) f << *o.pipeline.exploration.max_position_sd_m << " m";
  else f << "off";
  f << ", seeds";
  for (int s : o.seeds) f << ' ' << s;
  f << ", max actions " << o.pipeline.exploration.max_actions << (o.simulation.table ? ", on a table" : ", no table") << ".";
  return f.str();
}

void writeRunsCsv(const std::vector<RunResult>& runs, const fs::path& path) {
  std::ofstream f(path);
  f << "object,strategy,probe,seed,vmax,max_position_sd_m,actions,contacts,converged,status,stop_reason,n_train,rmse_pred_to_gt_m,"
       "rmse_gt_to_pred_m,rmse_gt_to_pred_seen_m,rmse_gt_to_pred_unseen_m,chamfer_l1_m,fscore_5mm,calibration_2sd,"
       "position_sd_m,coverage_2sd,sharpness,position_sd_scale,max_evaluated_variance,wall_s,plan_ms_median,"
       "update_ms_median,unreachable_touches,unreachable_candidates,final_unreachable_candidates,"
       "final_unreachable_area_fraction,approach_collisions,retreat_collisions,neighbour_collision_touches,"
       "guarded_entries,approach_plan_ms_median,recent_target_error_m\n";
  for (const auto& r : runs) {
    const bool ok = r.metrics.ok;
    f << r.object << ',' << r.strategy << ',' << r.probe << ',' << r.seed << ',' << num(r.v_max) << ',' << (r.max_position_sd_m ? num(*r.max_position_sd_m) : "off") << ',' << r.actions
      << ',' << r.contacts << ',' << (r.converged ? 1 : 0) << ',' << csvField(r.status) << ',' << csvField(r.stop_reason)
      << ',' << r.n_train << ','
      << (ok ? num(r.metrics.rmse_predicted_to_truth) : "nan") << ','
      << (ok ? num(r.metrics.rmse_truth_to_predicted) : "nan") << ',' << num(r.rmse_gt_to_pred_seen) << ','
      << num(r.rmse_gt_to_pred_unseen) << ',' << (ok ? num(r.metrics.chamfer_l1) : "nan")
      << ',' << (ok ? num(r.metrics.f_score) : "nan") << ',' << num(r.calibration) << ',' << num(r.position_sd_m) << ','
      << num(r.coverage) << ',' << num(r.sharpness) << ',' << num(r.position_sd_scale) << ','
      << num(r.max_evaluated_variance) << ','
      << num(r.wall_s, 4) << ',' << num(r.plan_ms_median, 4) << ',' << num(r.update_ms_median, 4) << ','
      << r.unreachable_touches << ',' << r.unreachable_candidates << ',' << r.final_unreachable_candidates << ','
      << num(r.final_unreachable_area_fraction) << ',' << r.approach_collisions << ',' << r.retreat_collisions << ','
      << r.neighbour_collision_touches << ',' << r.guarded_entries << ',' << num(r.approach_plan_ms_median, 4) << ',' << num(r.recent_target_error_m) << '\n';
  }
}

void writeHistoryCsv(const std::vector<RunResult>& runs, const fs::path& path) {
  std::ofstream f(path);
  // measured: how the row's shape error was measured ("curve": at the curve's cheaper quality,
  // "final": as runs.csv, "": not); measure_ms: the bench's time on the row's model before the
  // next action, the curve's measurement (0 where there was none).
  f << "object,strategy,seed,action,contacts_total,max_evaluated_variance,rmse_pred_to_gt_m,rmse_gt_to_pred_m,"
       "fscore_5mm,plan_ms,probe_ms,update_ms,n_train,sampled_max_variance,unreachable_touches,unreachable_candidates,"
       "approach_collisions,retreat_collisions,approach_ms,approach_plan_ms,target_error_m,measured,measure_ms,"
       "plan_budget_exhausted\n";
  for (const auto& r : runs)
    for (std::size_t i = 0; i < r.history.size(); ++i) {
      const gpatlas_core::ExplorationRecord& h = r.history[i];
      const bool initial = h.index < 0;
      f << r.object << ',' << r.strategy << ',' << r.seed << ',' << h.index + 1 << ',' << h.contacts_total << ','
        << (initial ? "nan" : num(h.max_evaluated_variance)) << ',' << num(h.rmse_pred_to_gt_m) << ','
        << num(h.rmse_gt_to_pred_m) << ',' << num(h.fscore_5mm) << ',' << num(h.plan_ms, 4) << ','
        << num(h.probe_ms, 4) << ',' << num(h.update_ms, 4) << ',' << h.n_train << ',' << num(h.sampled_max_variance)
        << ',' << h.approach_refusals << ',' << h.unreachable_candidates << ',' << h.approach_collisions << ','
        << h.retreat_collisions << ',' << num(h.approach_ms, 4) << ',' << num(h.approach_compute_ms, 4) << ','
        << num(h.target_error_m) << ',' << measuredAs(r, i) << ',' << num(h.progress_ms, 4) << ','
        << (h.plan_budget_exhausted ? 1 : 0) << '\n';
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


std::vector<PlanTimes> planTimesByStrategy(const std::vector<RunResult>& runs) {
  std::vector<PlanTimes> out;
  for (const auto& r : runs) {
    auto it = std::find_if(out.begin(), out.end(), [&](const PlanTimes& p) { return p.strategy == r.strategy; });
    if (it == out.end()) it = out.insert(out.end(), PlanTimes{r.strategy, {}, {}});
    for (const auto& h : r.history) {
      if (h.index < 0) continue;  // the initial model has no plan
      it->all_ms.push_back(h.plan_ms);
      const std::size_t first = h.n_train / kTimeBinObservations * kTimeBinObservations;
      auto bin = std::find_if(it->bins.begin(), it->bins.end(), [&](const TimeBin& b) { return b.first_observations >= first; });
      if (bin == it->bins.end() || bin->first_observations != first) bin = it->bins.insert(bin, TimeBin{first, {}, {}});
      bin->plan_ms.push_back(h.plan_ms);
      // An action that found nothing to add made no update.
      if (h.update_ms > 0.0) bin->update_ms.push_back(h.update_ms);
    }
  }
  return out;
}

std::string describePlanTimes(const PlanTimes& p) {
  std::ostringstream s;
  s << p.strategy << ": " << std::fixed << std::setprecision(1);
  if (p.all_ms.empty()) return s.str() + "no plans";
  s << "median " << median(p.all_ms) << " ms over " << p.all_ms.size() << " plans";
  const TimeBin& largest = p.bins.back();
  s << "; at n_train " << largest.first_observations << "-" << largest.first_observations + kTimeBinObservations
    << ": median " << median(largest.plan_ms) << " ms over " << largest.plan_ms.size() << " plans";
  return s.str();
}

std::vector<std::string> describeTimeBins(const PlanTimes& p) {
  std::vector<std::string> lines;
  for (const TimeBin& bin : p.bins) {
    std::ostringstream s;
    s << p.strategy << ", n_train " << bin.first_observations << "-" << bin.first_observations + kTimeBinObservations
      << ": plan " << distribution(bin.plan_ms) << "; update " << distribution(bin.update_ms);
    lines.push_back(s.str());
  }
  return lines;
}


namespace {

// A merge that lacks jobs says so where the tables are read, not only on stderr.
void writeMissingJobs(std::ostream& f, const std::vector<std::string>& missing_jobs, std::size_t merged_runs) {
  if (missing_jobs.empty()) return;
  f << "**Incomplete:** " << missing_jobs.size() << " of " << missing_jobs.size() + merged_runs
    << " jobs are missing (no shard folder given to --merge ran them); the tables below leave them out:\n\n";
  for (const std::string& job : missing_jobs) f << "- " << job << '\n';
  f << '\n';
}

}  // namespace

void writeSummary(const std::vector<RunResult>& runs, const std::vector<GroundTruth>& truths,
                  const std::vector<PlanTimes>& plan_times, const std::string& settings, const fs::path& path,
                  const std::vector<std::string>& missing_jobs) {
  std::vector<std::string> objects, strategies;
  for (const auto& r : runs) {
    if (std::find(objects.begin(), objects.end(), r.object) == objects.end()) objects.push_back(r.object);
    if (std::find(strategies.begin(), strategies.end(), r.strategy) == strategies.end())
      strategies.push_back(r.strategy);
  }
  std::ofstream f(path);
  writeSummaryHeader(f, settings);
  writeMissingJobs(f, missing_jobs, runs.size());
  writeShapeTable(f, runs, objects, strategies);
  writeAnytimeTable(f, runs, strategies);
  f << "\nPlanning time per touch (history.csv: plan_ms, and n_train, the model size each plan saw):\n\n";
  for (const auto& p : plan_times) f << "- " << describePlanTimes(p) << '\n';
  f << "\nPlan and update time per model size (n_train; median / p95 / max, wall clock, and the count):\n\n";
  for (const auto& p : plan_times)
    for (const std::string& line : describeTimeBins(p)) f << "- " << line << '\n';
  if (std::any_of(truths.begin(), truths.end(), [](const GroundTruth& g) { return g.reachability_measured; }))
    writeReachabilityTable(f, runs, truths, strategies);
}

std::vector<PlanTimes> writeSummaryOfFolder(const fs::path& folder, const std::string& settings,
                                            const std::vector<std::string>& missing_jobs) {
  std::vector<RunResult> runs;
  std::vector<GroundTruth> truths;
  runsFromTables(readBenchTables(folder), &runs, &truths);
  const std::vector<PlanTimes> plan_times = planTimesByStrategy(runs);
  writeSummary(runs, truths, plan_times, settings, folder / "summary.md", missing_jobs);
  return plan_times;
}

}  // namespace gpatlas_bench
