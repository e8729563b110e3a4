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


// Planning time grows with the model's size and a run's median mixes plans made on models of
// very different sizes, so the plans are also pooled by model size: those at n_train of about 1000.
constexpr std::size_t kPlanBandLow = 800, kPlanBandHigh = 1200;

// One cell of the summary's table: sums over the runs that left a predicted surface; a run that
// failed (an error, or no predicted surface) is counted, not averaged in.
struct CellSums {
  double actions = 0, rmse_p = 0, rmse_g = 0, mean_nn = 0, conv = 0, f_score = 0, calibration = 0;
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
    if (std::isfinite(r.calibration)) {
      calibration += r.calibration;
      ++calibrated;
    }
  }

  // The cell's columns: mean actions, RMSEs, mean NN, F-score, calibration, converged runs.
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
    if (calibrated > 0) s << calibration / calibrated;
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
       "paper's kind of number; m), the F-score at 5 mm, the calibration (the share of true-surface samples whose "
       "predicted f is within 2 sd of 0; 0.95 is calibrated), converged runs / runs; failed runs (errors, no surface) are counted after "
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
      << " calibration | " << s << " conv |";
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

}  // namespace

std::string summarySettings(const Options& o) {
  std::ostringstream f;
  f << "config `" << o.config_path << "`";
  for (const auto& overlay : o.overlays) f << " --overlay " << overlay;
  for (const auto& assignment : o.overrides) f << " --set " << assignment;
  f << ", probe `" << o.simulation.probe << "`, V_max " << o.pipeline.exploration.v_max << ", seeds";
  for (int s : o.seeds) f << ' ' << s;
  f << ", max actions " << o.pipeline.exploration.max_actions << (o.simulation.table ? ", on a table" : ", no table") << ".";
  return f.str();
}

void writeRunsCsv(const std::vector<RunResult>& runs, const fs::path& path) {
  std::ofstream f(path);
  f << "object,strategy,probe,seed,vmax,actions,contacts,converged,status,stop_reason,n_train,rmse_pred_to_gt_m,"
       "rmse_gt_to_pred_m,rmse_gt_to_pred_seen_m,rmse_gt_to_pred_unseen_m,chamfer_l1_m,fscore_5mm,calibration_2sd,"
       "position_sd_m,coverage_2sd,sharpness,position_sd_scale,max_evaluated_variance,wall_s,plan_ms_median,"
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
      << num(r.coverage) << ',' << num(r.sharpness) << ',' << num(r.position_sd_scale) << ','
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
                  const std::vector<PlanTimes>& plan_times, const std::string& settings, const fs::path& path) {
  std::vector<std::string> objects, strategies;
  for (const auto& r : runs) {
    if (std::find(objects.begin(), objects.end(), r.object) == objects.end()) objects.push_back(r.object);
    if (std::find(strategies.begin(), strategies.end(), r.strategy) == strategies.end())
      strategies.push_back(r.strategy);
  }
  std::ofstream f(path);
  writeSummaryHeader(f, settings);
  writeShapeTable(f, runs, objects, strategies);
  f << "\nPlanning time per touch (history.csv: plan_ms, and n_train, the model size each plan saw):\n\n";
  for (const auto& p : plan_times) f << "- " << describePlanTimes(p) << '\n';
  if (std::any_of(truths.begin(), truths.end(), [](const GroundTruth& g) { return g.reachability_measured; }))
    writeReachabilityTable(f, runs, truths, strategies);
}

std::vector<PlanTimes> writeSummaryOfFolder(const fs::path& folder, const std::string& settings) {
  std::vector<RunResult> runs;
  std::vector<GroundTruth> truths;
  runsFromTables(readBenchTables(folder), &runs, &truths);
  const std::vector<PlanTimes> plan_times = planTimesByStrategy(runs);
  writeSummary(runs, truths, plan_times, settings, folder / "summary.md");
  return plan_times;
}

}  // namespace gpatlas_bench
