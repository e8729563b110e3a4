#include "gpatlas_core/planning/atlas_planner.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <numeric>
#include <cmath>
#include <random>
#include <sstream>
#include <unordered_map>

namespace gpatlas_core {

const char* toString(PlanStatus status) {
  switch (status) {
    case PlanStatus::kTouch: return "touch";
    case PlanStatus::kConverged: return "converged";
    case PlanStatus::kCapReached: return "cap_reached";
    case PlanStatus::kError: return "error";
  }
  return "unknown";
}

std::string validate(const AtlasPlanner::Config& config) {
  std::ostringstream problem;
  problem << validate(config.chart);
  if (!(config.depth_first_probability >= 0.0 && config.depth_first_probability <= 1.0))
    problem << "depth_first_probability must be in [0, 1]; ";
  if (config.max_charts < 1) problem << "max_charts must be at least 1; ";
  if (config.max_queries < 1) problem << "max_queries must be at least 1; ";
  if (!(config.reuse.near_new_data_m >= 0.0) || !std::isfinite(config.reuse.near_new_data_m) ||
      !(config.reuse.max_centre_shift_m >= 0.0) || !(config.reuse.max_normal_change_rad >= 0.0))
    problem << "reuse: near_new_data_m, max_centre_shift_m and max_normal_change_rad must be >= 0; ";
  if (!(config.max_start_distance_m > 0.0)) problem << "max_start_distance_m must be positive; ";
  if (config.max_start_attempts < 1) problem << "max_start_attempts must be at least 1; ";
  if (config.extend_path_charts < 0) problem << "extend_path_charts must be >= 0; ";
  if (!(config.projection.f_tolerance > 0.0) || config.projection.max_iterations < 1 ||
      !(config.projection.max_step_fraction > 0.0))
    problem << "projection needs f_tolerance > 0, max_iterations >= 1, max_step_fraction > 0; ";
  if (const std::string evidence = validate(config.evidence); !evidence.empty()) problem << "evidence: " << evidence << "; ";
  if (const std::string score = validate(config.score); !score.empty()) problem << "score: " << score;
  return problem.str();
}

void readAtlasPlanner(ParamReader& r, AtlasPlanner::Config* c) {
  ChartConfig& chart = c->chart;
  chart.rho_gain = r.number("planner/rho_gain", chart.rho_gain, 1e-9, 10.0);
  chart.rho_min_m = r.number("planner/rho_min_m", chart.rho_min_m, 1e-5, 1.0);
  chart.rho_max_m = r.number("planner/rho_max_m", chart.rho_max_m, 1e-5, 1.0);
  chart.candidate_density = r.number("planner/candidate_density", chart.candidate_density, 1.0, 1000.0);
  c->depth_first_probability =
      r.number("planner/depth_first_probability", c->depth_first_probability, 0.0, 1.0);
  c->max_charts = r.integer("planner/max_charts", c->max_charts, 1, 1000000);
  c->max_queries = r.integer("planner/max_queries", static_cast<int>(c->max_queries), 1, 100000000);
  AtlasReuseConfig& reuse = c->reuse;
  reuse.enabled = r.flag("planner/reuse/enabled", reuse.enabled);
  reuse.near_new_data_m = r.number("planner/reuse/near_new_data_m", reuse.near_new_data_m, 0.0, 1.0);
  c->extend_path_charts = r.integer("planner/extend_path_charts", c->extend_path_charts, 0, 1000);
  const std::string selection = r.text("planner/selection", toString(c->selection));
  if (!parseSelection(selection, &c->selection))
    r.invalid("planner/selection", "'" + selection + "' is not first or best_score");
  TouchScoreConfig& score = c->score;
  score.max_reference_points = r.integer("score/max_reference_points", score.max_reference_points, 1, 100000);
  score.max_candidates = r.integer("score/max_candidates", score.max_candidates, 1, 10000);
  score.max_excess_candidates = r.integer("score/max_excess_candidates", score.max_excess_candidates, 0, score.max_candidates);
  readEvidence(r, &c->evidence);
}

bool parseSelection(const std::string& name, AtlasPlanner::Config::Selection* selection) {
  if (name == "first") *selection = AtlasPlanner::Config::Selection::kFirst;
  else if (name == "best_score") *selection = AtlasPlanner::Config::Selection::kBestScore;
  else return false;
  return true;
}

const char* toString(AtlasPlanner::Config::Selection selection) {
  return selection == AtlasPlanner::Config::Selection::kFirst ? "first" : "best_score";
}

std::uint64_t observationHash(const TrainingPoint& point) {
  // FNV-1a over the fields' bytes.
  std::uint64_t hash = 14695981039346656037ULL;
  const auto mix = [&hash](const void* data, std::size_t bytes) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < bytes; ++i) hash = (hash ^ p[i]) * 1099511628211ULL;
  };
  mix(point.position.data(), 3 * sizeof(double));
  mix(point.slope_direction.data(), 3 * sizeof(double));
  mix(&point.noise_sigma, sizeof(double));
  mix(&point.target_override, sizeof(double));
  mix(&point.surface_distance_m, sizeof(double));
  const int tags[2] = {static_cast<int>(point.label), static_cast<int>(point.source)};
  mix(tags, sizeof(tags));
  return hash;
}

