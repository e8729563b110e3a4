#include "gpatlas_core/observations/touch_training.h"

#include "gpatlas_core/model/position_uncertainty.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>
#include <sstream>

namespace gpatlas_core {
namespace {

// `thin(spacing)` at `spacing`; when that keeps more than `cap` points (a dense sensor, a long
// slide), again at 1.5 times the spacing until it fits, so that one touch cannot make the model
// arbitrarily large. `before` and `capped_spacing` say so (0 when the cap did not bind).
template <typename Thin>
std::vector<Vector3> thinToCap(Thin thin, double spacing, std::optional<std::size_t> cap, std::size_t* before,
                               double* capped_spacing) {
  std::vector<Vector3> kept = thin(spacing);
  if (!cap || kept.size() <= *cap) return kept;
  *before = kept.size();
  if (!(spacing > 0.0)) spacing = 0.001;
  while (kept.size() > *cap) {
    spacing *= 1.5;
    kept = thin(spacing);
  }
  *capped_spacing = spacing;
  return kept;
}

}  // namespace

std::vector<Vector3> thinToSpacing(const std::vector<Vector3>& points, double spacing_m) {
  const double spacing2 = spacing_m > 0.0 ? spacing_m * spacing_m : 0.0;
  std::vector<Vector3> kept;
  for (const Vector3& p : points) {
    if (!p.allFinite()) continue;
    bool crowded = false;
    for (const Vector3& q : kept)
      if ((q - p).squaredNorm() < spacing2) {
        crowded = true;
        break;
      }
    if (!crowded) kept.push_back(p);
  }
  return kept;
}

std::vector<Vector3> thinFreeSpace(const std::vector<Vector3>& free_space, const std::vector<Vector3>& contacts,
                                   double spacing_m) {
  if (contacts.empty()) return thinToSpacing(free_space, spacing_m);
  std::vector<std::pair<double, std::size_t>> order;
  order.reserve(free_space.size());
  for (std::size_t i = 0; i < free_space.size(); ++i) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const Vector3& c : contacts) nearest = std::min(nearest, (c - free_space[i]).squaredNorm());
    order.emplace_back(nearest, i);
  }
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Vector3> sorted;
  sorted.reserve(free_space.size());
  for (const auto& entry : order) sorted.push_back(free_space[entry.second]);
  return thinToSpacing(sorted, spacing_m);
}

