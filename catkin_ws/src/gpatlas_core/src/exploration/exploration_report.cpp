#include "gpatlas_core/exploration/exploration_report.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <vector>

namespace gpatlas_core {

namespace {

std::string jsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream s;
  s << std::setprecision(8) << v;
  return s.str();
}

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    if (static_cast<unsigned char>(c) < 0x20) continue;
    out += c;
  }
  return out + "\"";
}

const char* jsonBool(bool b) { return b ? "true" : "false"; }

// [[x, y, z], ...]: points in metres.
std::string jsonPoints(const std::vector<Vector3>& points) {
  std::string out = "[";
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vector3& p = points[i];
    out += (i > 0 ? ", [" : "[") + jsonNumber(p.x()) + ", " + jsonNumber(p.y()) + ", " + jsonNumber(p.z()) + "]";
  }
  return out + "]";
}

// The shape error against the touches: the initial model (0 touches), then after each action its
// touches and contacts so far and the error measured on its model; null where it was not measured
// (no truth, not on the measurement's schedule, or skipped).
std::string curveJson(const ExplorationReport& report) {
  std::ostringstream json;
  auto point = [&json](int touches, int contacts, const ExplorationRecord& r) {
    json << "    {\"touches\": " << touches << ", \"contacts_total\": " << contacts
         << ", \"rmse_pred_to_gt_m\": " << jsonNumber(r.rmse_pred_to_gt_m)
         << ", \"rmse_gt_to_pred_m\": " << jsonNumber(r.rmse_gt_to_pred_m)
         << ", \"fscore_5mm\": " << jsonNumber(r.fscore_5mm) << "}";
  };
  json << "  \"curve\": [\n";
  point(0, 0, report.initial);
  for (const ExplorationRecord& r : report.result.records) {
    json << ",\n";
    point(r.index + 1, r.contacts_total, r);
  }
  json << "\n  ]\n";
  return json.str();
}

}  // namespace

std::string describeAction(const ExplorationRecord& record) {
  std::ostringstream line;
  line << "action " << std::setw(3) << record.index + 1 << ": " << (record.probe_success ? "contact   " : "no contact")
       << " +" << record.contacts_added << " contacts (" << record.contacts_total << "), max evaluated variance "
       << std::setprecision(3) << record.max_evaluated_variance << ", plan " << std::fixed << std::setprecision(0)
       << record.plan_ms << " ms, probe " << record.probe_ms << " ms, update " << record.update_ms << " ms";
  if (std::isfinite(record.rmse_pred_to_gt_m))
    line << std::setprecision(1) << ", RMSE " << 1000 * record.rmse_pred_to_gt_m << "/" << 1000 * record.rmse_gt_to_pred_m
         << " mm";
  if (std::isfinite(record.target_error_m))
    line << std::setprecision(1) << ", surface found " << 1000 * record.target_error_m << " mm from the target";
  if (record.approach_ms > 0.0) {
    line << std::setprecision(0) << ", approach " << record.approach_ms << " ms";
    if (record.approach_refusals > 0)
      line << " (" << record.approach_refusals << " touch(es) refused: " << record.approach_message << ")";
  }
  if (record.approach_collisions + record.retreat_collisions > 0)
    line << ", " << record.approach_collisions << "+" << record.retreat_collisions << " collisions on the way";
  if (record.guarded_entry) line << ", guarded entry";
  if (!record.probe_reason.empty()) line << " (probe: " << record.probe_reason << ")";
  if (!record.update_message.empty()) line << " (model: " << record.update_message << ")";
  return line.str();
}

double approachPlanMsMedian(const ExplorationResult& result) {
  std::vector<double> times;
  for (const ExplorationRecord& r : result.records)
    if (r.approach_ms > 0.0) times.push_back(r.approach_compute_ms);
  return median(times);
}

double recentTargetError(const ExplorationResult& result, std::size_t touches) {
  std::vector<double> recent;
  for (auto r = result.records.rbegin(); r != result.records.rend() && recent.size() < touches; ++r)
    if (std::isfinite(r->target_error_m)) recent.push_back(r->target_error_m);
  return median(recent);
}

std::string runStatus(const ExplorationResult& result, bool has_surface, const std::string& surface_message) {
  if (!has_surface) return "error: no predicted surface: " + surface_message;
  if (result.converged) return "converged";
  const std::string& reason = result.stop_reason;
  // The loop's "error: ..." says it already.
  if (reason.rfind("error: ", 0) == 0) return reason;
  if (reason.rfind("error", 0) == 0 || reason.rfind("planner_error", 0) == 0 || reason.rfind("invalid_config", 0) == 0)
    return "error: " + reason;
  return "stopped: " + reason;
}

std::string outOfReachNote(const ExplorationResult& result) {
  if (result.final_unreachable_candidates <= 0) return "";
  std::ostringstream note;
  note.precision(2);
  note << " (" << result.final_unreachable_candidates << " candidates left out of reach";
  // The baselines' candidates are sampled points, with no area of their own.
  if (result.final_unreachable_area_fraction > 0.0)
    note << ": " << std::fixed << 100.0 * result.final_unreachable_area_fraction << "% of the atlas's area";
  note << ")";
  return note.str();
}

