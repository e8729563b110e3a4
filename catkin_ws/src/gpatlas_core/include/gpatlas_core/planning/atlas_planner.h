#pragma once

#include "gpatlas_core/common/parameters.h"
#include "gpatlas_core/planning/atlas.h"
#include "gpatlas_core/planning/chart.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/observations/surface_evidence.h"
#include "gpatlas_core/model/surface_projection.h"
#include "gpatlas_core/observations/touch_training.h"
#include "gpatlas_core/planning/touch_score.h"
#include "gpatlas_core/planning/stop_rule.h"

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

// The direction the probe can come from to a touch of `point` (it moves along minus it): the
// outward normal, or one tilted from it when that approach is blocked; nullopt when there is
// none. A cheap test of the approach: the full plan is made for the chosen touch only. Empty:
// every point can be touched along its normal.
using TouchFilter = std::function<std::optional<Vector3>(const Vector3& point, const Vector3& outward_normal)>;

enum class PlanStatus : std::uint8_t {
  kTouch = 0,       // a touch (path) was found
  kConverged = 1,   // the predicted surface was covered without finding variance above V_max
  kCapReached = 2,  // the plan's work budget (charts, queries) ran out first: not a proof of convergence
  kError = 3        // bad input or unusable model; see the message
};
const char* toString(PlanStatus status);

struct AtlasPlanResult {
  PlanStatus status{PlanStatus::kError};
  std::string message;
  Atlas atlas;                     // every chart grown, for display
  std::vector<int> path;           // chart indices root -> new chart (kTouch only)
  double max_chart_variance{0.0};  // over all charts of the atlas
  int expansions{0};               // EXPANDCHART calls
  int failed_projections{0};       // candidates dropped because eq. 13 had no solution
  int retouch_skipped{0};          // charts above V_max at a measurement or an earlier target (EvidenceRule::retouch_radius_m)
  int unreachable_skipped{0};      // charts that needed a touch the TouchFilter said the probe cannot make
  // Their share of the atlas's area (each chart's disc, pi r^2, over all charts'). A converged
  // atlas covers the predicted surface: then about the share of it that needs a touch out of
  // reach (the discs overlap, about alike everywhere).
  double unreachable_area_fraction{0.0};
  // Selection::kBestScore: the charts that needed a touch, how many were scored, and the chosen
  // touch's predicted fall of the surface's error against the error before it (touch_score.h).
  int needy_charts{0};
  int scored_candidates{0};
  // Those scored charts (atlas indices), in the order they were sampled: for an analysis that
  // judges the same candidates another way (gpatlas_bench's oracle_poke).
  std::vector<int> scored_charts;
  double predicted_reduction{0.0};
  double total_error{0.0};
  double elapsed_s{0.0};
  // The work budget (AtlasPlanner::Config::max_charts, max_queries): the points the plan asked
  // the model about, and whether the budget, not convergence or a touch found, ended the growth
  // (a best-scoring plan then still offers the best touch it found: status kTouch).
  long queries{0};
  bool budget_exhausted{false};
  // Charts taken over from the previous plan (AtlasMemory) unchanged, and those of it the new
  // data (or the model's move) made the plan drop and grow again.
  int reused_charts{0};
  int dropped_charts{0};
};

// Which earlier charts a plan may keep (AtlasPlanner::Config::reuse). A touch changes the model
// near it (the local GPs of the cells it lands in) and the coarse level a little everywhere; a
// chart far from the new data keeps its centre, basis and radius unless the surface moved there
// by more than the tolerances below, and takes the model's variance and slope there now.
struct AtlasReuseConfig {
  bool enabled{true};
  // A chart whose ball comes this close to a surface observation added (or removed) since is
  // dropped and grown again: about a local cell's side. Free space and interior points change
  // the surface less; where they moved it, the tolerances below catch it.
  double near_new_data_m{0.015};
  // Elsewhere the mean, its gradient and the variance are asked again at every chart's centre
  // (one batch): the chart is dropped when the predicted surface moved further than this from it
  // (|f| / |grad f|), or when its variance is now so high that its radius (eq. 14) exceeds what
  // the variance allows by more than this (removed data, such as guesses a touch retracts, raise
  // the variance)...
  double max_centre_shift_m{0.001};
  // ... or its normal turned by more than this.
  double max_normal_change_rad{0.1};
};

// What a plan leaves for the next one: its atlas, and the model state it was grown on.
struct AtlasMemory {
  std::string model;
  Vector3 centroid{Vector3::Zero()};
  double scale{0.0};
  Eigen::VectorXd hyperparameters;
  std::vector<std::uint64_t> observations;  // observationHash of each observation
  std::vector<Vector3> surface_positions;   // where its surface observations lie, by hash
  std::vector<std::uint64_t> surface_hashes;
  Atlas atlas;
  // Whether the atlas was grown on an earlier state of `model` (the same model, frame and
  // hyperparameters); then `changed` gets the surface observations added or removed since.
  bool changesTo(const SurfaceModel& model, std::vector<Vector3>* changed) const;
  void remember(const SurfaceModel& model, const Atlas& grown);
};
// A hash of an observation (position, label, source, noise, targets, slope).
std::uint64_t observationHash(const TrainingPoint& point);