std::vector<TrainingPoint> touchTrainingPoints(const SurfaceModel& model, const std::vector<Contact>& contacts,
                                               const std::vector<Vector3>& free_space, const TouchObservationConfig& config,
                                               TouchPointCounts* counts) {
  std::vector<Vector3> positions;
  positions.reserve(contacts.size());
  for (const Contact& contact : contacts) positions.push_back(contact.position);
  TouchPointCounts counted;
  std::vector<Vector3> kept_contacts =
      thinToCap([&](double spacing) { return thinToSpacing(positions, spacing); }, config.min_point_spacing_m,
                config.max_contacts_per_touch, &counted.contacts_before_cap, &counted.capped_contact_spacing_m);
  std::vector<TrainingPoint> points;
  for (const Vector3& contact : kept_contacts) {
    TrainingPoint point;
    point.position = contact;
    point.label = PointLabel::kSurface;
    point.noise_sigma = config.contact_noise_sigma;
    point.source = PointSource::kTouch;
    points.push_back(point);
  }
  counted.contacts = points.size();
  // How far each contact lay from the surface the model predicted (first order: |f| / |grad f|).
  if (model.isFitted() && !points.empty()) {
    Points3 x(3, static_cast<Eigen::Index>(points.size()));
    for (std::size_t i = 0; i < points.size(); ++i) x.col(static_cast<Eigen::Index>(i)) = points[i].position;
    const BatchPrediction predicted = model.predictBatch(x, /*with_gradient=*/true, false, /*with_variance=*/false);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Index k = static_cast<Eigen::Index>(i);
      const double slope = predicted.gradient.col(k).norm();
      if (predicted.in_domain[k] && std::isfinite(predicted.mean[k]) && slope > 1e-9)
        points[i].prediction_error_m = std::abs(predicted.mean[k]) / slope;
    }
  }
  const bool tangents = config.contact_tangent_noise_sigma.has_value();
  std::vector<TrainingPoint> slope_points;  // after the inside points, as TouchPointCounts says
  if (config.contact_inside_depth_m > 0.0 || tangents) {
    // thinToSpacing keeps the first of near-duplicates in order, so the kept contacts are a
    // subsequence of `contacts`: walk both to find each kept contact's normal.
    std::size_t next = 0;
    for (const Vector3& kept : kept_contacts) {
      while (next < contacts.size() && contacts[next].position != kept) ++next;
      if (next == contacts.size()) break;
      const Vector3& normal = contacts[next].normal;
      if (!normal.allFinite() || normal.norm() < 0.5) continue;
      if (config.contact_inside_depth_m > 0.0) {
        TrainingPoint point;
        point.position = kept - config.contact_inside_depth_m * normal.normalized();
        point.label = PointLabel::kInside;
        point.noise_sigma = config.contact_inside_noise_sigma;
        point.source = PointSource::kTouch;
        point.surface_distance_m = config.contact_inside_depth_m;
        if (model.inDomain(point.position)) points.push_back(point);
      }
      if (tangents) {
        // f does not change across the measured normal: two slopes, target 0, that fix the
        // normal's direction whatever f's slope along it.
        const Vector3 unit_normal = normal.normalized();
        const Vector3 across = unit_normal.unitOrthogonal();
        for (const Vector3& tangent : {across, Vector3(unit_normal.cross(across))}) {
          TrainingPoint point;
          point.position = kept;
          point.label = PointLabel::kSurface;
          point.noise_sigma = *config.contact_tangent_noise_sigma;
          point.source = PointSource::kTouch;
          point.slope_direction = tangent;
          point.target_override = 0.0;
          slope_points.push_back(point);
        }
      }
    }
  }
  counted.contact_inside = points.size() - counted.contacts;
  points.insert(points.end(), slope_points.begin(), slope_points.end());
  counted.contact_tangents = slope_points.size();
  // Outside the domain the model has its own outside pseudo-points and would reject them:
  // filtered before the thinning, so that they cannot crowd out points the model keeps.
  std::vector<Vector3> free_in_domain;
  for (const Vector3& free : free_space)
    if (free.allFinite() && model.inDomain(free)) free_in_domain.push_back(free);
  const std::vector<Vector3> kept_free =
      thinToCap([&](double spacing) { return thinFreeSpace(free_in_domain, kept_contacts, spacing); },
                config.min_free_space_spacing_m, config.max_free_space_per_touch, &counted.free_space_before_cap,
                &counted.capped_free_space_spacing_m);
  for (const Vector3& free : kept_free) {
    TrainingPoint point;
    point.position = free;
    point.label = PointLabel::kOutside;
    point.noise_sigma = config.free_space_noise_sigma;
    point.source = PointSource::kFreeSpace;
    point.surface_distance_m = model.nearestSurfaceDistance(free, kept_contacts);
    points.push_back(point);
  }
  counted.free_space = points.size() - counted.contacts - counted.contact_inside - counted.contact_tangents;
  if (counts) *counts = counted;
  return points;
}

std::vector<Vector3> measuredPositions(const std::vector<Contact>& contacts, const std::vector<Vector3>& free_space) {
  std::vector<Vector3> positions = free_space;
  for (const Contact& contact : contacts) positions.push_back(contact.position);
  return positions;
}

FitReport addTouchPoints(SurfaceModel& model, const std::vector<TrainingPoint>& new_points,
                         const std::vector<Vector3>& evidence, const TouchObservationConfig& config,
                         InteriorRetraction* retraction) {
  if (retraction) *retraction = InteriorRetraction();
  if (!model.isFitted()) return model.addPoints(new_points);
  std::vector<TrainingPoint> observations = model.observations();
  const InteriorRetraction retracted =
      retractContradictedInterior(&observations, evidence, config.guess_min_depth_fraction * model.scale());
  if (!retracted.any()) return model.addPoints(new_points);
  observations.insert(observations.end(), new_points.begin(), new_points.end());
  FitReport report = model.fitInFrame(observations, model.centroid(), model.scale());
  if (report.ok) {
    // Screening only removes points and keeps the order, so the accepted new points are among
    // the last new_points.size() observations (a renormalised refit can also drop old ones).
    const std::vector<TrainingPoint>& kept = model.observations();
    std::size_t accepted = 0;
    for (std::size_t i = kept.size() > new_points.size() ? kept.size() - new_points.size() : 0; i < kept.size(); ++i)
      for (const TrainingPoint& p : new_points)
        if (p.position == kept[i].position && p.label == kept[i].label && sameSlopeDirection(p, kept[i])) {
          ++accepted;
          break;
        }
    report.num_added = accepted;
    if (retraction) *retraction = retracted;
  }
  return report;
}

