#include "gpatlas_core/planning/atlas_strategy.h"

namespace gpatlas_core {

namespace {

// The rules of each mode, applied once when the strategy is made.
AtlasPlanner::Config withModeRules(AtlasStrategy::Mode mode, AtlasPlanner::Config config) {
  // A slide runs from the known surface to the first chart that needs a touch and on into the
  // unknown (extend_path_charts): Algorithm 1's path. A best-scoring atlas covers the surface,
  // so its charts leave the extension no room to grow.
  if (mode == AtlasStrategy::Mode::kSlide) config.selection = AtlasPlanner::Config::Selection::kFirst;
  // A poke touches the path's last chart: the first that needs a touch (or the best-scoring).
  if (mode == AtlasStrategy::Mode::kPoke) config.extend_path_charts = 0;
  return config;
}

}  // namespace

AtlasStrategy::AtlasStrategy(Mode mode, AtlasPlanner::Config config, std::uint64_t seed)
    : mode_(mode), config_(withModeRules(mode, std::move(config))), seed_(seed) {}

std::string AtlasStrategy::name() const { return mode_ == Mode::kPoke ? "atlas_poke" : "atlas_slide"; }

PlanResult AtlasStrategy::plan(const SurfaceModel& model, const PlanRequest& request) const {
  if (auto error = checkPlanInput(model, request)) return *error;
  // The pad's aim past the edge of the supported surface is for the first chart, which lies at
  // that edge; the best-scoring chart lies wherever its touch removes the most error.
  const double aim_past_m =
      mode_ == Mode::kPoke && config_.selection == AtlasPlanner::Config::Selection::kFirst ? request.footprint_radius_m : 0.0;
  const AtlasPlanner planner(config_, mixSeeds(seed_, request.seed));
  const auto planWith = [&](AtlasMemory* memory) {
    return planner.plan(model, request.stopRule(), request.start, {}, request.reachable, request.evidence_state,
                        request.touch_observations, memory, aim_past_m);
  };
  // Without reuse a plan neither reads nor leaves a memory: plans need not wait for each other,
  // nor hash the model's observations and copy the atlas for nobody.
  AtlasPlanResult planned;
  if (config_.reuse.enabled) {
    const std::lock_guard<std::mutex> lock(memory_->mutex);
    planned = planWith(&memory_->atlas);
  } else {
    planned = planWith(nullptr);
  }

  PlanResult result;
  result.status = planned.status;
  result.message = planned.message;
  result.max_evaluated_variance = planned.max_chart_variance;
  result.elapsed_s = planned.elapsed_s;
  result.budget_exhausted = planned.budget_exhausted;
  result.unreachable_candidates = planned.unreachable_skipped;
  result.unreachable_area_fraction = planned.unreachable_area_fraction;
  if (const std::string note = vMaxNoiseNote(model, request.v_max); !note.empty()) result.message += "; " + note;
  if (planned.status == PlanStatus::kTouch) {
    Touch& touch = result.touch;
    touch.strategy = name();
    touch.kind = mode_ == Mode::kPoke ? Touch::Kind::kPoke : Touch::Kind::kSlide;
    // Poke: only the uncertain end of the path. Slide: the whole path, root first, so the
    // probe starts where the model is certain and slides toward the uncertainty.
    std::size_t first = mode_ == Mode::kPoke ? planned.path.size() - 1 : 0;
    // A slide starts at the first chart of the path the probe can be brought to.
    std::optional<Vector3> first_direction;
    if (mode_ == Mode::kSlide && request.reachable)
      for (; first + 1 < planned.path.size(); ++first) {
        const Chart& chart = planned.atlas.chart(planned.path[first]);
        first_direction = request.reachable(chart.centre, chart.normal);
        if (first_direction) break;
      }
    // Each waypoint is approached (pressed) along its chart's direction: the one the filter
    // chose for the ends, the normal in between, where the probe slides on in contact.
    for (std::size_t k = first; k < planned.path.size(); ++k) {
      const Chart& chart = planned.atlas.chart(planned.path[k]);
      touch.points.push_back(chart.centre);
      Vector3 direction = chart.approach_direction.norm() > 0.0 ? chart.approach_direction : chart.normal;
      if (k == first && first_direction) direction = *first_direction;
      touch.normals.push_back(direction.normalized());
      touch.variances.push_back(chart.variance);
    }
  }
  result.atlas = std::move(planned);
  return result;
}

}  // namespace gpatlas_core