bool AtlasMemory::changesTo(const SurfaceModel& model, std::vector<Vector3>* changed) const {
  changed->clear();
  if (atlas.empty() || !model.isFitted() || model.name() != this->model) return false;
  if (model.centroid() != centroid || model.scale() != scale) return false;
  const Eigen::VectorXd now = model.hyperparameters();
  if (now.size() != hyperparameters.size() || now != hyperparameters) return false;
  // The observations as multisets of hashes: those on one side only changed (a touch adds some;
  // a refit that retracts guessed interior removes some). Only surface observations are
  // returned, the rest counted, so that a model rebuilt from other data is not taken for this one.
  std::unordered_map<std::uint64_t, int> count;
  for (std::uint64_t h : observations) ++count[h];
  std::size_t other_changes = 0;
  for (const TrainingPoint& point : model.observations()) {
    const auto found = count.find(observationHash(point));
    if (found != count.end() && found->second > 0) {
      --found->second;
    } else if (isSurfaceValue(point) && point.position.allFinite()) {
      changed->push_back(point.position);
    } else {
      ++other_changes;
    }
  }
  for (std::size_t i = 0; i < surface_hashes.size(); ++i) {
    const auto found = count.find(surface_hashes[i]);
    if (found != count.end() && found->second > 0) {
      --found->second;
      changed->push_back(surface_positions[i]);
    }
  }
  for (const auto& [hash, left] : count) other_changes += static_cast<std::size_t>(std::max(0, left));
  // Most of the data replaced: another model, not a touch's change of this one.
  return changed->size() + other_changes <= observations.size() / 2;
}

void AtlasMemory::remember(const SurfaceModel& model, const Atlas& grown) {
  this->model = model.name();
  centroid = model.centroid();
  scale = model.scale();
  hyperparameters = model.hyperparameters();
  observations.clear();
  surface_positions.clear();
  surface_hashes.clear();
  for (const TrainingPoint& point : model.observations()) {
    observations.push_back(observationHash(point));
    if (isSurfaceValue(point) && point.position.allFinite()) {
      surface_positions.push_back(point.position);
      surface_hashes.push_back(observations.back());
    }
  }
  atlas = grown;
}