namespace {

// What the model took of `new_points` (touchTrainingPoints' order: the contacts first). The
// model reports acceptance as a total; free-space points are the ones it drops (duplicates, out
// of domain), so rejections are attributed to them first.
void countAccepted(const FitReport& report, const TouchPointCounts& counts, const std::vector<TrainingPoint>& new_points,
                   TouchUpdate& update) {
  const int accepted = static_cast<int>(report.num_added);
  const std::size_t num_contact_points = counts.contacts + counts.contact_inside + counts.contact_tangents;
  update.points_added = accepted;
  update.contacts_added = std::min(accepted, static_cast<int>(counts.contacts));
  for (int i = 0; i < update.contacts_added; ++i)
    update.contact_positions.push_back(new_points[static_cast<std::size_t>(i)].position);
  update.free_points_added = std::max(0, accepted - static_cast<int>(num_contact_points));
}

// The touch as tests of the model before it, for its calibration (addTouchCalibration): each
// contact's |f| / sd(f) (heldOutRatios), and each free-space point the model put inside the
// object. The probe passed there, so the true surface lies beyond it and the model's error is at
// least its |f|: a lower bound, so a probe that passes through a predicted surface and finds
// nothing counts, not only one that finds the surface elsewhere.
std::vector<double> touchTests(const SurfaceModel& model, const std::vector<TrainingPoint>& points,
                               const std::vector<Vector3>& free_space) {
  std::vector<Vector3> contacts;
  for (const TrainingPoint& point : points)
    if (point.source == PointSource::kTouch && isSurfaceValue(point)) contacts.push_back(point.position);
  Points3 x(3, static_cast<Eigen::Index>(contacts.size()));
  for (std::size_t i = 0; i < contacts.size(); ++i) x.col(static_cast<Eigen::Index>(i)) = contacts[i];
  std::vector<double> tests = heldOutRatios(model, x);
  if (free_space.empty()) return tests;
  Points3 free(3, static_cast<Eigen::Index>(free_space.size()));
  for (std::size_t i = 0; i < free_space.size(); ++i) free.col(static_cast<Eigen::Index>(i)) = free_space[i];
  const BatchPrediction predicted = model.predictBatch(free, false, false, true);
  for (Eigen::Index i = 0; i < free.cols(); ++i) {
    const double sd_f = std::sqrt(std::max(predicted.variance[i], 0.0) / model.varianceUnitFactor());
    if (predicted.in_domain[i] && predicted.mean[i] < 0.0 && sd_f > 0.0) tests.push_back(-predicted.mean[i] / sd_f);
  }
  return tests;
}

}  // namespace

