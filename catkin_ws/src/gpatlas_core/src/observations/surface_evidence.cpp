#include "gpatlas_core/observations/surface_evidence.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace gpatlas_core {

namespace {
constexpr std::int64_t kCellRange = 1 << 20;  // cells per axis: enough for any scene in metres
// The grid's cell side when the distance test is off (measuredNear alone): about a retouch radius.
constexpr double kRetouchCellM = 0.01;
std::optional<double> scaled(std::optional<double> normalised, double scale) {
  if (normalised) return *normalised * scale;
  return std::nullopt;
}
std::int64_t packCell(std::int64_t i, std::int64_t j, std::int64_t k) {
  return ((i + kCellRange / 2) * kCellRange + (j + kCellRange / 2)) * kCellRange + (k + kCellRange / 2);
}
}  // namespace

namespace {
// The distance, or why it is no distance; empty stays empty (the feature off).
std::optional<double> checkedDistance(std::optional<double> distance_m, const char* name, bool zero_allowed) {
  if (distance_m && !(std::isfinite(*distance_m) && (*distance_m > 0.0 || (zero_allowed && *distance_m == 0.0))))
    throw std::invalid_argument(std::string("SurfaceEvidence: ") + name + " must be finite and " +
                                (zero_allowed ? ">= 0" : "> 0") + ", or empty (off)");
  return distance_m;
}
}  // namespace

SurfaceEvidence::SurfaceEvidence(const SurfaceModel& model, std::optional<double> max_distance_m,
                                 const std::optional<SupportPlane>& support, double approach_m,
                                 const std::vector<Vector3>& attempted, std::optional<double> view_max_distance_m,
                                 const std::vector<double>& attempted_errors_m,
                                 std::optional<double> surprise_distance_m, double min_surprise_fraction)
    : max_distance_m_(checkedDistance(max_distance_m, "max_distance_m", false).value_or(0.0)),
      cell_m_(enabled() ? max_distance_m_ : kRetouchCellM),
      surprise_distance_m_(checkedDistance(surprise_distance_m, "surprise_distance_m", false).value_or(0.0)),
      min_surprise_fraction_(min_surprise_fraction) {
  if (!(min_surprise_fraction > 0.0 && min_surprise_fraction <= 1.0))
    throw std::invalid_argument("SurfaceEvidence: min_surprise_fraction must be in (0, 1]");
  const double view_radius_m =
      std::min(checkedDistance(view_max_distance_m, "view_max_distance_m", true).value_or(max_distance_m_), max_distance_m_);
  // Without the distance test the points are still kept for measuredNear, on a grid of its own.
  const auto add = [&](const Vector3& p, double radius_m) {
    if (!p.allFinite()) return;
    cells_[key(p)].push_back(static_cast<std::uint32_t>(points_.size()));
    points_.push_back(p);
    support_radius_m_.push_back(radius_m);
  };
  for (const TrainingPoint& point : model.observations()) {
    if (!isSurfaceValue(point)) continue;  // a contact's slopes add nothing to the contact
    if (point.source == PointSource::kVision) add(point.position, view_radius_m);
    if (point.source == PointSource::kTouch)
      add(point.position, max_distance_m_ * surpriseFraction(point.prediction_error_m));
  }
  for (std::size_t i = 0; i < attempted.size(); ++i)
    add(attempted[i], max_distance_m_ * surpriseFraction(i < attempted_errors_m.size()
                                                              ? attempted_errors_m[i]
                                                              : std::numeric_limits<double>::quiet_NaN()));
  if (support && support->normal.allFinite() && support->normal.norm() > 0.5 && std::isfinite(support->offset)) {
    support_ = SupportPlane{support->normal.normalized(), support->offset / support->normal.norm()};
    approach_m_ = std::isfinite(approach_m) ? std::max(0.0, approach_m) : 0.0;
  }
}

SurfaceEvidence::SurfaceEvidence(const SurfaceModel& model, const EvidenceRule& rule, const EvidenceState& state)
    : SurfaceEvidence(model, scaled(rule.max_distance, model.scale()), state.support_plane, rule.approach_distance_m,
                      state.attempted_targets, rule.view_max_distance * model.scale(), state.attempted_target_errors_m,
                      rule.surprise_distance_m, rule.min_surprise_fraction) {}

double SurfaceEvidence::surpriseFraction(double error_m) const {
  if (!(surprise_distance_m_ > 0.0) || !std::isfinite(error_m) || error_m <= surprise_distance_m_) return 1.0;
  return std::max(min_surprise_fraction_, surprise_distance_m_ / error_m);
}

bool SurfaceEvidence::measuredNear(const Vector3& x, double radius_m) const {
  if (!x.allFinite() || !(radius_m > 0.0)) return false;
  const double squared = radius_m * radius_m;
  const auto near = [&](const Vector3& p) { return (p - x).squaredNorm() <= squared; };
  if (radius_m > cell_m_) return std::any_of(points_.begin(), points_.end(), near);
  bool found = false;
  forEachCandidate(x, [&](std::uint32_t index) {
    found = near(points_[index]);
    return !found;
  });
  return found;
}

template <typename Visit>
void SurfaceEvidence::forEachCandidate(const Vector3& x, Visit visit) const {
  for (int di = -1; di <= 1; ++di)
    for (int dj = -1; dj <= 1; ++dj)
      for (int dk = -1; dk <= 1; ++dk) {
        const auto it = cells_.find(key(x, di, dj, dk));
        if (it == cells_.end()) continue;
        for (const std::uint32_t index : it->second)
          if (!visit(index)) return;
      }
}

