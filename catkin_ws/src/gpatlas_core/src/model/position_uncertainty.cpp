#include "gpatlas_core/model/position_uncertainty.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <utility>

namespace gpatlas_core {
namespace {

// The held-out points' subsets are the same at every calibration, so that the scale changes
// with the model and its touches, not with the draw.
constexpr std::uint64_t kHeldOutSubsetSeed = 3;

}  // namespace

double positionSd(const SurfaceModel& model, double reported_variance, double gradient_norm) {
  const double cap = model.domainRadiusWorld();
  if (!std::isfinite(reported_variance)) return cap;
  const double sd_f = model.positionSdScale() * std::sqrt(std::max(reported_variance, 0.0) / model.varianceUnitFactor());
  if (!(gradient_norm > 0.0) || !std::isfinite(gradient_norm)) return cap;
  return std::min(sd_f / gradient_norm, cap);
}

Eigen::VectorXd positionSd(const SurfaceModel& model, const Points3& x_world) {
  Eigen::VectorXd sd(x_world.cols());
  if (x_world.cols() == 0) return sd;
  const BatchPrediction prediction = model.predictBatch(x_world, true, false, true);
  for (Eigen::Index k = 0; k < x_world.cols(); ++k) sd[k] = positionSd(model, prediction, k);
  return sd;
}

double positionSd(const SurfaceModel& model, const BatchPrediction& prediction, Eigen::Index k) {
  return prediction.in_domain[k] ? positionSd(model, prediction.variance[k], prediction.gradient.col(k).norm())
                                 : model.domainRadiusWorld();
}

std::string validate(const PositionCalibrationConfig& config) {
  std::ostringstream problem;
  if (config.folds < 0 || config.folds > 6) problem << "folds must be in [0, 6] (the six cuts); ";
  if (!(config.cut_fraction > 0.0) || !(config.cut_fraction < 1.0)) problem << "cut_fraction must be in (0, 1); ";
  if (config.max_test_points_per_fold < 1) problem << "max_test_points_per_fold must be >= 1; ";
  if (!(config.coverage > 0.0) || !(config.coverage < 1.0)) problem << "coverage must be in (0, 1); ";
  if (!(config.min_scale > 0.0) || !(config.max_scale >= config.min_scale) || !std::isfinite(config.max_scale))
    problem << "need 0 < min_scale <= max_scale < inf; ";
  return problem.str();
}

namespace {

// The directions of the folds' cuts: both ways along each principal axis of the surface data.
std::vector<Vector3> cutDirections(const std::vector<Vector3>& surface, int count) {
  Vector3 mean = Vector3::Zero();
  for (const Vector3& p : surface) mean += p;
  mean /= static_cast<double>(surface.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Vector3& p : surface) scatter += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> axes(scatter);
  std::vector<Vector3> directions;
  for (int k = 0; k < count; ++k) {
    const Vector3 axis = axes.eigenvectors().col(2 - (k / 2) % 3);
    directions.push_back(k % 2 == 0 ? axis : Vector3(-axis));
  }
  return directions;
}

// |mean| / sd(f) at the held-out surface points of one fold: the position error over the
// unscaled position sd (both are divided by |grad f|). The fold holds out every observation
// beyond a plane across `direction` that cuts off `cut_fraction` of the surface data: a side the
// camera did not see, next to the part it did. Empty when the refit fails.
std::vector<double> foldRatios(const SurfaceModel& model, const std::vector<Vector3>& surface, const Vector3& direction,
                               const PositionCalibrationConfig& config, std::mt19937_64& rng) {
  std::vector<double> sorted;
  for (const Vector3& p : surface) sorted.push_back(p.dot(direction));
  const std::size_t k = static_cast<std::size_t>((1.0 - config.cut_fraction) * static_cast<double>(sorted.size() - 1));
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(k), sorted.end());
  const double cut = sorted[k];
  std::vector<TrainingPoint> kept;
  std::vector<Vector3> held_out;
  for (const TrainingPoint& point : model.observations()) {
    if (point.position.dot(direction) <= cut) kept.push_back(point);
    else if (isSurfaceValue(point)) held_out.push_back(point.position);
  }
  if (held_out.empty()) return {};
  std::shuffle(held_out.begin(), held_out.end(), rng);
  held_out.resize(std::min(held_out.size(), static_cast<std::size_t>(config.max_test_points_per_fold)));
  std::unique_ptr<SurfaceModel> trial = model.clone();
  if (!trial->fitInFrame(kept, model.centroid(), model.scale()).ok) return {};
  Points3 queries(3, static_cast<Eigen::Index>(held_out.size()));
  for (std::size_t i = 0; i < held_out.size(); ++i) queries.col(static_cast<Eigen::Index>(i)) = held_out[i];
  return heldOutRatios(*trial, queries);
}

// The value below which `coverage` of the weight lies, each group weighing 1 in total (for equal
// weights, quantile()'s element).
double weightedQuantile(const std::vector<const std::vector<double>*>& groups, double coverage) {
  std::vector<std::pair<double, double>> weighted;
  for (const std::vector<double>* group : groups)
    for (const double ratio : *group) weighted.emplace_back(ratio, 1.0 / static_cast<double>(group->size()));
  if (weighted.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(weighted.begin(), weighted.end());
  // Plus a little: a sum of 1/n weights that reaches the target only by rounding must not pass it.
  const double target = coverage * static_cast<double>(groups.size()) + 1e-9;
  double cumulative = 0.0;
  for (const auto& [ratio, weight] : weighted) {
    cumulative += weight;
    if (cumulative > target) return ratio;
  }
  return weighted.back().first;
}

}  // namespace

std::vector<double> heldOutRatios(const SurfaceModel& model, const Points3& surface_points_world) {
  std::vector<double> ratios;
  if (!model.isFitted() || surface_points_world.cols() == 0) return ratios;
  const BatchPrediction prediction = model.predictBatch(surface_points_world, false, false, true);
  for (Eigen::Index i = 0; i < surface_points_world.cols(); ++i) {
    const double sd_f = std::sqrt(std::max(prediction.variance[i], 0.0) / model.varianceUnitFactor());
    if (prediction.in_domain[i] && sd_f > 0.0 && std::isfinite(prediction.mean[i]))
      ratios.push_back(std::abs(prediction.mean[i]) / sd_f);
  }
  return ratios;
}

double positionSdScale(const PositionSdEvidence& evidence) {
  if (evidence.view_folds.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::vector<const std::vector<double>*> groups;
  for (const auto* set : {&evidence.view_folds, &evidence.touches})
    for (const std::vector<double>& group : *set)
      if (!group.empty()) groups.push_back(&group);
  return std::clamp(weightedQuantile(groups, evidence.coverage) / 2.0, evidence.min_scale, evidence.max_scale);
}

bool addTouchCalibration(SurfaceModel& model, const std::vector<double>& ratios) {
  if (ratios.empty() || model.positionSdEvidence().view_folds.empty() || !model.positionSdEvidence().use_touches)
    return false;
  PositionSdEvidence evidence = model.positionSdEvidence();
  evidence.touches.push_back(ratios);
  if (!model.setPositionSdScale(positionSdScale(evidence))) return false;
  model.setPositionSdEvidence(std::move(evidence));
  return true;
}

PositionCalibration calibratePositionSd(SurfaceModel& model, const PositionCalibrationConfig& config) {
  const auto started = std::chrono::steady_clock::now();
  PositionCalibration result;
  result.scale = model.positionSdScale();
  if (const std::string problem = validate(config); !problem.empty()) {
    result.message = "invalid position calibration config: " + problem;
    return result;
  }
  if (!model.isFitted()) {
    result.message = "no model to calibrate";
    return result;
  }
  if (config.folds == 0) {
    result.message = "calibration off (folds 0): position sd scale kept at " + std::to_string(result.scale);
    return result;
  }
  std::vector<Vector3> surface;
  for (const TrainingPoint& point : model.observations())
    if (isSurfaceValue(point)) surface.push_back(point.position);
  if (surface.size() < 8) {
    result.message = "too few surface observations to cross-validate";
    return result;
  }
  std::mt19937_64 rng(kHeldOutSubsetSeed);
  PositionSdEvidence evidence;
  evidence.use_touches = config.touches;
  evidence.coverage = config.coverage;
  evidence.min_scale = config.min_scale;
  evidence.max_scale = config.max_scale;
  // The touches' tests stay: they tested the same kind of model where it was used.
  if (config.touches) evidence.touches = model.positionSdEvidence().touches;
  std::vector<double> ratios;
  for (const Vector3& direction : cutDirections(surface, config.folds)) {
    std::vector<double> fold = foldRatios(model, surface, direction, config, rng);
    if (fold.empty()) continue;
    ++result.folds_used;
    ratios.insert(ratios.end(), fold.begin(), fold.end());
    evidence.view_folds.push_back(std::move(fold));
  }
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  result.test_points = ratios.size();
  if (ratios.empty()) {
    result.message = "no fold could be refitted and predicted: position sd scale kept";
    return result;
  }
  result.median_ratio = quantile(ratios, 0.5);
  result.scale = positionSdScale(evidence);
  model.setPositionSdScale(result.scale);
  model.setPositionSdEvidence(std::move(evidence));
  result.ok = true;
  std::ostringstream message;
  message << "position sd scale " << result.scale << " from " << result.test_points << " held-out surface points in "
          << result.folds_used << " cut-off sides of " << config.cut_fraction << " of the data (median |error| / sd "
          << result.median_ratio << ")";
  if (!model.positionSdEvidence().touches.empty())
    message << " and " << model.positionSdEvidence().touches.size() << " touches";
  message << " in " << result.seconds << " s";
  result.message = message.str();
  return result;
}

}  // namespace gpatlas_core