namespace {

double discArea(const Chart& chart) { return M_PI * chart.radius * chart.radius; }

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

SurfacePoint projectFreePoint(const SurfaceModel& model, const Vector3& point, const ProjectionConfig& config) {
  Points3 starts(3, 1);
  starts.col(0) = point;
  return projectAlongGradient(model, starts, config).front();
}

// SELECTSURFACEPOINT: the given start projected onto the surface, else a random surface
// observation (they lie on the surface up to noise, so the projection is short).
SurfacePoint selectSurfacePoint(const SurfaceModel& model, const std::optional<Vector3>& start,
                                const AtlasPlanner::Config& config, std::mt19937_64& rng,
                                std::string* error) {
  if (start) {
    if (!start->allFinite()) {
      *error = "start point is not finite";
      return {};
    }
    if (!model.inDomain(*start)) {
      *error = "start point is outside the model's domain";
      return {};
    }
    SurfacePoint root = projectFreePoint(model, *start, config.projection);
    if (!root.ok) {
      *error = std::string("start point could not be projected onto the surface: ") + toString(root.failure);
      return {};
    }
    const double distance = (root.position - *start).norm();
    if (distance > config.max_start_distance_m) {
      std::ostringstream message;
      message << "start point is " << distance << " m from the predicted surface (limit "
              << config.max_start_distance_m << " m)";
      *error = message.str();
      return {};
    }
    return root;
  }
  std::vector<Vector3> surface_points;
  for (const TrainingPoint& point : model.observations())
    if (isSurfaceValue(point) && point.position.allFinite()) surface_points.push_back(point.position);
  if (surface_points.empty()) {
    *error = "the model has no surface observations to start from";
    return {};
  }
  std::uniform_int_distribution<std::size_t> pick(0, surface_points.size() - 1);
  for (int attempt = 0; attempt < config.max_start_attempts; ++attempt) {
    SurfacePoint root = projectFreePoint(model, surface_points[pick(rng)], config.projection);
    if (root.ok) return root;
  }
  *error = "no surface observation could be projected onto the predicted surface";
  return {};
}

// The end of a plan, before finishPlan adds its summary.
struct PlanEnd {
  PlanStatus status;
  std::string message;
};

// The result with its status, message, time and the atlas's highest chart variance; the
// message also says how many charts that need a touch were passed over.
AtlasPlanResult finishPlan(AtlasPlanResult& result, PlanStatus status, std::string message,
                           Clock::time_point started) {
  result.status = status;
  result.message = std::move(message);
  result.elapsed_s = secondsSince(started);
  double area = 0.0, unreachable_area = 0.0;
  for (const Chart& chart : result.atlas.charts()) {
    result.max_chart_variance = std::max(result.max_chart_variance, chart.variance);
    area += discArea(chart);
    unreachable_area += chart.out_of_reach ? discArea(chart) : 0.0;
  }
  result.unreachable_area_fraction = area > 0.0 ? unreachable_area / area : 0.0;
  std::ostringstream work;
  work << "; " << result.atlas.size() << " charts (" << result.reused_charts << " kept from the previous plan, "
       << result.dropped_charts << " of its dropped), " << result.queries << " queries";
  result.message += work.str();
  if (result.retouch_skipped > 0)
    result.message += "; " + std::to_string(result.retouch_skipped) +
                      " chart(s) that would need a touch lie right at a measurement or an earlier target";
  if (result.unreachable_skipped > 0) {
    std::ostringstream share;
    share.precision(2);
    share << std::fixed << 100.0 * result.unreachable_area_fraction;
    result.message += "; " + std::to_string(result.unreachable_skipped) +
                      " chart(s) that need a touch passed over: no safe approach (" + share.str() +
                      "% of the atlas's area)";
  }
  return result;
}

// One plan's growth of the atlas (Algorithm 1's loop): the atlas and the counters live in the
// result, every random choice comes from `rng`, in the order of the algorithm's steps.
class AtlasGrowth {
 public:
  AtlasGrowth(const SurfaceModel& model, const StopRule& rule, const AtlasPlanner::Config& config,
              const SurfaceEvidence& evidence, const AtlasPlanner::Progress& progress,
              const TouchFilter& reachable, double aim_past_m, std::mt19937_64& rng, AtlasPlanResult& result)
      : model_(model), rule_(rule), config_(config), evidence_(evidence), progress_(progress),
        reachable_(reachable), aim_past_m_(aim_past_m), rng_(rng), result_(result), atlas_(result.atlas),
        scoring_(config.selection == AtlasPlanner::Config::Selection::kBestScore) {}

  ChartCreation makeChart(const SurfacePoint& point, int parent) {
    ChartConfig chart = config_.chart;
    chart.rho_min_m = budgetRadiusFloor();
    ChartCreation created = createChart(model_, point, parent, chart, rng_,
                                        evidence_.radiusCap(point.position, chart.rho_min_m), rank_candidates_);
    if (rank_candidates_) result_.queries += static_cast<long>(created.chart.candidates.size());
    return created;
  }

  // Counts a projection's queries: its iterations, and the variance at the point it found.
  void countProjection(const SurfacePoint& projected) { result_.queries += projected.iterations + 2; }

  // Algorithm 1's test (StopRule: variance above V_max, or position sd above its bound), or a
  // surface nobody saw or felt. A chart right at
  // a measurement or an earlier touch's target needs none (EvidenceRule::retouch_radius_m): a
  // touch there would find what was found. `counted`: a chart passed over is reported in the
  // plan's message (not for the aim's charts, past the one already found).
  // When scoring, the approach is tested later, in the order of the scores (chooseBest).
  bool needsTouch(Chart& chart, bool counted = true) {
    if (!rule_.exceeded(model_, chart.variance, chart.slope) && !evidence_.isUnsupported(chart.centre, chart.normal)) return false;
    if (evidence_.measuredNear(chart.centre, config_.evidence.retouch_radius_m)) {
      if (counted) ++result_.retouch_skipped;
      return false;
    }
    if (scoring_ && counted) return true;
    if (!takeApproach(chart)) {
      if (counted) ++result_.unreachable_skipped;
      chart.out_of_reach = counted;
      return false;
    }
    return true;
  }

  // Adds the chart and reports progress; returns its index.
  int addChart(Chart chart) {
    const int index = atlas_.addChart(std::move(chart));
    if (progress_) progress_(atlas_);
    return index;
  }

