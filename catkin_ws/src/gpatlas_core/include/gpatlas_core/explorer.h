#pragma once

#include "gpatlas_core/exploration_strategy.h"
#include "gpatlas_core/gpis_model.h"
#include "gpatlas_core/hyperparameter_tuner.h"
#include "gpatlas_core/prober.h"
#include "gpatlas_core/surface_evidence.h"
#include "gpatlas_core/types.h"
#include "gpatlas_core/view_free_space.h"

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

// One iteration of Algorithm 2.
struct ExplorationRecord {
  int index{0};                  // 0-based action number
  PlanStatus plan_status{PlanStatus::kError};
  bool probe_success{false};
  std::string probe_reason;      // the prober's reason when the touch failed
  int contacts_added{0};         // surface points accepted by the model
  int free_points_added{0};      // outside points accepted by the model
  double max_surface_variance{0.0};  // the strategy's estimate before this action
  double plan_ms{0.0};
  double update_ms{0.0};         // model update (and re-tuning, when it happened)
  bool retuned{false};
  std::string update_message;    // why the model refused the new points, if it did
  InteriorRetraction retraction; // occluded-interior guesses this touch contradicted
  Touch touch;
};

struct ExplorationResult {
  // "converged", "max_actions", "consecutive_failures", "planner_cap_reached",
  // "planner_error: ...", "invalid_config: ...". A touch whose points the model refuses
  // counts as a failed touch (see ExplorationRecord::update_message).
  std::string stop_reason;
  bool converged{false};
  int actions{0};  // touches executed (probed), failed ones included
  std::vector<ExplorationRecord> records;
  // The strategy's estimate on the final model (from the plan that ended the run).
  double final_max_surface_variance{0.0};
};

// Greedy thinning of one touch's contacts or free space: the finite points, in order, that lie at
// least `spacing_m` from every point kept before them (spacing_m <= 0 keeps them all).
std::vector<Vector3> thinToSpacing(const std::vector<Vector3>& points, double spacing_m);
// A touch's free space thinned to `spacing_m`, the points nearest the touch's contacts kept
// first: they pin the surface down, while those a probe's length away hardly constrain it.
std::vector<Vector3> thinFreeSpace(const std::vector<Vector3>& free_space, const std::vector<Vector3>& contacts,
                                   double spacing_m);