std::string toJson(const ExplorationReport& report) {
  const ExplorationResult& result = report.result;
  std::ostringstream json;
  // max_position_sd_m null: the V_max rule alone.
  json << "{\n  \"settings\": {\"strategy\": " << jsonString(report.strategy) << ", \"v_max\": "
       << jsonNumber(report.loop.v_max) << ", \"max_position_sd_m\": " << jsonNumber(report.loop.max_position_sd_m.value_or(NAN))
       << ", \"max_actions\": " << report.loop.max_actions
       << ", \"max_consecutive_failures\": " << report.loop.max_consecutive_failures << ", \"seed\": " << report.loop.seed
       << ", \"model\": " << jsonString(report.model) << "},\n";
  json << "  \"status\": " << jsonString(report.status) << ",\n  \"stop_reason\": " << jsonString(result.stop_reason)
       << ",\n  \"converged\": " << jsonBool(report.status == "converged") << ",\n  \"actions\": " << result.actions
       << ",\n  \"contacts\": " << result.contacts << ",\n  \"unreachable_touches\": " << result.unreachable_touches
       << ",\n  \"unreachable_candidates\": " << result.unreachable_candidates
       << ",\n  \"final_unreachable_candidates\": " << result.final_unreachable_candidates
       << ",\n  \"final_unreachable_area_fraction\": " << result.final_unreachable_area_fraction
       << ",\n  \"approach_collisions\": " << result.approach_collisions
       << ",\n  \"retreat_collisions\": " << result.retreat_collisions
       << ",\n  \"approach_plan_ms_median\": " << jsonNumber(approachPlanMsMedian(result))
       << ",\n  \"recent_target_error_m\": " << jsonNumber(recentTargetError(result))
       << ",\n  \"final_max_evaluated_variance\": " << jsonNumber(result.final_max_evaluated_variance) << ",\n";
  json << "  \"final_metrics\": ";
  const FinalShape& shape = report.final_shape;
  if (shape.measured)
    json << "{\"rmse_pred_to_gt_m\": " << jsonNumber(shape.rmse_pred_to_gt_m)
         << ", \"rmse_gt_to_pred_m\": " << jsonNumber(shape.rmse_gt_to_pred_m)
         << ", \"chamfer_l1_m\": " << jsonNumber(shape.chamfer_l1_m) << ", \"fscore_5mm\": " << jsonNumber(shape.fscore_5mm)
         << ", \"coverage_2sd\": " << jsonNumber(shape.coverage_2sd) << ", \"sharpness\": " << jsonNumber(shape.sharpness)
         << ", \"position_sd_m\": " << jsonNumber(shape.position_sd_m) << "}";
  else
    json << "null";
  const ExplorationRecord& initial = report.initial;
  json << ",\n  \"initial\": {\"n_train\": " << initial.n_train
       << ", \"sampled_max_variance\": " << jsonNumber(initial.sampled_max_variance)
       << ", \"rmse_pred_to_gt_m\": " << jsonNumber(initial.rmse_pred_to_gt_m)
       << ", \"rmse_gt_to_pred_m\": " << jsonNumber(initial.rmse_gt_to_pred_m)
       << ", \"fscore_5mm\": " << jsonNumber(initial.fscore_5mm) << "}";
  json << ",\n  \"history\": [\n";
  for (std::size_t i = 0; i < result.records.size(); ++i) {
    const ExplorationRecord& r = result.records[i];
    json << "    {\"action\": " << r.index + 1 << ", \"probe_success\": " << jsonBool(r.probe_success)
         << ", \"probe_reason\": " << jsonString(r.probe_reason) << ", \"contacts\": " << r.contacts_added
         << ", \"free_points\": " << r.free_points_added << ", \"contacts_total\": " << r.contacts_total
         << ", \"max_evaluated_variance\": " << jsonNumber(r.max_evaluated_variance)
         << ", \"action_ms\": " << jsonNumber(r.action_ms) << ", \"plan_ms\": " << jsonNumber(r.plan_ms)
         << ", \"plan_compute_ms\": " << jsonNumber(r.plan_compute_ms)
         << ", \"plan_budget_exhausted\": " << jsonBool(r.plan_budget_exhausted) << ", \"probe_ms\": " << jsonNumber(r.probe_ms)
         << ", \"update_ms\": " << jsonNumber(r.update_ms) << ", \"progress_ms\": " << jsonNumber(r.progress_ms)
         << ", \"approach_ms\": " << jsonNumber(r.approach_ms)
         << ", \"approach_compute_ms\": " << jsonNumber(r.approach_compute_ms)
         << ", \"approach_refusals\": " << r.approach_refusals
         << ", \"unreachable_candidates\": " << r.unreachable_candidates
         << ", \"approach_message\": " << jsonString(r.approach_message)
         << ", \"target_error_m\": " << jsonNumber(r.target_error_m)
         << ", \"approach_collisions\": " << r.approach_collisions
         << ", \"retreat_collisions\": " << r.retreat_collisions << ", \"n_train\": " << r.n_train
         << ", \"update_message\": " << jsonString(r.update_message)
         << ", \"sampled_max_variance\": " << jsonNumber(r.sampled_max_variance)
         << ", \"rmse_pred_to_gt_m\": " << jsonNumber(r.rmse_pred_to_gt_m)
         << ", \"rmse_gt_to_pred_m\": " << jsonNumber(r.rmse_gt_to_pred_m)
         << ", \"fscore_5mm\": " << jsonNumber(r.fscore_5mm)
         << ", \"contact_points\": " << jsonPoints(r.contact_positions) << "}"
         << (i + 1 < result.records.size() ? ",\n" : "\n");
  }
  json << "  ],\n" << curveJson(report) << "}\n";
  return json.str();
}

}  // namespace gpatlas_core