  // Surface observations in random order: when the tree runs out of candidates, a new tree
  // starts from one that no chart covers, so that a predicted surface in several pieces (or a
  // piece the first tree cannot reach) is explored too before "converged" is declared. The
  // paper notes that, in theory, the atlas could start from all surface points.
  void collectUncoveredCandidates() {
    if (!config_.cover_all_observations) return;
    for (const TrainingPoint& point : model_.observations())
      if (isSurfaceValue(point) && point.position.allFinite()) uncovered_candidates_.push_back(point.position);
    std::shuffle(uncovered_candidates_.begin(), uncovered_candidates_.end(), rng_);
  }

  // Expands the tree from `continuation` until it has no candidate left (nullopt) or the plan
  // ends (a touch, or a cap).
  std::optional<PlanEnd> growTree(int& continuation) {
    while (atlas_.isExpandable()) {
      if (capReached()) return PlanEnd{PlanStatus::kCapReached, budgetMessage() + " without finding " + rule_.describe()};
      ChartCreation created = expand(selectChart(continuation));
      if (!created.ok) continue;
      const bool new_needs_touch = needsTouch(created.chart);
      continuation = addChart(std::move(created.chart));
      if (endsPlan(new_needs_touch, continuation)) {
        result_.path = atlas_.pathTo(extendPath(continuation));
        return PlanEnd{PlanStatus::kTouch, "found a chart that needs a touch (" + rule_.describe() + " or no evidence nearby)"};
      }
    }
    return std::nullopt;
  }

  // The current tree is exhausted: roots a new one at an uncovered surface observation.
  // `rooted` false: none is left. Returns the plan's end when the new root needs a touch or a cap
  // is reached.
  std::optional<PlanEnd> rootNewTree(int& continuation, bool& rooted) {
    rooted = false;
    while (!rooted && next_candidate_ < uncovered_candidates_.size()) {
      if (capReached())
        return PlanEnd{PlanStatus::kCapReached, budgetMessage() + " while covering the remaining surface observations"};
      const Vector3& observation = uncovered_candidates_[next_candidate_++];
      if (atlas_.coveredByOtherChart(observation, -1)) continue;
      const SurfacePoint projected = projectFreePoint(model_, observation, config_.projection);
      countProjection(projected);
      ++result_.queries;  // the gradient that gave the projection's line
      if (!projected.ok || atlas_.coveredByOtherChart(projected.position, -1)) continue;
      ChartCreation created = makeChart(projected, -1);
      if (!created.ok) continue;
      const bool new_needs_touch = needsTouch(created.chart);
      continuation = atlas_.addChart(std::move(created.chart));
      ++trees_;
      if (progress_) progress_(atlas_);
      if (endsPlan(new_needs_touch, continuation)) {
        result_.path = atlas_.pathTo(continuation);
        return PlanEnd{PlanStatus::kTouch, "a new tree's root needs a touch (" + rule_.describe() + " or no evidence nearby)"};
      }
      rooted = true;
    }
    return std::nullopt;
  }

  int trees() const { return trees_; }

  // Starts from the previous plan's charts that the model's change left in place (Config::reuse):
  // false, and nothing done, when none is left.
  bool adoptPrevious(const Atlas& previous, const std::vector<Vector3>& changed) {
    std::vector<int> kept, dropped;
    std::vector<double> variances, slopes;
    splitPrevious(previous, changed, &kept, &dropped, &variances, &slopes);
    if (kept.empty()) return false;
    // The holes the dropped charts leave are grown again from the kept charts around them: those
    // get back the candidates they drew there; elsewhere, those the previous growth had not used.
    const Atlas holes = Atlas::keep(previous, dropped, [](int, const ChartCandidate&) { return false; });
    atlas_ = Atlas::keep(previous, kept, [&](int old, const ChartCandidate& candidate) {
      if (holes.coveredByOtherChart(candidate.ambient, -1)) return true;
      const auto& left = previous.chart(old).candidates;
      return std::any_of(left.begin(), left.end(), [&](const ChartCandidate& c) { return c.tangent == candidate.tangent; });
    });
    result_.reused_charts = static_cast<int>(kept.size());
    result_.dropped_charts = static_cast<int>(dropped.size());
    for (std::size_t i = 0; i < atlas_.size(); ++i) {
      Chart& chart = atlas_.chart(static_cast<int>(i));
      chart.variance = variances[i];
      chart.slope = slopes[i];
      chart.out_of_reach = false;
      chart.approach_direction = Vector3::Zero();
    }
    for (std::size_t i = 0; i < atlas_.size(); ++i)
      endsPlan(needsTouch(atlas_.chart(static_cast<int>(i))), static_cast<int>(i));
    if (progress_) progress_(atlas_);
    return true;
  }
  bool scoring() const { return scoring_; }

