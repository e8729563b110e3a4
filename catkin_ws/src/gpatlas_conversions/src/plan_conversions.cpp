// The planner's messages: next_touch's request and answer, the grown atlas (conversions.h).
#include "gpatlas_conversions/conversions.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace gpatlas_conversions {

namespace {

using Request = gpatlas_msgs::GetNextTouch::Request;
using Response = gpatlas_msgs::GetNextTouch::Response;

std::uint8_t toStatusMsg(gpatlas_core::PlanStatus status) {
  switch (status) {
    case gpatlas_core::PlanStatus::kTouch: return Response::TOUCH;
    case gpatlas_core::PlanStatus::kConverged: return Response::CONVERGED;
    case gpatlas_core::PlanStatus::kCapReached: return Response::CAP_REACHED;
    case gpatlas_core::PlanStatus::kError: return Response::ERROR;
  }
  return Response::ERROR;
}

gpatlas_core::PlanStatus fromStatusMsg(std::uint8_t status) {
  switch (status) {
    case Response::TOUCH: return gpatlas_core::PlanStatus::kTouch;
    case Response::CONVERGED: return gpatlas_core::PlanStatus::kConverged;
    case Response::CAP_REACHED: return gpatlas_core::PlanStatus::kCapReached;
    default: return gpatlas_core::PlanStatus::kError;
  }
}

}  // namespace

gpatlas_msgs::GetNextTouch::Request toMsg(const gpatlas_core::PlanRequest& request) {
  gpatlas_msgs::GetNextTouch::Request msg;
  msg.use_v_max = true;
  msg.v_max = request.v_max;
  msg.stop_rule = request.max_position_sd_m ? Request::STOP_RULE_POSITION_SD : Request::STOP_RULE_V_MAX_ONLY;
  msg.max_position_sd_m = request.max_position_sd_m.value_or(0.0);
  msg.use_start = request.start.has_value();
  if (request.start) msg.start = toPointMsg(*request.start);
  for (const auto& p : request.evidence_state.attempted_targets) msg.attempted_targets.push_back(toPointMsg(p));
  msg.attempted_target_errors_m = request.evidence_state.attempted_target_errors_m;
  msg.empty_unknown_pokes = request.evidence_state.empty_unknown_pokes;
  msg.footprint_radius_m = request.footprint_radius_m;
  msg.use_seed = true;
  msg.seed = request.seed;
  return msg;
}

gpatlas_core::PlanRequest fromMsg(const gpatlas_msgs::GetNextTouch::Request& msg, const NodePlanDefaults& node) {
  gpatlas_core::PlanRequest request;
  request.v_max = msg.use_v_max ? msg.v_max : node.v_max;
  switch (msg.stop_rule) {
    case Request::STOP_RULE_POSITION_SD: request.max_position_sd_m = msg.max_position_sd_m; break;
    case Request::STOP_RULE_V_MAX_ONLY: request.max_position_sd_m = std::nullopt; break;
    case Request::STOP_RULE_PARAMETER: request.max_position_sd_m = node.max_position_sd_m; break;
    // Not a rule: a bound validate(StopRule) refuses, rather than the node's by accident.
    default: request.max_position_sd_m = std::numeric_limits<double>::quiet_NaN(); break;
  }
  if (msg.use_start) request.start = fromMsg(msg.start);
  for (const auto& p : msg.attempted_targets) request.evidence_state.attempted_targets.push_back(fromMsg(p));
  request.evidence_state.attempted_target_errors_m = msg.attempted_target_errors_m;
  request.evidence_state.empty_unknown_pokes = msg.empty_unknown_pokes;
  request.footprint_radius_m = msg.footprint_radius_m;
  request.seed = msg.use_seed ? msg.seed : node.seed;
  return request;
}

gpatlas_msgs::GetNextTouch::Response toMsg(const gpatlas_core::PlanResult& result) {
  gpatlas_msgs::GetNextTouch::Response msg;
  msg.status = toStatusMsg(result.status);
  if (result.status == gpatlas_core::PlanStatus::kTouch) msg.touch = toMsg(result.touch);
  msg.message = result.message;
  msg.plan_time_s = result.elapsed_s;
  msg.max_evaluated_variance = result.max_evaluated_variance;
  msg.unreachable_candidates = static_cast<std::uint32_t>(std::max(0, result.unreachable_candidates));
  msg.unreachable_area_fraction = result.unreachable_area_fraction;
  msg.budget_exhausted = result.budget_exhausted;
  return msg;
}

gpatlas_core::PlanResult fromMsg(const gpatlas_msgs::GetNextTouch::Response& msg) {
  gpatlas_core::PlanResult result;
  result.status = fromStatusMsg(msg.status);
  result.message = msg.message;
  result.elapsed_s = msg.plan_time_s;
  result.max_evaluated_variance = msg.max_evaluated_variance;
  result.unreachable_candidates = static_cast<int>(msg.unreachable_candidates);
  result.unreachable_area_fraction = msg.unreachable_area_fraction;
  result.budget_exhausted = msg.budget_exhausted;
  std::string malformed;
  if (result.status == gpatlas_core::PlanStatus::kTouch && !fromMsg(msg.touch, &result.touch, &malformed)) {
    result.status = gpatlas_core::PlanStatus::kError;
    result.message = "malformed touch: " + malformed;
  }
  return result;
}

gpatlas_msgs::Atlas toMsg(const gpatlas_core::Atlas& atlas, const std::vector<int>& path) {
  gpatlas_msgs::Atlas msg;
  for (const gpatlas_core::Chart& chart : atlas.charts()) {
    gpatlas_msgs::Chart c;
    c.centre = toPointMsg(chart.centre);
    c.normal = toVectorMsg(chart.normal);
    c.radius_m = chart.radius;
    c.variance = chart.variance;
    c.parent = chart.parent;
    msg.charts.push_back(c);
  }
  msg.path = path;
  return msg;
}

}  // namespace gpatlas_conversions
