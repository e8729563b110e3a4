#pragma once

#include "gpatlas_core/common/deep_copy_ptr.h"
#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/common/types.h"

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace gpatlas_core {

// Settings of MultiscaleGpisModel. Lengths are metres (world units); sigma is in units of f.
struct MultiscaleGpisConfig {
  // ---- coarse level: a global GpisModel (SurfaceModelConfig::gpis) on a thinned copy of the data.
  // Its O(n^3) fit bounds how much it can take; the thinning keeps the coverage of the data
  // (one point per voxel) rather than its density. These caps are for the view's data (source
  // vision); the probe's data come on top (below), thinned so that an exploration step never
  // changes which earlier points are kept: it extends the coarse factor instead of refitting it.
  // View surface values.
  std::size_t coarse_max_surface_points{600};
  // View free space (outside) and interior (inside) values.
  std::size_t coarse_max_other_points{600};
  // The probe's data are kept in the order they came, at most one per voxel of this side on a
  // fixed world grid: its contacts (each with its slopes), and its free space and interior points
  // up to the count below.
  double coarse_probe_voxel_m{0.01};
  std::size_t coarse_max_probe_other_points{600};

  // ---- fine level: local GPs of the coarse model's residual on a sparse grid of cubic cells.
  // A cell's side: small enough that its factorisation stays cheap at the densest data (a 2 mm
  // voxel grid puts ~100-200 surface points in a 15 mm cell), large enough that a cell holds
  // several correlation lengths.
  double cell_size_m{0.015};
  // Each cell trains on the data within this margin around its core, and its blending weight
  // falls to zero at the margin's edge: neighbouring cells agree where both are trusted.
  double overlap_m{0.006};
  // A cell's training set is thinned (one point per voxel) to at most this many points.
  int max_points_per_cell{400};
  // Weight of the "zero expert" (r = 0, prior variance) in the blend: makes r fall continuously
  // to zero where the last cell's weight ends. A cell's weight peaks at 1.
  double zero_expert_weight{1e-3};

  // Local kernel sigma^2 * Matern52(distance / length). sigma: the amplitude of the residual
  // the coarse model leaves (f is about the normalised distance to the surface, so 0.1 is 10% of
  // the object's radius: a thin part the coarse level smoothed away entirely).
  double sigma{0.1};
  // About the thickness of the thinnest parts to resolve (a mug's wall, 4-7 mm).
  double length_m{0.004};
  // Observation noise of the fine level (depth sensor and contact noise), converted to units of
  // f by the frame's scale.
  double noise_m{0.0005};

  // Tuning of (sigma, length_m, noise_m) by maximising the summed log marginal likelihood of
  // the most populated cells at every fit from scratch: fit(), and fitInFrame() of an unfitted
  // model or in another frame. Updates keep the result: addPoints(), and fitInFrame() in the
  // model's own frame (the exploration's refit when a touch retracts guessed interior).
  bool tune_on_fit{true};
  int tune_max_cells{8};
  int tune_max_iterations{30};
  // Bounds. length: below the 2 mm data spacing the GP returns to its prior between samples
  // (bumps); its upper bound is overlap_m, beyond which a cell's prediction at its blending edge
  // would rest on data on one side only.
  double length_min_m{0.002};
  // sigma: from a residual of 1% of the object's radius to one as large as f itself.
  double sigma_min{0.01};
  double sigma_max{1.0};
  // noise: a good depth sensor's to a poor one's; without a floor the likelihood drives it to
  // zero on noise-free samples, and the cells' matrices become singular.
  double noise_min_m{0.0001};
  double noise_max_m{0.003};
};

// Multi-scale residual GPIS: f(x) = m0(x) + r(x). The coarse level m0 is the global GPIS on a
// thinned copy of the data: it fills the unseen parts with the smooth, object-sized shape the
// paper's model gives. The fine level r is a blend of local GPs of the residual target - m0 on
// a sparse hashed grid of cubic cells (one wherever surface data lie), in the spirit of
// GPisMap's local GPs and of multi-level compact RBF fitting: it uses every measurement and has
// a correlation length of millimetres, so thin parts (handles, walls) that the coarse level
// smooths away are kept. Far from the data r falls to 0 and f to m0.
//
// Frame, domain and variance units are the coarse model's; reported variance = coarse reported
// variance + varianceUnitFactor() * fine variance, so that one V_max means what it means for
// GpisModel. Const queries are thread-safe (and use TBB); a failed fit or update leaves the
// model unchanged.
class MultiscaleGpisModel : public SurfaceModel {
 public:
  using Config = MultiscaleGpisConfig;
  static constexpr const char* kName = "multiscale";

  explicit MultiscaleGpisModel(Config config = Config(), GpisModelConfig coarse_config = GpisModelConfig());
  MultiscaleGpisModel(const MultiscaleGpisModel& other);
  MultiscaleGpisModel& operator=(const MultiscaleGpisModel& other);
  MultiscaleGpisModel(MultiscaleGpisModel&&) noexcept;
  MultiscaleGpisModel& operator=(MultiscaleGpisModel&&) noexcept;
  ~MultiscaleGpisModel() override;

  std::string name() const override { return kName; }
  std::unique_ptr<SurfaceModel> clone() const override;

  // Fits from scratch tune the fine level when config().tune_on_fit (see there); fitInFrame() in
  // the model's own frame starts from the current coarse level and keeps the hyperparameters.
  FitReport fit(const std::vector<TrainingPoint>& points) override;
  FitReport fitInFrame(const std::vector<TrainingPoint>& points, const Vector3& centroid, double scale) override;
  // New vision surface data (or a surface point that moves the frame): full refit in the current
  // frame, without tuning. Contacts, free space and slopes: the coarse model is extended (refitted
  // in its frame when new view free space changes its thinning), the
  // cells whose region holds a new point are refactored (new ones created), the others only
  // re-solved for the new residual targets. Both give what a fit of all the data in this frame
  // with these hyperparameters gives (restore()).
  FitReport addPoints(const std::vector<TrainingPoint>& points) override;
  bool isFitted() const override;
  const std::vector<TrainingPoint>& observations() const override;

  ModelFrame frame() const override;  // the coarse level's

  BatchPrediction predictBatch(const Points3& x_world, bool with_gradient = true, bool with_variance_gradient = true,
                               bool with_variance = true) const override;
  // Both levels' low-rank updates, blended as predictBatch blends them: the coarse level's
  // (GpisModel::varianceAfter) for the batch's points its thinning would keep; the fine level's
  // for each cell whose region holds a new value point (rank k on its factor), and a cell built
  // at a new surface point where none is. Exact while no cell holds more than
  // max_points_per_cell (beyond, a cell's thinning would choose its members again); a batch that
  // addPoints() takes by a refit (view surface data, a frame that moves, a coarse thinning that
  // changes) takes the clone's way.
  Eigen::MatrixXd varianceAfter(const Points3& x_world,
                                const std::vector<std::vector<TrainingPoint>>& touches) const override;

  // The coarse model's log-parameters, then fine log sigma, log length_m, log noise_m.
  std::vector<std::string> hyperparameterNames() const override;
  Eigen::VectorXd hyperparameters() const override;
  FitReport setHyperparameters(const Eigen::VectorXd& log_params) override;
  FitReport restore(const SurfaceModelState& state) override;

  const Config& config() const;
  const GpisModel& coarseModel() const;
  std::size_t numCells() const;
  // The outcome of the last fine-level tuning (ok false and a reason when none ran).
  const TuneReport& fineTuneReport() const;
  // Summed log marginal likelihood of the cells the tuning samples, at the current fine
  // hyperparameters or at the given log (sigma, length_m, noise_m); NaN before a fit.
  double fineLogMarginalLikelihood() const;
  double fineLogMarginalLikelihood(const Eigen::Vector3d& log_params, Eigen::Vector3d* gradient = nullptr) const;

 private:
  struct Impl;
  DeepCopyPtr<Impl> impl_;
};

}  // namespace gpatlas_core