void readEvidence(ParamReader& r, EvidenceRule* c) {
  c->max_distance = r.optionalNumber("evidence/max_distance", c->max_distance, 100.0);
  c->view_max_distance = r.number("evidence/view_max_distance", c->view_max_distance, 0.0, 100.0);
  c->approach_distance_m = r.number("evidence/approach_distance_m", c->approach_distance_m, 0.0, 10.0);
  c->retouch_radius_m = r.number("evidence/retouch_radius_m", c->retouch_radius_m, 0.0, 1.0);
  c->surprise_distance_m = r.optionalNumber("evidence/surprise_distance_m", c->surprise_distance_m, 1.0);
}

std::string validate(const EvidenceRule& rule) {
  if (!(rule.retouch_radius_m >= 0.0) || !std::isfinite(rule.retouch_radius_m))
    return "retouch_radius_m must be finite and >= 0";
  if (!(rule.approach_distance_m >= 0.0) || !std::isfinite(rule.approach_distance_m))
    return "approach_distance_m must be finite and >= 0";
  if (rule.max_distance && (!(*rule.max_distance > 0.0) || !std::isfinite(*rule.max_distance)))
    return "max_distance must be finite and > 0, or empty (V_max alone)";
  if (!(rule.view_max_distance >= 0.0) || !std::isfinite(rule.view_max_distance))
    return "view_max_distance must be finite and >= 0";
  if (rule.surprise_distance_m && (!(*rule.surprise_distance_m > 0.0) || !std::isfinite(*rule.surprise_distance_m)))
    return "surprise_distance_m must be finite and > 0, or empty (every contact supports max_distance)";
  if (!(rule.min_surprise_fraction > 0.0 && rule.min_surprise_fraction <= 1.0))
    return "min_surprise_fraction must be in (0, 1]";
  return "";
}

std::string validate(const EvidenceState& state) {
  if (!state.attempted_target_errors_m.empty() && state.attempted_target_errors_m.size() != state.attempted_targets.size())
    return "attempted_target_errors_m must be empty or hold one value per attempted target";
  if (state.empty_unknown_pokes < 0) return "empty_unknown_pokes must be >= 0";
  // A target that is not a point would vouch for nothing and be passed over without a word.
  for (std::size_t i = 0; i < state.attempted_targets.size(); ++i)
    if (!state.attempted_targets[i].allFinite()) return "attempted_targets[" + std::to_string(i) + "] is not finite";
  for (const CameraView& view : state.views)
    if (std::string problem = validate(view); !problem.empty()) return problem;
  return "";
}

bool mergeEvidenceState(const EvidenceState& own, const EvidenceState& requested, EvidenceState* merged,
                        std::string* error) {
  for (const EvidenceState* side : {&own, &requested})
    if (std::string problem = validate(*side); !problem.empty()) {
      *error = problem;
      return false;
    }
  EvidenceState result = own;
  if (!result.support_plane) result.support_plane = requested.support_plane;
  std::vector<double>& errors = result.attempted_target_errors_m;
  if (!errors.empty() || !requested.attempted_target_errors_m.empty()) {
    const double unknown = std::numeric_limits<double>::quiet_NaN();
    errors.resize(own.attempted_targets.size(), unknown);
    errors.insert(errors.end(), requested.attempted_target_errors_m.begin(), requested.attempted_target_errors_m.end());
    errors.resize(own.attempted_targets.size() + requested.attempted_targets.size(), unknown);
  }
  result.attempted_targets.insert(result.attempted_targets.end(), requested.attempted_targets.begin(),
                                  requested.attempted_targets.end());
  result.views.insert(result.views.end(), requested.views.begin(), requested.views.end());
  result.empty_unknown_pokes += requested.empty_unknown_pokes;
  *merged = std::move(result);
  return true;
}

bool SurfaceEvidence::isUnsupported(const Vector3& x, const Vector3& normal) const {
  if (!isUnsupported(x)) return false;
  if (!support_ || !normal.allFinite() || !(normal.norm() > 0.0)) return true;
  const Vector3 approach_start = x + approach_m_ * normal.normalized();
  return support_->height(approach_start) >= 0.0 && support_->height(x) >= 0.0;
}

std::int64_t SurfaceEvidence::key(const Vector3& x, int di, int dj, int dk) const {
  const Vector3 cell = (x / cell_m_).array().floor();
  return packCell(static_cast<std::int64_t>(cell.x()) + di, static_cast<std::int64_t>(cell.y()) + dj,
                  static_cast<std::int64_t>(cell.z()) + dk);
}

double SurfaceEvidence::distance(const Vector3& x) const {
  const double infinity = std::numeric_limits<double>::infinity();
  if (!enabled() || !x.allFinite()) return infinity;
  double best_squared = max_distance_m_ * max_distance_m_;
  bool found = false;
  forEachCandidate(x, [&](std::uint32_t index) {
    const double squared = (points_[index] - x).squaredNorm();
    if (squared <= best_squared) {
      best_squared = squared;
      found = true;
    }
    return true;
  });
  return found ? std::sqrt(best_squared) : infinity;
}

double SurfaceEvidence::supportSlack(const Vector3& x) const {
  double best = -std::numeric_limits<double>::infinity();
  if (!enabled() || !x.allFinite()) return best;
  // Every support radius is at most max_distance_m_ = cell_m_: the 27 cells hold every point
  // whose support can reach x.
  forEachCandidate(x, [&](std::uint32_t index) {
    best = std::max(best, support_radius_m_[index] - (points_[index] - x).norm());
    return true;
  });
  return best;
}

double SurfaceEvidence::radiusCap(const Vector3& x, double floor_m) const {
  if (!enabled()) return std::numeric_limits<double>::infinity();
  return std::max(floor_m, std::max(0.0, supportSlack(x)));
}

}  // namespace gpatlas_core