// Tactile exploration, paper Algorithm 2: plan a touch on the current model, probe it, add the
// contacts as surface points and the free-space observations as outside points, update the
// model incrementally, and repeat until the strategy reports convergence.
class Explorer {
 public:
  struct Config {
    double v_max{0.1};
    int max_actions{100};
    // The paper's extra stop on the real robot: this many failed touches in a row.
    int max_consecutive_failures{5};
    // Noise standard deviations of the new observations, in the model's reference units
    // (GpisModelConfig). The default is the paper's noise variance of 0.1 on every point.
    // With the paper's thin-plate kernel it must not be much smaller: that covariance is not
    // positive definite for dense point sets in 3-D, and the model would refuse touches as
    // singular.
    double contact_noise_sigma{0.316};
    double free_space_noise_sigma{0.316};
    // Free-space points carry their distance to the nearest surface point, so their target is
    // about their normalised distance to the surface (at most +1) instead of +1.
    bool free_space_distance_targets{true};
    // New contacts closer than this to one already kept from the same touch are dropped: a slide reports a contact every few millimetres,
    // and near-duplicates add O(n^2) cost to every later query for almost no information
    // (the GP's correlation length is centimetres). 0 keeps every point.
    double min_point_spacing_m{0.004};
    // The same for free-space points, coarser: a slide's approach rays yield thousands of them
    // (measured: 5000 of the 6500 training points after 15 slides on the jug), each costing
    // as much as a contact in every later query.
    double min_free_space_spacing_m{0.015};
    // A point this far behind each contact (against the contact's normal, which faces the side
    // the probe came from) is labelled inside with that depth. Without it a thin wall touched
    // from one side has surface points and free space but nothing inside, so the GP's level
    // set can vanish there (measured: a container's carved cavity lost its walls and bottom).
    // It must stay below the thinnest wall to be explored; 0: contacts alone (the paper).
    // Contacts without a normal (zero vector) get none.
    double contact_inside_depth_m{0.003};
    // Their noise, in reference units: tighter than contact_noise_sigma, or the tiny target
    // (-depth / scale) would be lost in the noise.
    double contact_inside_noise_sigma{0.1};
    // Each kept contact with a normal also observes that f does not change across that normal:
    // two slope observations (TrainingPoint::slope_direction) along tangents, target 0, with
    // this noise sigma (reference units). They give the GP the measured normal's direction
    // without assuming f's slope along it. Negative: none (the paper).
    double contact_tangent_noise_sigma{-1.0};
    // The evidence test (SurfaceEvidence): exploration has converged only when no predicted
    // surface point lacks evidence. A distance of 0.5 by default; attempted_targets given here
    // count from the start.
    EvidenceRule evidence{0.5, std::nullopt, 0.1, {}};
    // The surface points touches aimed at (a poke's target, a slide's path) count as evidence
    // (EvidenceRule::attempted_targets), whatever the touch found: otherwise a point whose
    // approach another part of the object blocks is asked for again after every touch
    // (measured: 60 pokes on the scanned mug at evidence distance 0.3).
    bool attempts_are_evidence{true};
    // A touch's contacts and free space retract the occluded-interior guesses they contradict
    // (retractContradictedInterior), dropping those left shallower than this fraction of the
    // model's scale (the view's radius; sampleOccludedInterior's own clearance is 0.08).
    bool retract_contradicted_guesses{true};
    double guess_min_depth_fraction{0.08};
    // Re-tune the hyperparameters after every k-th action; 0 never re-tunes.
    int retune_every{0};
    HyperparameterTuner::Config tuner;
    std::uint64_t seed{1};
  };
  // Called after every action with its record; may be empty.
  using Progress = std::function<void(const ExplorationRecord& record, const GpisModel& model)>;

  Explorer() = default;
  explicit Explorer(Config config) : config_(std::move(config)) {}
  const Config& config() const { return config_; }

  // `model` must be fitted (the initial view); it is updated in place.
  ExplorationResult run(GpisModel& model, const ExplorationStrategy& strategy, Prober& prober,
                        const Progress& progress = {}) const;

 private:
  Config config_;
};

// How many of touchTrainingPoints' points are of each kind (in this order in its output).
struct TouchPointCounts {
  std::size_t contacts{0};
  std::size_t contact_inside{0};
  std::size_t contact_tangents{0};
  std::size_t free_space{0};
};

// A touch's observations as training points for `model` (used by the Explorer and by the GP
// model nodelet): contacts thinned to config.min_point_spacing_m; behind each kept contact with
// a normal, an inside point at config.contact_inside_depth_m, then (when
// config.contact_tangent_noise_sigma >= 0) its two tangent slope observations; free space inside the model's
// domain thinned to config.min_free_space_spacing_m, nearest the contacts first, and labelled
// with its distance to the surface when config.free_space_distance_targets.
std::vector<TrainingPoint> touchTrainingPoints(const GpisModel& model, const std::vector<Contact>& contacts,
                                               const std::vector<Vector3>& free_space, const Explorer::Config& config,
                                               TouchPointCounts* counts = nullptr);

// Where a touch measured something: its contacts' positions and its free space (before
// thinning), the points that retract the guesses they contradict (addTouchPoints).
std::vector<Vector3> measuredPositions(const std::vector<Contact>& contacts, const std::vector<Vector3>& free_space);

// Adds a touch's training points (from touchTrainingPoints) to a fitted model. First the
// touch's measured points (`evidence`: measuredPositions of the touch) retract
// the occluded-interior guesses they contradict, when config.retract_contradicted_guesses; the
// update is incremental when nothing was retracted, and a full refit in the model's current
// frame otherwise. On failure the model is unchanged. The report's num_added counts the new
// points the model accepted (not the retained old ones).
FitReport addTouchPoints(GpisModel& model, const std::vector<TrainingPoint>& new_points,
                         const std::vector<Vector3>& evidence, const Explorer::Config& config,
                         InteriorRetraction* retraction = nullptr);

}  // namespace gpatlas_core
