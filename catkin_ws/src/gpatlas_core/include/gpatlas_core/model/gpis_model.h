#pragma once

#include "gpatlas_core/common/deep_copy_ptr.h"
#include "gpatlas_core/model/gp_numerics.h"
#include "gpatlas_core/model/kernel.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/common/types.h"

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace gpatlas_core {

// Settings of GpisModel (declared outside the class so it can be a default argument).
//
// Frame and units (the paper's, section 3.1): surface data are centred on their centroid and
// scaled so that the farthest surface point is at data_radius = 1 (the paper's unit ball). A
// partial view sees only the front of the object, and the visible centroid sits in front of the
// true centre, so the unseen back can lie up to about one visible width beyond the data: the
// model's domain (where queries are valid and the outside pseudo-points sit) is therefore the
// ball of radius 2, which contains a back as deep as the visible extent.
//
// Variance convention: every variance the model reports, and every noise sigma it is given, is
// in "reference units", those of the paper's reference model (thin-plate R = 2, prior variance
// k(0) = 8, in the unit-ball frame): reported = raw * reference_prior_variance / k(0), and a
// noise sigma s adds s^2 * k(0) / reference_prior_variance to the raw diagonal. Scaling the
// kernel (R, sigma) or re-tuning it then changes neither the posterior mean nor the reported
// variance, only the kernel's shape matters. The default Wendland R = 3.65 has the reference
// thin-plate's correlation curvature at the origin, so a gap between data of a given size (as
// a fraction of the object) has the same reported variance as in the paper to second order,
// and V_max = 0.1 is the paper's threshold: the variance of one point observed with the paper's
// noise variance 0.1, i.e. 1/80 of the prior.
struct GpisModelConfig {
  // "wendland" (positive definite in 3-D at any R); "thin_plate" is the paper's kernel, valid
  // only for a domain diameter <= R: use thinPlateReference() for its settings.
  std::string kernel{"wendland"};
  // Kernel log-parameters at construction; empty keeps the kernel's defaults.
  std::vector<double> initial_params;
  // Surface data are scaled into a ball of this radius around their centroid.
  double data_radius{1.0};
  // A new surface point beyond this normalised radius triggers renormalisation + full refit.
  double renormalise_radius{1.5};
  // Every training point and query must lie within this normalised radius (see above); the
  // thin-plate kernel needs R >= 2 * domain_radius, which is checked at construction and fit.
  double domain_radius{2.0};
  // Pseudo-points (paper 3.1): outside points (+1) on the domain sphere, and one inside
  // point (-1) at the centroid of the surface data.
  int num_outside_points{32};
  bool inside_point_at_centroid{true};
  // ... but only if no surface or outside observation lies within this normalised distance of
  // the centroid (0 always places it): the centroid of a partial view of a cup or a bowl lies in
  // its cavity, close to the wall, and a -1 there would declare the cavity's air inside. The
  // centroid of a convex view lies about half the object's radius behind the visible surface
  // (~0.45 in the unit-ball frame), that of a cup's much closer to the wall (about 0.25); the
  // default lies between the two.
  double inside_point_min_clearance{0.35};
  double pseudo_point_sigma{0.0};
  // Multiplies every point's noise variance; tuned with the kernel's parameters if asked.
  double noise_scale{1.0};
  // Noise sigmas are in reference units (see above); false: in units of f.
  bool noise_in_reported_units{true};
  // The jitter ladder of the factorisation (relative to the kernel's prior variance); the
  // multiscale model's local cells use the same.
  CholeskyConfig cholesky;
  // Two points closer than this (normalised) with the same label are duplicates.
  double duplicate_distance{1e-6};
  // Prior variance of the reference model (see above): reported = raw * this / k(0).
  double reference_prior_variance{8.0};

  // A reference configuration with the paper's thin-plate kernel (R = 2): data in a ball of
  // radius 0.6, domain radius 1 (the largest the kernel allows), inside point always placed. Its
  // Gram matrices are indefinite in 3-D, so its points need a noise sigma of about 0.3.
  static GpisModelConfig thinPlateReference() {
    GpisModelConfig c;
    c.kernel = "thin_plate";
    c.data_radius = 0.6;
    c.renormalise_radius = 0.85;
    c.domain_radius = 1.0;
    c.inside_point_min_clearance = 0.0;
    return c;
  }
};

// The value a GPIS fits at an observation, in units of f for a frame of the given scale (metres):
// target_override when finite; +1 per normalised unit for a slope; for an outside (inside) point
// with a known surface_distance_m, min(1, distance / scale) (its negative), so that the target
// follows every renormalisation; else the label's value (-1, 0, +1).
double gpisTarget(const TrainingPoint& point, double scale);

// Gaussian Process Implicit Surface (paper section 3.1): a GP with zero prior mean fit to
// surface points (target 0), outside points (+1) and inside points (-1), evaluated in a
// normalised frame (centroid at the origin, surface data inside a ball of fixed radius), so
// that the kernel's parameters and the pseudo-points are fixed numbers. A point may also observe
// f's slope along a direction (TrainingPoint::slope_direction), e.g. across a measured normal.
//
// World coordinates are stored; the normalised copies are derived on every (re)fit, so a change
// of centroid or scale can never leave stale points behind. Const queries are thread-safe.
class GpisModel : public SurfaceModel {
 public:
  using Config = GpisModelConfig;
  static constexpr const char* kName = "gpis";

  explicit GpisModel(Config config = Config());
  GpisModel(const GpisModel& other);
  // A copy with room for this many observations, so that adding points up to that count (by
  // addPoints, or by fitInFrame's update of what the model holds) does not copy the factor again.
  GpisModel(const GpisModel& other, std::size_t room_for_observations);
  GpisModel& operator=(const GpisModel& other);
  GpisModel(GpisModel&&) noexcept;
  GpisModel& operator=(GpisModel&&) noexcept;
  ~GpisModel() override;

  std::string name() const override { return kName; }
  std::unique_ptr<SurfaceModel> clone() const override;

  // Replaces the data and fits from scratch. Needs at least 4 valid surface points.
  FitReport fit(const std::vector<TrainingPoint>& points) override;
  // Fits in a given normalisation frame (e.g. to replicate another process's model exactly:
  // the GP node's frame is sticky under incremental updates, so it can differ from the one a
  // fresh fit() would compute from the same data).
  FitReport fitInFrame(const std::vector<TrainingPoint>& points, const Vector3& centroid, double scale) override;
  // Adds points to a fitted model by extending the Cholesky factor (O(n^2 k)); falls back to
  // a full refit when the normalisation must change.
  FitReport addPoints(const std::vector<TrainingPoint>& points) override;
  // Full refit of the current data (after a change of hyperparameters, or to compare with an
  // incremental update). Keeps the current normalisation unless `renormalise` is set, the model
  // was never fitted, or a surface point lies beyond renormalise_radius.
  FitReport refit(bool renormalise = false);

  bool isFitted() const override;
  const Config& config() const;
  // Observations in world coordinates (no pseudo-points).
  const std::vector<TrainingPoint>& observations() const override;
  // Size of the GP's training set, pseudo-points included.
  std::size_t size() const;

  // Normalisation: x_normalised = (x_world - centroid) / scale; the domain and data radii are
  // Config's, times the scale.
  ModelFrame frame() const override;
  Vector3 toNormalised(const Vector3& x_world) const;
  Vector3 toWorld(const Vector3& x_normalised) const;

  // One matrix solve for the whole batch. Gradients are computed only when asked for; without
  // `with_variance` (and without the variance gradient) the O(n^2) per point solve is skipped
  // and `variance` is NaN: mean-only queries (meshing, projection) cost O(n) per point.
  BatchPrediction predictBatch(const Points3& x_world, bool with_gradient = true,
                               bool with_variance_gradient = true, bool with_variance = true) const override;
  // The variance after each batch from the posterior covariance between the references and the
  // batch's rows, cov(a, b) = k(a, b) - k(a, X) K^-1 k(X, b): var'(x) = var(x) - c^T S^-1 c with
  // c = cov(batch, x) and S = cov(batch, batch) + noise (one solve against the factor for all
  // batches and references). A batch that addPoints() would take by a refit (a surface point that
  // moves the frame, a point that drops the inside pseudo-point) takes the clone's way.
  Eigen::MatrixXd varianceAfter(const Points3& x_world,
                                const std::vector<std::vector<TrainingPoint>>& touches) const override;

  // Hyperparameters.
  const Kernel& kernel() const;
  // Sets kernel log-parameters and the noise scale, then refits; on failure restores the
  // previous ones and returns the failing report.
  FitReport setHyperparameters(const Eigen::VectorXd& kernel_log_params, double noise_scale);
  // The kernel's log-parameters, then log noise_scale.
  std::vector<std::string> hyperparameterNames() const override;
  Eigen::VectorXd hyperparameters() const override;
  FitReport setHyperparameters(const Eigen::VectorXd& log_params) override;
  FitReport restore(const SurfaceModelState& state) override;
  // Log marginal likelihood of the current fit (normalised frame).
  double logMarginalLikelihood() const;


 private:
  FitReport fitFrom(const std::vector<TrainingPoint>& points, const Vector3* centroid, double scale);
  // fitInFrame, when the points begin with those the model holds, in its frame, some missing or
  // with other targets (interior guesses a touch retracted or dropped), and the rest are new:
  // the factor of K loses the missing rows (a rank-one update each), K^-1 y is solved again, and
  // the new points extend it (addPoints), instead of a refit's O(n^3). False, with the model as
  // it was, when that does not hold, when more than a third would go, or when the extension fails.
  bool updateInFrame(const std::vector<TrainingPoint>& points, const Vector3& centroid, double scale, FitReport* report);
  // refit() with `added` appended to the observations; on failure the observations are as they
  // were (refit() restores the rest). num_added: the added points' count, 0 on failure.
  FitReport refitWith(const std::vector<TrainingPoint>& added, bool renormalise);

  struct Impl;
  DeepCopyPtr<Impl> impl_;
};

}  // namespace gpatlas_core