  // Whether the chart just added ends the plan: kFirst, when it needs a touch; kBestScore keeps
  // such a chart for chooseBest and grows on.
  bool endsPlan(bool needs_touch, int index) {
    if (needs_touch && scoring_) needy_.push_back(index);
    return needs_touch && !scoring_;
  }

  // kBestScore, once the atlas is grown: the needy charts scored (a sample, see TouchScoreConfig),
  // then offered to the TouchFilter best first, the unscored ones after them by how far past
  // the rule they are. nullopt when none can be touched (each is then out of reach).
  std::optional<PlanEnd> chooseBest(const TouchObservationConfig& touch) {
    result_.needy_charts = static_cast<int>(needy_.size());
    if (needy_.empty()) return std::nullopt;
    const auto excess = [&](int index) {
      const Chart& chart = atlas_.chart(index);
      const double e = rule_.excess(model_, chart.variance, chart.slope);
      return std::isfinite(e) ? e : std::numeric_limits<double>::infinity();
    };
    // The furthest past the rule first, then a sample of the others taken in the order the atlas
    // found them, so that the sample does not follow the excess's last digits.
    std::vector<int> order = needy_;
    const std::size_t most = static_cast<std::size_t>(config_.score.max_candidates);
    const std::size_t by_excess = std::min(order.size(), static_cast<std::size_t>(config_.score.max_excess_candidates));
    std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(by_excess), order.end(),
                      [&](int a, int b) { return excess(a) > excess(b) || (excess(a) == excess(b) && a < b); });
    std::sort(order.begin() + static_cast<std::ptrdiff_t>(by_excess), order.end());
    std::shuffle(order.begin() + static_cast<std::ptrdiff_t>(by_excess), order.end(), rng_);
    std::vector<int> scored(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(std::min(most, order.size())));
    std::vector<int> rest(order.begin() + static_cast<std::ptrdiff_t>(scored.size()), order.end());
    std::stable_sort(rest.begin(), rest.end(), [&](int a, int b) { return excess(a) > excess(b); });

    std::vector<SurfacePatch> patches;
    patches.reserve(atlas_.size());
    for (const Chart& chart : atlas_.charts())
      patches.push_back({chart.centre, discArea(chart), chart.variance, chart.slope});
    // The poke's fantasy holds its approach's free space: the probe starts approach_distance_m
    // out along the normal (the evidence rule's distance, the approach pose's too).
    std::vector<TouchCandidate> candidates;
    for (int index : scored)
      candidates.push_back({atlas_.chart(index).centre, atlas_.chart(index).normal, config_.evidence.approach_distance_m});
    const TouchScores scores = scoreTouches(model_, rule_, patches, candidates, touch, config_.score, rng_());
    result_.scored_candidates = static_cast<int>(scored.size());
    result_.scored_charts = scored;
    result_.total_error = scores.total_error;
    // Best first. A score within kScoreTie of the best counts as the best, and the chart the atlas
    // made first among those goes first: the fantasy's last digits (a model rebuilt from a message
    // in another process) must not change the touch.
    constexpr double kScoreTie = 0.02;
    std::vector<std::size_t> by_score(scored.size());
    std::iota(by_score.begin(), by_score.end(), std::size_t{0});
    if (scores.ok && !by_score.empty()) {
      std::stable_sort(by_score.begin(), by_score.end(),
                       [&](std::size_t a, std::size_t b) { return scores.reduction[a] > scores.reduction[b]; });
      const double near_best = (1.0 - kScoreTie) * scores.reduction[by_score.front()];
      auto first_made = by_score.begin();
      for (auto it = by_score.begin(); it != by_score.end() && scores.reduction[*it] >= near_best; ++it)
        if (scored[*it] < scored[*first_made]) first_made = it;
      std::rotate(by_score.begin(), first_made, first_made + 1);
    }
    std::vector<std::pair<int, double>> tries;  // (chart, predicted reduction)
    for (std::size_t i : by_score) tries.emplace_back(scored[i], scores.ok ? scores.reduction[i] : 0.0);
    for (int index : rest) tries.emplace_back(index, 0.0);
    for (const auto& [index, reduction] : tries) {
      Chart& chart = atlas_.chart(index);
      if (takeApproach(chart)) {
        result_.predicted_reduction = reduction;
        result_.path = atlas_.pathTo(extendPath(index));
        std::ostringstream message;
        message.precision(3);
        message << "touching the chart whose poke removes the most error of " << scored.size() << " scored ("
                << needy_.size() << " need a touch: " << rule_.describe() << " or no evidence nearby); predicted "
                << 1e4 * reduction << " of " << 1e4 * scores.total_error << " cm^2"
                << (scores.ok ? "" : " (scoring failed: " + scores.message + ")");
        return PlanEnd{PlanStatus::kTouch, message.str()};
      }
      ++result_.unreachable_skipped;
      chart.out_of_reach = true;
    }
    return std::nullopt;
  }

