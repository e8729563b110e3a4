#pragma once

// A touch's measurements as training data: the twin of view_training.h for a camera view.

#include "gpatlas_core/common/types.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/observations/observation_gate.h"
#include "gpatlas_core/observations/occluded_interior.h"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace gpatlas_core {

// How a touch's measurements become training points (touchTrainingPoints, applyTouch): the
// same rules in the bench's loop and in the GP model nodelet.
struct TouchObservationConfig {
  // Noise standard deviations of the new observations, in the model's reference units
  // (GpisModelConfig). The default is the paper's noise variance of 0.1 on every point.
  // With the paper's thin-plate kernel it must not be much smaller: that covariance is not
  // positive definite for dense point sets in 3-D, and the model would refuse touches as
  // singular.
  double contact_noise_sigma{0.3162};
  double free_space_noise_sigma{0.3162};
  // New contacts closer than this to one already kept from the same touch are dropped: a slide
  // reports a contact every few millimetres, and near-duplicates add O(n^2) cost to every later
  // query for almost no information (the GP's correlation length is centimetres). 0 keeps all.
  double min_point_spacing_m{0.004};
  // The same for free-space points, coarser: a slide's approach rays yield thousands of them,
  // each costing as much as a contact in every later query.
  double min_free_space_spacing_m{0.015};
  // A point this far behind each contact (against the contact's normal, which faces the side
  // the probe came from) is labelled inside with that depth. Without it a thin wall touched
  // from one side has surface points and free space but nothing inside, so the GP's level
  // set can vanish there. It must stay below the thinnest wall to be explored; 0: contacts
  // alone (the paper). Contacts without a normal (zero vector) get none.
  double contact_inside_depth_m{0.003};
  // Their noise, in reference units: tighter than contact_noise_sigma, or the tiny target
  // (-depth / scale) would be lost in the noise.
  double contact_inside_noise_sigma{0.1};
  // Each kept contact with a normal also observes that f does not change across that normal:
  // two slope observations (TrainingPoint::slope_direction) along tangents, target 0, with
  // this noise sigma (reference units). They give the GP the measured normal's direction
  // without assuming f's slope along it: between sparse contacts the surface follows the
  // measured normals. A probe that reports no normal gives none. Empty: none (the paper).
  std::optional<double> contact_tangent_noise_sigma{0.1};
  // A touch's contacts and free space retract the occluded-interior guesses they contradict
  // (retractContradictedInterior), dropping those left shallower than this fraction of the
  // model's scale (the view's radius; the occluded interior's own margin_fraction).
  double guess_min_depth_fraction{0.08};
  // At most this many contacts and free-space points per touch after thinning: a touch with
  // more is thinned at a coarser spacing (empty: no cap). Every contact costs the model's coarse
  // level a row of its O(n^3) factor, so one dense touch must not be able to stall it.
  std::optional<std::size_t> max_contacts_per_touch{500};
  std::optional<std::size_t> max_free_space_per_touch{1000};
  // The most training points from touches (contacts, the points behind them, slopes, free
  // space) the model holds: the bound on its memory and on the cost of every later query
  // however long the exploration runs (empty: no bound). A touch that would pass it is thinned to
  // the room left, its free space first; once there is no room, touches are refused and the
  // exploration stops (TouchUpdate::budget_full).
  std::optional<std::size_t> max_touch_observations{20000};
  // Which observations the model takes at all (gateObservations), checked first.
  ObservationGateConfig gate;
};

// Empty when the config is usable; otherwise what is wrong with it.
std::string validate(const TouchObservationConfig& config);