TouchUpdate applyTouch(SurfaceModel& model, const std::vector<Contact>& contacts, const std::vector<Vector3>& free_space,
                       const TouchObservationConfig& config) {
  TouchUpdate update;
  if (!model.isFitted()) {
    update.message = "no model yet: the GP is not fitted";
    return update;
  }
  const GatedObservations gated = gateObservations(model, contacts, free_space, config.gate);
  update.contacts_refused = gated.contacts_refused;
  update.free_space_refused = gated.free_space_refused;
  if (gated.contacts.empty() && gated.free_space.empty()) {
    update.message = gated.refused() > 0 ? "nothing added: " + gated.message : "no observation";
    return update;
  }
  if (!gated.message.empty()) update.warnings.push_back(gated.message);
  TouchPointCounts counts;
  std::vector<TrainingPoint> new_points = touchTrainingPoints(model, gated.contacts, gated.free_space, config, &counts);
  if (new_points.empty()) {
    update.message = "no observation inside the model's domain";
    return update;
  }
  if (config.max_touch_observations) {
    std::size_t held = 0;
    for (const TrainingPoint& p : model.observations()) held += fromView(p.source) ? 0 : 1;
    const std::size_t room = held < *config.max_touch_observations ? *config.max_touch_observations - held : 0;
    const std::size_t wanted = new_points.size();
    if (wanted > room) {
      // The free space goes first (the contacts pin the surface down): what fits of it is kept,
      // nearest the contacts first (it comes last, in that order). Then the contacts are thinned
      // coarser until they fit.
      const std::size_t contact_points = counts.contacts + counts.contact_inside + counts.contact_tangents;
      bool contacts_thinned = false;
      if (contact_points <= room) {
        new_points.resize(room);
        counts.free_space = room - contact_points;
      } else {
        TouchObservationConfig thinned = config;
        std::size_t contacts_cap = counts.contacts;
        new_points.resize(contact_points);
        counts.free_space = 0;
        while (!new_points.empty() && new_points.size() > room) {
          contacts_thinned = true;
          contacts_cap = contacts_cap * 2 / 3;
          if (contacts_cap == 0) {
            new_points.clear();
            break;
          }
          thinned.max_contacts_per_touch = contacts_cap;
          new_points = touchTrainingPoints(model, gated.contacts, {}, thinned, &counts);
        }
      }
      std::ostringstream note;
      note << "the model holds " << held << " observations from touches (touch/max_touch_observations "
           << *config.max_touch_observations << ")";
      if (new_points.empty()) {
        update.budget_full = true;
        update.message = "observation budget full: " + note.str() +
                         "; remove_observations or reset make room, or raise the budget";
        return update;
      }
      note << ": the touch's " << wanted << " training points were thinned to " << new_points.size()
           << (contacts_thinned ? " (its free space dropped, its contacts thinned)" : " (its free space thinned)");
      update.warnings.push_back(note.str());
      // This note replaces the per-touch caps' own.
      counts.contacts_before_cap = 0;
      counts.free_space_before_cap = 0;
    }
  }
  const auto capped = [&](std::size_t before, std::size_t after, double spacing, std::optional<std::size_t> cap,
                          const char* what, const char* key) {
    if (before == 0 || !cap) return;
    std::ostringstream note;
    note << "the touch's " << before << " " << what << " (after thinning) were thinned to " << after << " at "
         << 1000.0 * spacing << " mm spacing (touch/" << key << " " << *cap << ")";
    update.warnings.push_back(note.str());
  };
  capped(counts.contacts_before_cap, counts.contacts, counts.capped_contact_spacing_m, config.max_contacts_per_touch,
         "contacts", "max_contacts_per_touch");
  capped(counts.free_space_before_cap, counts.free_space, counts.capped_free_space_spacing_m,
         config.max_free_space_per_touch, "free-space points", "max_free_space_per_touch");
  update.contacts_capped_from = counts.contacts_before_cap;
  const std::size_t num_contact_points = counts.contacts + counts.contact_inside + counts.contact_tangents;
  const std::vector<Vector3> measured = measuredPositions(gated.contacts, gated.free_space);
  const PositionSdEvidence& evidence = model.positionSdEvidence();
  const std::vector<double> calibration_tests = !evidence.view_folds.empty() && evidence.use_touches
                                                    ? touchTests(model, new_points, gated.free_space)
                                                    : std::vector<double>();
  FitReport report = addTouchPoints(model, new_points, measured, config, &update.retraction);
  if (!report.ok && counts.contacts > 0 && num_contact_points < new_points.size()) {
    new_points.resize(num_contact_points);
    report = addTouchPoints(model, new_points, measured, config, &update.retraction);
  }
  update.ok = report.ok;
  update.message = report.message;
  update.warnings.insert(update.warnings.end(), report.warnings.begin(), report.warnings.end());
  if (!report.ok) return update;
  countAccepted(report, counts, new_points, update);
  addTouchCalibration(model, calibration_tests);
  return update;
}

std::string validate(const TouchObservationConfig& config) {
  std::ostringstream problem;
  const auto nonNegative = [&](double value, const char* name) {
    if (!(value >= 0.0) || !std::isfinite(value)) problem << name << " must be finite and >= 0; ";
  };
  nonNegative(config.contact_noise_sigma, "contact_noise_sigma");
  nonNegative(config.free_space_noise_sigma, "free_space_noise_sigma");
  nonNegative(config.min_point_spacing_m, "min_point_spacing_m");
  nonNegative(config.min_free_space_spacing_m, "min_free_space_spacing_m");
  nonNegative(config.contact_inside_depth_m, "contact_inside_depth_m");
  nonNegative(config.contact_inside_noise_sigma, "contact_inside_noise_sigma");
  nonNegative(config.guess_min_depth_fraction, "guess_min_depth_fraction");
  if (config.contact_tangent_noise_sigma &&
      (!(*config.contact_tangent_noise_sigma > 0.0) || !std::isfinite(*config.contact_tangent_noise_sigma)))
    problem << "contact_tangent_noise_sigma must be finite and > 0, or empty (no tangent slopes); ";
  for (const auto& [cap, name] : {std::pair{config.max_contacts_per_touch, "max_contacts_per_touch"},
                                  std::pair{config.max_free_space_per_touch, "max_free_space_per_touch"},
                                  std::pair{config.max_touch_observations, "max_touch_observations"}})
    if (cap == std::optional<std::size_t>(0)) problem << name << " must be > 0, or empty (no cap); ";
  const std::string gate = validate(config.gate);
  if (!gate.empty()) problem << "gate: " << gate;
  return problem.str();
}

}  // namespace gpatlas_core