// GPAtlasRRT, paper Algorithm 1: grows an atlas over the GP's zero level set toward high
// variance and returns the tree path to the first chart whose centre variance exceeds V_max,
// run on by up to Config::extend_path_charts charts (a slide's; a poke plans with 0).
class AtlasPlanner {
 public:
  struct Config {
    ChartConfig chart;
    ProjectionConfig projection;
    // SELECTCHART: with this probability continue from the chart created by the previous
    // expansion (depth-first, toward variance), otherwise pick an expandable chart uniformly
    // (breadth). If the continuation chart has no candidates left, the uniform pick is used.
    double depth_first_probability{0.4};
    // The plan's work budget: charts, and points queried (the projections' iterations, the
    // charts' variances, ranked candidates, the reuse's checks; not the score's lookahead, which
    // TouchScoreConfig bounds). Past half of it the charts grow larger, their radius floor rising
    // from rho_min_m to rho_max_m as the rest is used: the atlas still covers the surface, more
    // coarsely, rather than stopping part way. A work budget, not a clock: a plan gives the same
    // answer on a loaded machine.
    int max_charts{3000};
    long max_queries{10000};
    // Growing from the previous plan's atlas (AtlasMemory) rather than from scratch (selection
    // kBestScore: an atlas over the whole surface).
    AtlasReuseConfig reuse;
    // A given start point must project onto the surface within this distance (metres).
    double max_start_distance_m{0.03};
    // Random training points tried as the root before giving up.
    int max_start_attempts{25};
    // Before reporting convergence, start new trees from surface observations that no chart
    // covers (a predicted surface in several pieces); false: only the root's tree (Algorithm 1
    // verbatim).
    bool cover_all_observations{true};
    // Once a chart above V_max is found, extend the path from it by up to this many charts,
    // each grown toward the highest-variance candidate of the previous one: a slide then runs
    // on into the unknown instead of stopping at its edge, up to the first chart plan()'s
    // `reachable` refuses. 0: Algorithm 1 verbatim, which atlas_poke always plans with (a poke
    // touches the path's last chart: AtlasStrategy).
    int extend_path_charts{20};
    // A chart without evidence (SurfaceEvidence) needs a touch whatever its variance, and
    // charts are kept small enough that none hides such a point (no max_distance: variance
    // alone, Algorithm 1). Read from evidence/, as every strategy's.
    EvidenceRule evidence;
    // Which chart that needs a touch is touched. kFirst: the first one the growth finds, where
    // it stops (Algorithm 1 verbatim). kBestScore: the atlas grows over the whole predicted
    // surface, and the chart whose poke would remove the most error (scoreTouches, over the
    // charts as the surface's patches, each with its disc's area) is touched, or the next best
    // one the TouchFilter accepts. atlas_slide always follows Algorithm 1's path, and plan()'s
    // aim_past_m is for kFirst's chart (AtlasStrategy).
    enum class Selection { kFirst, kBestScore };
    Selection selection{Selection::kBestScore};
    TouchScoreConfig score;
  };
  // Called after each chart is added (for progress displays); may be empty.
  using Progress = std::function<void(const Atlas& atlas)>;

  // `seed`: the plan's random choices (the root, SELECTCHART, the score's samples). A strategy
  // makes a planner per plan with the seed it derives from the run's and the plan's;
  // kStandaloneSeed is that of a plan made outside a run.
  static constexpr std::uint64_t kStandaloneSeed = 1;
  AtlasPlanner() = default;
  explicit AtlasPlanner(Config config, std::uint64_t seed = kStandaloneSeed) : config_(std::move(config)), seed_(seed) {}
  const Config& config() const { return config_; }

  // `start`: a point near the surface (e.g. the probe's position); without it the root is a
  // random on-surface training point of the model (SELECTSURFACEPOINT). A chart that needs a
  // touch `reachable` refuses is passed over: the atlas grows on past it, and the surface
  // counts as covered when only such charts are left. `evidence_state`: what the run has
  // learnt that the evidence test reads (Config::evidence).
  // `touch`: how a touch's measurements become observations, for the score's fantasy pokes.
  // `memory`: the previous plan's atlas, reused where the model allows (Config::reuse), and
  // replaced by this plan's; may be null. A reused atlas that finds no touch is grown again
  // from scratch before the plan reports convergence (or a spent budget).
  // `aim_past_m`: the first chart that needs a touch lies where the supported surface ends. A
  // probe with a footprint (a tactile pad) centred there spends half of it on surface already
  // measured, so past that chart the path goes on toward the highest variance, chart by chart
  // while each still needs a touch, until it has gone at least this distance (metres; the
  // request's footprint radius): the footprint's rim, not its centre, then meets the supported
  // surface. 0: the first chart (Algorithm 1). Only when Config::extend_path_charts is 0; a
  // negative or non-finite one is an error.
  AtlasPlanResult plan(const SurfaceModel& model, const StopRule& rule,
                       const std::optional<Vector3>& start = std::nullopt,
                       const Progress& progress = {}, const TouchFilter& reachable = {},
                       const EvidenceState& evidence_state = {}, const TouchObservationConfig& touch = {},
                       AtlasMemory* memory = nullptr, double aim_past_m = 0.0) const;

 private:
  // One growth, from the memory's atlas when `reuse` and the model allow it.
  AtlasPlanResult grow(const SurfaceModel& model, const StopRule& rule, const std::optional<Vector3>& start,
                       const Progress& progress, const TouchFilter& reachable, const EvidenceState& evidence_state,
                       const TouchObservationConfig& touch, AtlasMemory* memory, double aim_past_m,
                       bool reuse) const;

  Config config_;
  std::uint64_t seed_{kStandaloneSeed};
};

std::string validate(const AtlasPlanner::Config& config);
// Its reader: planner/ (but planner/surface_samples, the baselines'), score/ and evidence/, which
// every atlas strategy reads alike when it is made (strategy_registry.h).
void readAtlasPlanner(ParamReader& r, AtlasPlanner::Config* c);
// "first" or "best_score"; false for another name.
bool parseSelection(const std::string& name, AtlasPlanner::Config::Selection* selection);
const char* toString(AtlasPlanner::Config::Selection selection);

}  // namespace gpatlas_core
