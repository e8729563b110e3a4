#pragma once

// Where is the surface, in metres? The standard deviation of the predicted surface's position
// along its normal, from any SurfaceModel, and its calibration on the model's own data. The
// loop's stop rule in those units is planning/stop_rule.h.

#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/common/types.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_core {

// The surface near x lies where f crosses 0; to first order a change df of f moves it by
// df / |grad f| along the normal, so its position sd is positionSdScale() * sd(f) / |grad f|
// (sd(f) = sqrt(variance / varianceUnitFactor())). Where the gradient vanishes (no surface is
// predicted near, or two sides meet) that is unbounded; the surface is still somewhere in the
// model's domain, so the value is capped at domainRadiusWorld(): large, finite, honest.
double positionSd(const SurfaceModel& model, double reported_variance, double gradient_norm);
// Batched over points (world frame); one predictBatch with gradients, no variance gradient.
Eigen::VectorXd positionSd(const SurfaceModel& model, const Points3& x_world);
// Column k of a prediction made with variance and gradient: the cap outside the domain.
double positionSd(const SurfaceModel& model, const BatchPrediction& prediction, Eigen::Index k);

// The common scale of the prior's and the noise's variance (SurfaceModel::positionSdScale),
// fitted by spatial cross-validation on the model's own surface data: scaling both variances by
// s^2 leaves the posterior mean unchanged and multiplies the posterior sd by s, so s is set from
// how far the mean misses held-out data in units of the sd. Each fold cuts off one side of the
// data (every observation beyond a plane), refits a clone in the model's frame, and predicts the
// held-out surface points: an extrapolation into a side the data do not show, as the unseen
// back of an object is one.
struct PositionCalibrationConfig {
  // Cuts, both ways along the principal axes of the surface data in turn: at most 6 (0: no
  // calibration).
  int folds{6};
  // The share of the surface data a cut holds out.
  double cut_fraction{0.25};
  // Held-out surface points predicted per fold (a random subset beyond).
  int max_test_points_per_fold{200};
  // The share of held-out points whose error should lie within 2 sd: s is this quantile of
  // |error| / (2 sd).
  double coverage{0.95};
  // Each touch tests the model before it and the scale is refitted with the folds
  // (addTouchCalibration); false: the view's folds alone.
  bool touches{true};
  // Bounds on s.
  double min_scale{0.01};
  double max_scale{10.0};
};

std::string validate(const PositionCalibrationConfig& config);

struct PositionCalibration {
  bool ok{false};
  std::string message;
  double scale{1.0};          // the fitted s (the model's is set to it when ok)
  int folds_used{0};          // folds whose refit succeeded
  std::size_t test_points{0};
  double median_ratio{0.0};   // median |error| / sd before scaling
  double seconds{0.0};
};

// Fits s on `model` (fitted) and sets it, with the touches the model's evidence holds; on failure
// the model keeps its scale and evidence.
PositionCalibration calibratePositionSd(SurfaceModel& model, const PositionCalibrationConfig& config);

// Calibration by the touches. Each contact tests the model as it was before the touch: |f| /
// sd(f) there, as the folds test it on a cut-off side. The scale is the weighted `coverage`
// quantile of all the tests over 2, each fold and each touch weighing 1 whatever its number of
// points: the touches, where the model is used, take over from the view's folds as they arrive,
// and a slide's hundred contacts count as one touch. Contacts outside the domain or with no
// variance are not tests.
std::vector<double> heldOutRatios(const SurfaceModel& model, const Points3& surface_points_world);
// The scale the evidence gives (NaN without view folds).
double positionSdScale(const PositionSdEvidence& evidence);
// Adds one touch's tests and sets the model's scale from its evidence. False, and nothing
// changed, when the model has no view folds (calibration off), its calibration does not take
// touches (PositionCalibrationConfig::touches), or `ratios` is empty.
bool addTouchCalibration(SurfaceModel& model, const std::vector<double>& ratios);

}  // namespace gpatlas_core