 private:
  // The share of the work budget used: of the charts or of the queries, whichever is further.
  double budgetUsed() const {
    return std::max(static_cast<double>(atlas_.size()) / config_.max_charts,
                    static_cast<double>(result_.queries) / static_cast<double>(config_.max_queries));
  }

  // The smallest radius a new chart gets: rho_min_m until half the budget is used, then rising
  // to rho_max_m as the rest is, so that the atlas covers the surface with fewer, larger charts.
  double budgetRadiusFloor() const {
    constexpr double kCoarserFrom = 0.5;
    const double coarser = std::clamp((budgetUsed() - kCoarserFrom) / (1.0 - kCoarserFrom), 0.0, 1.0);
    return config_.chart.rho_min_m + coarser * (config_.chart.rho_max_m - config_.chart.rho_min_m);
  }

  bool capReached() {
    if (budgetUsed() < 1.0) return false;
    result_.budget_exhausted = true;
    return true;
  }

  std::string budgetMessage() const {
    return "the plan's work budget ran out (" + std::to_string(atlas_.size()) + " of " +
           std::to_string(config_.max_charts) + " charts, " + std::to_string(result_.queries) + " of " +
           std::to_string(config_.max_queries) + " queries)";
  }

  // The previous plan's charts: dropped where surface observations changed near them, where the
  // surface moved, or where the variance now allows a radius smaller than the chart's by more
  // than the shift tolerance (one batch of the mean, its gradient and the variance at the others'
  // centres: removed data, such as the guesses a touch retracts or the coarse level's
  // re-thinning, can raise the variance far from any new surface data); else kept, with the
  // variance and slope there now (`variances`, `slopes`, in the order of `kept`).
  void splitPrevious(const Atlas& previous, const std::vector<Vector3>& changed, std::vector<int>* kept,
                     std::vector<int>* dropped, std::vector<double>* variances, std::vector<double>* slopes) {
    std::vector<int> far;
    for (std::size_t i = 0; i < previous.size(); ++i) {
      const Chart& chart = previous.chart(static_cast<int>(i));
      const double reach = chart.radius + config_.reuse.near_new_data_m;
      const bool near = std::any_of(changed.begin(), changed.end(),
                                    [&](const Vector3& p) { return (p - chart.centre).squaredNorm() < reach * reach; });
      (near ? dropped : &far)->push_back(static_cast<int>(i));
    }
    if (far.empty()) return;
    Points3 centres(3, static_cast<Eigen::Index>(far.size()));
    for (std::size_t k = 0; k < far.size(); ++k) centres.col(static_cast<Eigen::Index>(k)) = previous.chart(far[k]).centre;
    const BatchPrediction now = model_.predictBatch(centres, true, false, true);
    result_.queries += static_cast<long>(far.size());
    const double min_cos = std::cos(config_.reuse.max_normal_change_rad);
    for (std::size_t k = 0; k < far.size(); ++k) {
      const auto q = static_cast<Eigen::Index>(k);
      const Chart& chart = previous.chart(far[k]);
      const Vector3 gradient = now.gradient.col(q);
      const double norm = gradient.norm();
      const double variance = now.variance(q);
      // The evidence that let the chart be that large may have changed (a surprising contact
      // trusts its surroundings less), and so may the variance its radius was made for: a chart
      // must not hide a point that now needs a touch.
      const bool stays = std::isfinite(now.mean(q)) && norm > 0.0 && gradient.allFinite() && std::isfinite(variance) &&
                         std::abs(now.mean(q)) / norm <= config_.reuse.max_centre_shift_m &&
                         gradient.dot(chart.normal) / norm >= min_cos &&
                         chart.radius - chartRadius(variance, config_.chart) <= config_.reuse.max_centre_shift_m &&
                         chart.radius <= evidence_.radiusCap(chart.centre, config_.chart.rho_min_m);
      (stays ? kept : dropped)->push_back(far[k]);
      if (stays) {
        variances->push_back(variance);
        slopes->push_back(norm);
      }
    }
    std::sort(dropped->begin(), dropped->end());
  }

