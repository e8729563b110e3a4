#pragma once

#include "gpatlas_core/common/types.h"

#include <Eigen/Core>

#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace gpatlas_core {

// Outcome of a fit or an update. On failure the model keeps its previous state.
struct FitReport {
  bool ok{false};
  std::string message;
  std::vector<std::string> warnings;  // something the user should look at
  std::vector<std::string> notes;     // routine information (e.g. what tuning found): for debug logs
  bool full_refit{false};      // false when the model was extended incrementally
  bool renormalised{false};    // the centroid/scale changed, every point was re-normalised
  double jitter{0.0};          // diagonal jitter that made a matrix factorisable
  std::size_t num_added{0};    // points accepted from the call
  std::size_t num_rejected{0}; // NaN/Inf, duplicates, out of domain
};

// Posterior at one point. Units: mean is the (unitless) implicit function value; gradients
// are per metre of world coordinates; variance is in the model's reported units (those of the
// paper's reference GPIS, see GpisModelConfig), so that one V_max means the same for every model.
struct Prediction {
  double mean{0.0};
  double variance{0.0};
  Vector3 gradient{Vector3::Zero()};
  Vector3 variance_gradient{Vector3::Zero()};
  bool in_domain{true};
};

struct BatchPrediction {
  BatchPrediction() = default;
  // Room for `queries` answers, the gradients' only where they will be filled.
  BatchPrediction(Eigen::Index queries, bool with_gradient, bool with_variance_gradient)
      : mean(queries), variance(queries), in_domain(queries) {
    if (with_gradient) gradient.resize(3, queries);
    if (with_variance_gradient) variance_gradient.resize(3, queries);
  }
  Eigen::VectorXd mean;
  Eigen::VectorXd variance;
  Points3 gradient;           // filled when requested
  Points3 variance_gradient;  // filled when requested
  Eigen::Array<bool, Eigen::Dynamic, 1> in_domain;
};

struct TuneReport {
  bool ok{false};
  std::string message;
  double log_likelihood_before{0.0};
  double log_likelihood_after{0.0};
  Eigen::VectorXd params_before;  // in natural units, in the order of hyperparameterNames()
  Eigen::VectorXd params_after;
  int iterations{0};
  double seconds{0.0};
};

// What every query of a model is relative to (SurfaceModel::frame()): its normalisation frame,
// x_normalised = (x_world - centroid) / scale, the balls of its domain and of its data, and the
// unit of its reported variance.
struct ModelFrame {
  Vector3 centroid{Vector3::Zero()};
  double scale{1.0};
  double domain_radius_m{0.0};  // queries are valid within this ball around the centroid
  double data_radius_m{0.0};    // the ball around the centroid that holds the surface data
  double variance_unit_factor{1.0};  // reported variance = variance of f * this
};

// Everything a replica needs to rebuild a model exactly (gpatlas_msgs/TrainingSet carries it
// between nodelets): which model, its hyperparameters, its normalisation frame and its data.
struct SurfaceModelState {
  std::string model;                  // the registered name (surfaceModelNames())
  std::vector<double> hyperparameters;  // the model's log-parameters, see hyperparameters()
  Vector3 centroid{Vector3::Zero()};
  double scale{1.0};
  std::vector<TrainingPoint> observations;
  double position_sd_scale{1.0};  // SurfaceModel::positionSdScale
};

// The held-out tests behind SurfaceModel::positionSdScale (position_uncertainty.h): groups of
// |f| / sd(f) at surface points the model had not seen, each group one sample, because the points
// of a group share their error: a side of the view cut off by cross-validation, or one touch's
// contacts as the model predicted them before the touch.
struct PositionSdEvidence {
  std::vector<std::vector<double>> view_folds;
  std::vector<std::vector<double>> touches;
  // PositionCalibrationConfig's touches, coverage and bounds on the scale, from the view's
  // calibration.
  bool use_touches{true};
  double coverage{0.95};
  double min_scale{0.01};
  double max_scale{10.0};
};

// An implicit surface model (paper section 3.1): a posterior over a function f that is negative
// inside the object, zero on its surface and positive outside, with a mean, a variance and a
// gradient everywhere in its domain. The planner, the strategies, the mesher, the collision map,
// the nodelets and the bench see a model through this interface only; implementations are chosen
// by name (makeSurfaceModel) and can be added with registerSurfaceModel.
//
// Frame: every model has a normalisation frame, x_normalised = (x_world - centroid) / scale, in
// which f grows like the normalised distance to the surface near it (f = 1 about one object
// radius out). Const queries must be thread-safe; a failed fit or update leaves the model as it was.
class SurfaceModel {
 public:
  virtual ~SurfaceModel() = default;

  // The name the model is registered under.
  virtual std::string name() const = 0;
  virtual std::unique_ptr<SurfaceModel> clone() const = 0;

