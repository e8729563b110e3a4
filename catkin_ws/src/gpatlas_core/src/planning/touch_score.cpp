#include "gpatlas_core/planning/touch_score.h"

#include "gpatlas_core/model/position_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>

namespace gpatlas_core {

std::string validate(const TouchScoreConfig& config) {
  std::ostringstream problem;
  if (config.max_reference_points < 1) problem << "max_reference_points must be at least 1; ";
  if (config.max_candidates < 1) problem << "max_candidates must be at least 1; ";
  if (config.max_excess_candidates < 0 || config.max_excess_candidates > config.max_candidates)
    problem << "max_excess_candidates must be in [0, max_candidates]; ";
  return problem.str();
}

double surfaceError(const SurfaceModel& model, const StopRule& rule, double reported_variance, double gradient_norm) {
  if (rule.max_position_sd_m) {
    const double sd = positionSd(model, reported_variance, gradient_norm);
    if (!(sd > *rule.max_position_sd_m)) return 0.0;
    // 2 Phi(-b / sd) = erfc(b / (sqrt(2) sd)); at sd = b it is erfc(1 / sqrt(2)).
    return std::erfc(*rule.max_position_sd_m / (std::sqrt(2.0) * sd)) - std::erfc(1.0 / std::sqrt(2.0));
  }
  return std::max(0.0, (reported_variance - rule.v_max) / rule.v_max);
}

std::vector<Vector3> approachFreeSpace(const TouchCandidate& candidate, double spacing_m) {
  std::vector<Vector3> points;
  const double norm = candidate.normal.norm();
  if (!(candidate.approach_m > 0.0) || !(spacing_m > 0.0) || !(norm > 0.0) || !std::isfinite(candidate.approach_m))
    return points;
  const Vector3 n = candidate.normal / norm;
  const auto count = static_cast<int>(std::floor(candidate.approach_m / spacing_m + 1e-9));
  for (int k = 1; k <= count; ++k) points.push_back(candidate.point + (k * spacing_m) * n);
  return points;
}

TouchScores scoreTouches(const SurfaceModel& model, const StopRule& rule, const std::vector<SurfacePatch>& patches,
                         const std::vector<TouchCandidate>& candidates, const TouchObservationConfig& touch,
                         const TouchScoreConfig& config, std::uint64_t seed) {
  TouchScores scores;
  if (!model.isFitted()) {
    scores.message = "no model: the GP is not fitted";
    return scores;
  }
  if (const std::string problem = validate(config) + validate(rule); !problem.empty()) {
    scores.message = problem;
    return scores;
  }
  // The references: every patch that carries error, or a random sample of them.
  std::vector<std::size_t> carrying;
  std::vector<double> error(patches.size(), 0.0);
  for (std::size_t i = 0; i < patches.size(); ++i) {
    error[i] = surfaceError(model, rule, patches[i].variance, patches[i].slope);
    scores.total_error += patches[i].area_m2 * error[i];
    if (error[i] > 0.0 && patches[i].area_m2 > 0.0) carrying.push_back(i);
  }
  scores.reduction.assign(candidates.size(), 0.0);
  if (carrying.empty() || candidates.empty()) {
    scores.ok = true;
    scores.message = carrying.empty() ? "no surface carries error past the bound" : "no candidate";
    return scores;
  }
  double weight = 1.0;
  const std::size_t cap = static_cast<std::size_t>(config.max_reference_points);
  if (carrying.size() > cap) {
    std::mt19937_64 rng(seed);
    std::shuffle(carrying.begin(), carrying.end(), rng);
    weight = static_cast<double>(carrying.size()) / static_cast<double>(cap);
    carrying.resize(cap);
  }
  Points3 references(3, static_cast<Eigen::Index>(carrying.size()));
  for (std::size_t r = 0; r < carrying.size(); ++r) references.col(static_cast<Eigen::Index>(r)) = patches[carrying[r]].point;

  std::vector<std::vector<TrainingPoint>> fantasies;
  fantasies.reserve(candidates.size());
  // The probe samples its way in more densely than the loop keeps (min_free_space_spacing_m):
  // sampled at that spacing, the fantasy holds about the points the loop's thinning would keep.
  constexpr double kProbeSpacing = 0.01;
  const double spacing = touch.min_free_space_spacing_m > 0.0 ? touch.min_free_space_spacing_m : kProbeSpacing;
  for (const TouchCandidate& candidate : candidates)
    fantasies.push_back(touchTrainingPoints(model, {Contact{candidate.point, candidate.normal}},
                                            approachFreeSpace(candidate, spacing), touch));
  const Eigen::MatrixXd after = model.varianceAfter(references, fantasies);
  for (std::size_t c = 0; c < candidates.size(); ++c) {
    double fall = 0.0;
    for (std::size_t r = 0; r < carrying.size(); ++r) {
      const SurfacePatch& patch = patches[carrying[r]];
      const double later = surfaceError(model, rule, after(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)), patch.slope);
      fall += weight * patch.area_m2 * (error[carrying[r]] - later);
    }
    scores.reduction[c] = fall;
  }
  scores.ok = true;
  return scores;
}

}  // namespace gpatlas_core