  // The touch filter's direction for the chart, kept in it; false when it has none.
  bool takeApproach(Chart& chart) const {
    if (!reachable_) return true;
    const std::optional<Vector3> direction = reachable_(chart.centre, chart.normal);
    if (direction) chart.approach_direction = *direction;
    return direction.has_value();
  }

  // SELECTCHART.
  int selectChart(int continuation) {
    int selected = continuation;
    const bool continue_depth_first = unit_(rng_) < config_.depth_first_probability;
    if (!continue_depth_first || !atlas_.chart(selected).expandable()) {
      const std::vector<int> expandable = atlas_.expandableCharts();
      selected = expandable[std::uniform_int_distribution<std::size_t>(0, expandable.size() - 1)(rng_)];
    }
    return selected;
  }

  // EXPANDCHART toward the chart's highest-variance candidate (eq. 16): the new chart, not yet
  // added (ok false when the projection or the chart failed). The candidate is consumed
  // whatever happens, which bounds the search by the total number of candidates.
  ChartCreation expand(int parent_index) {
    const Chart& parent = atlas_.chart(parent_index);
    const auto best = std::max_element(parent.candidates.begin(), parent.candidates.end(),
                                       [](const ChartCandidate& a, const ChartCandidate& b) {
                                         return a.variance < b.variance;
                                       });
    Points3 start_point(3, 1), direction(3, 1);
    start_point.col(0) = best->ambient;
    direction.col(0) = parent.normal;
    atlas_.removeCandidate(parent_index, static_cast<std::size_t>(best - parent.candidates.begin()));
    ++result_.expansions;
    const SurfacePoint projected = projectOntoSurface(model_, start_point, direction, config_.projection).front();
    countProjection(projected);
    ChartCreation created;
    if (projected.ok) created = makeChart(projected, parent_index);
    if (!created.ok) ++result_.failed_projections;
    return created;
  }

  // The path's last chart, past the first chart that needs a touch (extend_path_charts, aim_past_m).
  int extendPath(int last) {
    // A scoring atlas grew without ranking its candidates; the path's extension goes toward the
    // highest variance (eq. 16), so from here on they are ranked.
    if (!rank_candidates_) {
      rank_candidates_ = true;
      rankCandidates(model_, &atlas_.chart(last).candidates);
      result_.queries += static_cast<long>(atlas_.chart(last).candidates.size());
    }
    for (int extra = 0; extra < config_.extend_path_charts; ++extra) {
      if (capReached()) break;
      if (atlas_.chart(last).candidates.empty()) break;
      ChartCreation extension = expand(last);
      if (!extension.ok) break;
      // A slide ends where the probe can still leave the surface.
      if (!takeApproach(extension.chart)) break;
      last = atlas_.addChart(std::move(extension.chart));
    }
    // Until the path has gone at least that far: in unsupported surface the charts are
    // rho_min_m wide, so the last step overshoots by less than that.
    for (double aimed = 0.0; config_.extend_path_charts == 0 && aimed < aim_past_m_;) {
      if (capReached()) break;
      if (atlas_.chart(last).candidates.empty()) break;
      ChartCreation extension = expand(last);
      if (!extension.ok || !needsTouch(extension.chart, false)) break;
      aimed += (extension.chart.centre - atlas_.chart(last).centre).norm();
      last = atlas_.addChart(std::move(extension.chart));
    }
    return last;
  }

  const SurfaceModel& model_;
  const StopRule rule_;
  const AtlasPlanner::Config& config_;
  const SurfaceEvidence& evidence_;
  const AtlasPlanner::Progress& progress_;
  const TouchFilter& reachable_;
  const double aim_past_m_;
  std::mt19937_64& rng_;
  AtlasPlanResult& result_;
  Atlas& atlas_;
  std::uniform_real_distribution<double> unit_{0.0, 1.0};
  std::vector<Vector3> uncovered_candidates_;
  std::size_t next_candidate_{0};
  int trees_{1};
  const bool scoring_;
  bool rank_candidates_{!scoring_};  // createChart's ranking of the candidates (eq. 16)
  std::vector<int> needy_;  // charts that need a touch (kBestScore), in the order found
};

}  // namespace