  // ---- data
  // Replaces the data and fits from scratch. Needs at least 4 valid surface points.
  virtual FitReport fit(const std::vector<TrainingPoint>& points) = 0;
  // Fits in a given normalisation frame (to replicate another process's model exactly).
  virtual FitReport fitInFrame(const std::vector<TrainingPoint>& points, const Vector3& centroid, double scale) = 0;
  // Adds observations to a fitted model, incrementally where the model can.
  virtual FitReport addPoints(const std::vector<TrainingPoint>& points) = 0;
  virtual bool isFitted() const = 0;
  // Observations in world coordinates (no pseudo-points), in the order they were accepted.
  virtual const std::vector<TrainingPoint>& observations() const = 0;

  // ---- frame: the model's answer, and what follows from it alike for every model
  virtual ModelFrame frame() const = 0;
  Vector3 centroid() const { return frame().centroid; }
  double scale() const { return frame().scale; }
  // Queries are valid within the ball of domainRadiusWorld() (metres) around centroid(), once fitted.
  bool inDomain(const Vector3& x_world) const;
  double domainRadiusWorld() const { return frame().domain_radius_m; }
  // Radius (metres) of the ball around centroid() that holds the surface data.
  double dataRadiusWorld() const { return frame().data_radius_m; }
  // Reported variance = variance of f * this factor (the collision map needs the variance of f).
  double varianceUnitFactor() const { return frame().variance_unit_factor; }

  // ---- queries (world coordinates; throw std::logic_error before the first fit)
  // predictBatch of one point, with gradients and variance.
  Prediction predict(const Vector3& x_world) const;
  // One call for the whole batch. Gradients only when asked for; without `with_variance` (and
  // without the variance gradient) `variance` is NaN and models may skip its cost.
  virtual BatchPrediction predictBatch(const Points3& x_world, bool with_gradient = true,
                                       bool with_variance_gradient = true, bool with_variance = true) const = 0;
  double mean(const Vector3& x_world) const;
  double variance(const Vector3& x_world) const;

  // ---- lookahead (planning/touch_score.h)
  // The reported variance at `x_world` that the model would have after taking each batch of
  // `touches` (one column per batch): what addPoints() of that batch gives, without changing the
  // model. A GP's variance does not depend on the observed values, so no outcome is assumed.
  // This default adds each batch to a clone; the GPIS models override it with a low-rank update
  // of their factors (the posterior covariance between the references and the batch).
  virtual Eigen::MatrixXd varianceAfter(const Points3& x_world,
                                        const std::vector<std::vector<TrainingPoint>>& touches) const;

  // ---- hyperparameters
  // Names of the log-parameters that hyperparameters() returns, in order.
  virtual std::vector<std::string> hyperparameterNames() const = 0;
  virtual Eigen::VectorXd hyperparameters() const = 0;
  // Sets them and refits; on failure the previous ones stay and the report says why.
  virtual FitReport setHyperparameters(const Eigen::VectorXd& log_params) = 0;

  // Distance (metres) from a point to the nearest surface observation or `new_surface_points`:
  // an upper bound on its distance to the surface (TrainingPoint::surface_distance_m).
  double nearestSurfaceDistance(const Vector3& point_world, const std::vector<Vector3>& new_surface_points = {}) const;

  // ---- position uncertainty (position_uncertainty.h)
  // The factor on sd(f) that calibratePositionSd fits: the common scale of the prior's and the
  // noise's standard deviation, which leaves the mean unchanged. The reported variance does not
  // include it, so that V_max keeps the paper's meaning; positionSd() does.
  double positionSdScale() const { return position_sd_scale_; }
  // False, and the scale kept, unless `scale` is finite and > 0.
  bool setPositionSdScale(double scale) {
    if (!(scale > 0.0) || !std::isfinite(scale)) return false;
    position_sd_scale_ = scale;
    return true;
  }

  // What the scale was fitted to; no view folds: not calibrated, and touches do not calibrate it.
  const PositionSdEvidence& positionSdEvidence() const { return position_sd_evidence_; }
  void setPositionSdEvidence(PositionSdEvidence evidence) { position_sd_evidence_ = std::move(evidence); }

  // ---- replicas
  SurfaceModelState state() const;
  // Rebuilds this model from another's state (same model name): its hyperparameters, frame and
  // data, fitted once. On failure the model is unchanged.
  virtual FitReport restore(const SurfaceModelState& state) = 0;

 protected:
  // The checks every model's fitInFrame() and restore() make; false with the reason in `report`.
  static bool checkFrame(const Vector3& centroid, double scale, FitReport* report);
  bool checkStateModel(const SurfaceModelState& state, FitReport* report) const;

 private:
  double position_sd_scale_{1.0};
  PositionSdEvidence position_sd_evidence_;
};

}  // namespace gpatlas_core
