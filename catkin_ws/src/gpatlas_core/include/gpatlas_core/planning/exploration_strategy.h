#pragma once

#include "gpatlas_core/planning/atlas_planner.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/planning/surface_sampler.h"
#include "gpatlas_core/common/seeds.h"
#include "gpatlas_core/common/types.h"
#include "gpatlas_core/planning/stop_rule.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

struct PlanRequest {
  double v_max{0.1};  // reported (paper-equivalent) variance units
  // The stop rule in metres as well as V_max (StopRule); empty: V_max alone.
  std::optional<double> max_position_sd_m;
  StopRule stopRule() const { return StopRule{v_max, max_position_sd_m}; }
  // What the run has learnt that every strategy's evidence test reads (its EvidenceRule, from
  // evidence/, says how): the Explorer fills the attempted targets, the planner
  // adds the table it knows of (mergeEvidenceState).
  EvidenceState evidence_state;
  // Where the probe is, if known: the atlas grows from there instead of a random surface point.
  std::optional<Vector3> start;
  // Mixed with the run's seed, which the strategy was made with (makeStrategy), so that
  // successive plans of one exploration differ while the whole run stays reproducible.
  std::uint64_t seed{0};
  // Every strategy passes over candidates this refuses (the Explorer's approacher's cheap
  // test) and approaches the one it keeps along the direction this chose; empty: every
  // candidate is reachable along its normal. The baselines test their first 32 choices and,
  // when it refuses all, poke the first anyway (the approacher then refuses it).
  TouchFilter reachable;
  // The probe's contact footprint: half the side of the largest tactile pad it has reported
  // (ProbeResult::pads; the Explorer fills it), 0 for a point probe. atlas_poke aims this far
  // past the edge of the supported surface (AtlasPlanner::plan's aim_past_m).
  double footprint_radius_m{0.0};
  // How the loop turns a touch's measurements into observations (the Explorer's, the GP
  // nodelet's touch/): the atlas strategies' score adds a candidate's in fantasy.
  TouchObservationConfig touch_observations;
};

struct PlanResult {
  PlanStatus status{PlanStatus::kError};
  std::string message;
  Touch touch;  // filled for kTouch
  // The largest variance the plan evaluated: over the atlas's charts (atlas strategies) or the
  // surface samples (the others). A lower bound on the surface's largest: an atlas that stops
  // at the first chart above V_max has seen only part of the surface.
  double max_evaluated_variance{0.0};
  std::optional<AtlasPlanResult> atlas;  // the grown atlas, for the atlas strategies
  double elapsed_s{0.0};
  // The plan's work budget, not convergence or a touch found, ended its search (the atlas
  // strategies: AtlasPlanResult::budget_exhausted).
  bool budget_exhausted{false};
  int unreachable_candidates{0};  // candidates passed over for PlanRequest::reachable
  // The atlas strategies: those charts' share of the atlas's area
  // (AtlasPlanResult::unreachable_area_fraction); 0 for the others. atlas_frontier counts the
  // shadow targets it could not approach among the candidates, without an area.
  double unreachable_area_fraction{0.0};
};

// Chooses the next touch on a GPIS model (the step "plan" of Algorithm 2).
class ExplorationStrategy {
 public:
  virtual ~ExplorationStrategy() = default;
  virtual std::string name() const = 0;
  virtual PlanResult plan(const SurfaceModel& model, const PlanRequest& request) const = 0;
};

// Empty, or a note that V_max lies below a tenth of the smallest noise variance of the model's
// surface observations: a point would have to be observed more than ten times to get there
// (a point observed k times gets to about sigma^2 / k), so the loop may not converge. Strategies
// append it to every answer.
std::string vMaxNoiseNote(const SurfaceModel& model, double v_max);

// Shared argument checks: an error PlanResult for an unusable model or V_max, else nullopt.
std::optional<PlanResult> checkPlanInput(const SurfaceModel& model, const PlanRequest& request);

}  // namespace gpatlas_core