AtlasPlanResult AtlasPlanner::plan(const SurfaceModel& model, const StopRule& rule, const std::optional<Vector3>& start,
                                   const Progress& progress, const TouchFilter& reachable,
                                   const EvidenceState& evidence_state, const TouchObservationConfig& touch,
                                   AtlasMemory* memory, double aim_past_m) const {
  AtlasPlanResult result =
      grow(model, rule, start, progress, reachable, evidence_state, touch, memory, aim_past_m, config_.reuse.enabled);
  const bool ends_run = result.status == PlanStatus::kConverged || result.status == PlanStatus::kCapReached;
  if (!ends_run || result.reused_charts == 0) return result;
  // Convergence (or a spent budget) is what the run stops on, so it is decided on an atlas grown
  // afresh: one plan at the end of a run, which then claims exactly what a plan without reuse would.
  const double reused_s = result.elapsed_s;
  const long reused_queries = result.queries;
  const int kept = result.reused_charts;
  result = grow(model, rule, start, progress, reachable, evidence_state, touch, memory, aim_past_m, false);
  result.elapsed_s += reused_s;
  result.queries += reused_queries;
  result.message += "; grown afresh after the previous plan's atlas (" + std::to_string(kept) + " charts kept) found no touch";
  return result;
}

AtlasPlanResult AtlasPlanner::grow(const SurfaceModel& model, const StopRule& rule, const std::optional<Vector3>& start,
                                   const Progress& progress, const TouchFilter& reachable,
                                   const EvidenceState& evidence_state, const TouchObservationConfig& touch,
                                   AtlasMemory* memory, double aim_past_m, bool reuse) const {
  const Clock::time_point started = Clock::now();
  AtlasPlanResult result;
  const bool scoring = config_.selection == Config::Selection::kBestScore;
  const auto finish = [&](PlanStatus status, std::string message) {
    // The next plan grows from this atlas where the model lets it (a best-scoring atlas covers
    // the whole surface; Algorithm 1's stops at its first chart that needs a touch).
    if (memory && scoring && status != PlanStatus::kError) memory->remember(model, result.atlas);
    return finishPlan(result, status, std::move(message), started);
  };
  if (!model.isFitted()) return finish(PlanStatus::kError, "no model: the GP is not fitted");
  if (const std::string problem = validate(rule); !problem.empty()) return finish(PlanStatus::kError, problem);
  if (const std::string problem = validate(config_); !problem.empty())
    return finish(PlanStatus::kError, "invalid planner config: " + problem);
  if (!(aim_past_m >= 0.0) || !std::isfinite(aim_past_m))
    return finish(PlanStatus::kError, "aim_past_m " + std::to_string(aim_past_m) + " must be finite and >= 0");

  std::mt19937_64 rng(seed_);
  const SurfaceEvidence evidence(model, config_.evidence, evidence_state);
  AtlasGrowth growth(model, rule, config_, evidence, progress, reachable, aim_past_m, rng, result);
  int continuation = 0;
  std::vector<Vector3> changed;
  const bool reused = memory && scoring && reuse && memory->changesTo(model, &changed) &&
                      growth.adoptPrevious(memory->atlas, changed);
  if (!reused) {
    std::string error;
    const SurfacePoint root_point = selectSurfacePoint(model, start, config_, rng, &error);
    if (!root_point.ok) return finish(PlanStatus::kError, error);
    ChartCreation root = growth.makeChart(root_point, -1);
    if (!root.ok) return finish(PlanStatus::kError, "root chart: " + root.message);
    const bool root_needs_touch = growth.needsTouch(root.chart);
    continuation = growth.addChart(std::move(root.chart));
    // Algorithm 1 checks only new charts, but a root above V_max is itself the place to touch
    // (its candidates may all be covered or out of the domain).
    if (growth.endsPlan(root_needs_touch, continuation)) {
      result.path = result.atlas.pathTo(continuation);
      return finish(PlanStatus::kTouch, "the root chart needs a touch (" + rule.describe() + " or no evidence nearby)");
    }
  }
  growth.collectUncoveredCandidates();
  for (;;) {
    std::optional<PlanEnd> end = growth.growTree(continuation);
    bool rooted = false;
    if (!end) end = growth.rootNewTree(continuation, rooted);
    if (end && end->status == PlanStatus::kCapReached && growth.scoring()) {
      // A capped atlas still offers the touches it found.
      if (std::optional<PlanEnd> chosen = growth.chooseBest(touch))
        return finish(chosen->status, chosen->message + "; " + end->message + " (a coarser atlas)");
    }
    if (end) return finish(end->status, std::move(end->message));
    if (!rooted) break;
  }
  if (std::optional<PlanEnd> chosen = growth.chooseBest(touch)) return finish(chosen->status, std::move(chosen->message));
  return finish(PlanStatus::kConverged, "no expandable chart left in " + std::to_string(growth.trees()) +
                                            " tree(s) covering the surface observations: no " + rule.describe() + ", all near evidence");
}

}  // namespace gpatlas_core
