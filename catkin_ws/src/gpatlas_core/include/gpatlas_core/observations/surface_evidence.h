#pragma once

#include "gpatlas_core/common/parameters.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/common/types.h"
#include "gpatlas_core/observations/support_plane.h"
#include "gpatlas_core/observations/view_shadow.h"

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

namespace gpatlas_core {

// The evidence test's settings: config/pipeline.yaml's evidence/ section (readEvidence). Every
// strategy reads them from that section when it is made; what the run has learnt that the test
// also reads (EvidenceState) comes with each plan.
struct EvidenceRule {
  // A predicted surface point farther than this (normalised units: the initial view's radius
  // is 1) from every measured surface point needs a touch whatever its variance. Empty: V_max
  // alone (the paper).
  std::optional<double> max_distance{0.35};
  // A view point supports the predicted surface only this close (normalised units, at most
  // max_distance). A dense view covers what the camera saw within a few of
  // its point spacings; what lies farther from it (the unseen back beyond the silhouette, a
  // cavity the rim hid) was not seen, however near a view point it is, and needs a touch.
  double view_max_distance{0.2};
  // How far along the normal a probe approaches a touch: surface whose approach would start
  // under the table (EvidenceState::support_plane) needs no evidence.
  double approach_distance_m{0.1};
  // A touch that found the surface far from where the model predicted it shows that the model
  // is wrong around there, however low its variance: such a contact supports the surface only
  // within max_distance * clamp(surprise_distance_m / error, min_surprise_fraction, 1), where
  // error is how far from the predicted surface it lay (TrainingPoint::prediction_error_m), so
  // that touches go on where the model's guesses fail and not where they hold. The same for an
  // attempted target the touch found the surface away from
  // (EvidenceState::attempted_target_errors_m). Empty: every contact and target supports
  // max_distance.
  std::optional<double> surprise_distance_m{0.005};
  double min_surprise_fraction{0.2};
  // A place whose variance is above V_max needs no touch when a measured surface point (a view
  // point or a contact) or an earlier touch's target lies within this distance: a touch there
  // would find what was found already. Otherwise a V_max below what the noise allows would
  // spend every touch where nothing is left to learn (0: variance alone).
  double retouch_radius_m{0.005};
};

// Empty when the rule is usable; otherwise what is wrong with it.
std::string validate(const EvidenceRule& rule);
// Its reader: evidence/, read alike by every component that tests evidence.
void readEvidence(ParamReader& r, EvidenceRule* c);

// What a run has learnt that the evidence test reads besides the model's measurements: the
// table under the object (the planner's own knowledge, from segmentation) and where earlier
// touches aimed (the exploration loop's). It travels in PlanRequest.
struct EvidenceState {
  // The table the object rests on, if known: surface whose probe approach would start below it
  // cannot be touched, and the table is its evidence.
  std::optional<SupportPlane> support_plane;
  // Surface points earlier touches aimed at (world frame): evidence whatever the touch found.
  std::vector<Vector3> attempted_targets;
  // Per attempted target (empty, or one each): how far from it its touch found the surface,
  // the nearest contact (metres); NaN when the touch found none (refused, or nothing in the way),
  // which supports max_distance.
  std::vector<double> attempted_target_errors_m;
  // The camera views the model was built from (the sensor's origin and the object's points):
  // what lies behind them as seen from the sensor was never observed (ViewShadow). Read by the
  // frontier strategy only; empty: nothing is known to be unobserved.
  std::vector<CameraView> views;
  // Touches into unobserved space (Touch::explores_unknown) that found no contact: the budget the
  // frontier strategy spends (the Explorer counts them).
  int empty_unknown_pokes{0};
};

// Empty when the state is usable; otherwise what is wrong with it.
std::string validate(const EvidenceState& state);

// The state a planner plans with: its own (`own`: the table it knows of, and any targets it
// holds) and the one a request brings (`requested`: where the loop's touches aimed), the
// requested targets after its own. The table is the planner's when it knows one, otherwise the
// request's; the views are both sides', its own first; the empty pokes their sum. Errors stay
// one per target, NaN for the targets of a side that gave none; both sides without errors give
// none. False, with why, when a side's errors do not match its targets or a view is not finite.
// The bench's planner (ModelTouchPlanner) and the ROS planner nodelet both plan through it.
bool mergeEvidenceState(const EvidenceState& own, const EvidenceState& requested, EvidenceState* merged,
                        std::string* error);

// Where the predicted surface rests on measurements. The GP's variance falls within a
// correlation length of any data, and its correlation length is about the object's size, so a
// wrong but nearby guess (a container's cavity closed by a lid a few centimetres below the rim,
// the filled hole of a handle) has a low variance and is never touched. The distance from a
// predicted surface point to the nearest measured surface point (a view point or a contact;
// not the guessed inside points, the free space or the pseudo-points) says whether anything
// was ever seen or felt there, or tried (a touch aimed there). A view point vouches for less
// than a contact (EvidenceRule::view_max_distance): the camera samples what it saw densely, so
// surface farther from its points was not seen.
class SurfaceEvidence {
 public:
  // `max_distance_m`: the distance beyond which a surface point is unsupported; empty turns the
  // test off (isUnsupported is always false, radiusCap is infinite). Throws
  // std::invalid_argument when a given distance is not finite and > 0 (the view's: >= 0), or
  // min_surprise_fraction is outside (0, 1].
  // With `support`, the table the object rests on: a surface point whose probe approach
  // (approach_m along its outward normal) would start below the table cannot be touched, and
  // the table is its evidence (an object's underside; touches there hit the table).
  // `attempted`: surface points that touches already aimed at (EvidenceState::attempted_targets)
  // count as evidence too, whatever the touch found: a point the probe cannot reach (its
  // approach blocked by another part of the object) is not asked for again and again.
  // `view_max_distance_m`: how far a view point (source vision) supports the surface, at most
  // max_distance_m (empty: max_distance_m, as contacts and attempted targets).
  // `surprise_distance_m` (with `min_surprise_fraction` in (0, 1]): a contact, or an
  // attempted target with a finite `attempted_errors_m`, supports the surface within
  // max_distance_m * surpriseFraction(its error) (EvidenceRule::surprise_distance_m).
  SurfaceEvidence(const SurfaceModel& model, std::optional<double> max_distance_m,
                  const std::optional<SupportPlane>& support = std::nullopt, double approach_m = 0.0,
                  const std::vector<Vector3>& attempted = {}, std::optional<double> view_max_distance_m = std::nullopt,
                  const std::vector<double>& attempted_errors_m = {},
                  std::optional<double> surprise_distance_m = std::nullopt, double min_surprise_fraction = 1.0);
  // The same from a rule and a run's state, the rule's distances converted with the model's scale.
  SurfaceEvidence(const SurfaceModel& model, const EvidenceRule& rule, const EvidenceState& state = {});