// What adding one touch's measurements did to the model.
struct TouchUpdate {
  // False when the model refused the touch (it is then unchanged) or was not fitted.
  bool ok{false};
  std::string message;
  int contacts_added{0};     // surface points accepted by the model
  std::vector<Vector3> contact_positions;  // those points, world frame (contacts_added of them)
  int free_points_added{0};  // outside points accepted by the model
  int points_added{0};       // every training point accepted (points behind contacts, slopes too)
  InteriorRetraction retraction;  // occluded-interior guesses the touch contradicted
  // Observations the gate refused (TouchObservationConfig::gate), and why in `warnings`.
  GateRefusals contacts_refused;
  GateRefusals free_space_refused;
  // Non-zero: the touch had this many contacts after thinning, above max_contacts_per_touch.
  std::size_t contacts_capped_from{0};
  // The model holds max_touch_observations points from touches: this touch was refused, and
  // so will every other be.
  bool budget_full{false};
  std::vector<std::string> warnings;
};

// Greedy thinning of one touch's contacts or free space: the finite points, in order, that lie at
// least `spacing_m` from every point kept before them (spacing_m <= 0 keeps them all).
std::vector<Vector3> thinToSpacing(const std::vector<Vector3>& points, double spacing_m);
// A touch's free space thinned to `spacing_m`, the points nearest the touch's contacts kept
// first: they pin the surface down, while those a probe's length away hardly constrain it.
std::vector<Vector3> thinFreeSpace(const std::vector<Vector3>& free_space, const std::vector<Vector3>& contacts,
                                   double spacing_m);

// How many of touchTrainingPoints' points are of each kind (in this order in its output).
struct TouchPointCounts {
  std::size_t contacts{0};
  std::size_t contact_inside{0};
  std::size_t contact_tangents{0};
  std::size_t free_space{0};
  // Non-zero when the per-touch caps thinned further: the counts before, and the spacing used.
  std::size_t contacts_before_cap{0};
  double capped_contact_spacing_m{0.0};
  std::size_t free_space_before_cap{0};
  double capped_free_space_spacing_m{0.0};
};

// A touch's observations as training points for `model` (used by the Explorer and by the GP
// model nodelet): contacts thinned to config.min_point_spacing_m; behind each kept contact with
// a normal, an inside point at config.contact_inside_depth_m, then (when
// config.contact_tangent_noise_sigma >= 0) its two tangent slope observations; free space inside the model's
// domain thinned to config.min_free_space_spacing_m, nearest the contacts first, and labelled
// with its distance to the nearest contact or model surface point.
std::vector<TrainingPoint> touchTrainingPoints(const SurfaceModel& model, const std::vector<Contact>& contacts,
                                               const std::vector<Vector3>& free_space, const TouchObservationConfig& config,
                                               TouchPointCounts* counts = nullptr);

// Where a touch measured something: its contacts' positions and its free space (before
// thinning), the points that retract the guesses they contradict (addTouchPoints).
std::vector<Vector3> measuredPositions(const std::vector<Contact>& contacts, const std::vector<Vector3>& free_space);

// Adds a touch's training points (from touchTrainingPoints) to a fitted model. First the
// touch's measured points (`evidence`: measuredPositions of the touch) retract
// the occluded-interior guesses they contradict; the
// update is incremental when nothing was retracted, and a full refit in the model's current
// frame otherwise. On failure the model is unchanged. The report's num_added counts the new
// points the model accepted (not the retained old ones).
FitReport addTouchPoints(SurfaceModel& model, const std::vector<TrainingPoint>& new_points,
                         const std::vector<Vector3>& evidence, const TouchObservationConfig& config,
                         InteriorRetraction* retraction = nullptr);

// What one touch measured, added to a fitted model: touchTrainingPoints, then addTouchPoints.
// A batch the model refuses as numerically singular (e.g. a free-space point right next to a
// surface point) is retried with the contacts alone (and the points behind them): the
// contacts are what the touch was for. The refused free space still retracts guesses.
TouchUpdate applyTouch(SurfaceModel& model, const std::vector<Contact>& contacts, const std::vector<Vector3>& free_space,
                       const TouchObservationConfig& config);

}  // namespace gpatlas_core