  bool enabled() const { return max_distance_m_ > 0.0; }
  // The share of max_distance a measurement that lay `error_m` from the predicted surface
  // supports: 1 up to the surprise distance (or without one, or for an unknown error), then
  // surprise distance / error, never below the minimum fraction.
  double surpriseFraction(double error_m) const;
  double maxDistance() const { return max_distance_m_; }
  // Distance (metres) to the nearest measured surface point, or infinity when none lies
  // within max_distance_m (only that range is searched).
  double distance(const Vector3& x) const;
  // How far x lies inside the support of its best measured point: max over them of (its
  // support radius - its distance to x); negative (or -infinity) when x is unsupported.
  double supportSlack(const Vector3& x) const;
  bool isUnsupported(const Vector3& x) const { return enabled() && supportSlack(x) < 0.0; }
  // The same for a surface point with its outward normal, with the support plane's exemption.
  bool isUnsupported(const Vector3& x, const Vector3& normal) const;
  // The largest chart radius around x whose whole ball stays supported: a chart that reaches
  // farther could hide an unsupported surface point inside its ball. Never below `floor_m`.
  double radiusCap(const Vector3& x, double floor_m) const;
  std::size_t size() const { return points_.size(); }
  // Whether a measured surface point or an `attempted` target lies within `radius_m` of x,
  // whether or not the distance test is enabled.
  bool measuredNear(const Vector3& x, double radius_m) const;

 private:
  // Calls visit(index into points_) for the points in the 27 cells around x (every point within
  // cell_m_ of it), until visit returns false.
  template <typename Visit>
  void forEachCandidate(const Vector3& x, Visit visit) const;
  // The cell of x (side cell_m_), moved by (di, dj, dk) cells, packed into one key.
  std::int64_t key(const Vector3& x, int di = 0, int dj = 0, int dk = 0) const;
  double max_distance_m_{0.0};
  double cell_m_{0.0};  // max_distance_m_, or a fixed side when the distance test is off
  std::optional<SupportPlane> support_;
  double approach_m_{0.0};
  double surprise_distance_m_{0.0};
  double min_surprise_fraction_{1.0};
  std::vector<Vector3> points_;  // measured surface points and attempted targets
  std::vector<double> support_radius_m_;  // per point: how far it supports the surface
  std::unordered_map<std::int64_t, std::vector<std::uint32_t>> cells_;  // cell side cell_m_
};

}  // namespace gpatlas_core
