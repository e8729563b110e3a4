#include "gpatlas_core/model/surface_model.h"

#include <cmath>
#include <limits>

namespace gpatlas_core {

double SurfaceModel::mean(const Vector3& x_world) const { return predictBatch(x_world, false, false, false).mean[0]; }

double SurfaceModel::variance(const Vector3& x_world) const {
  return predictBatch(x_world, false, false, true).variance[0];
}

bool SurfaceModel::inDomain(const Vector3& x_world) const {
  if (!isFitted()) return false;
  const ModelFrame f = frame();
  return (x_world - f.centroid).norm() <= f.domain_radius_m;
}

Prediction SurfaceModel::predict(const Vector3& x_world) const {
  const BatchPrediction batch = predictBatch(x_world, true, true, true);
  Prediction p;
  p.mean = batch.mean[0];
  p.variance = batch.variance[0];
  p.gradient = batch.gradient.col(0);
  p.variance_gradient = batch.variance_gradient.col(0);
  p.in_domain = batch.in_domain[0];
  return p;
}

bool SurfaceModel::checkFrame(const Vector3& centroid, double scale, FitReport* report) {
  if (centroid.allFinite() && scale > 0.0 && std::isfinite(scale)) return true;
  report->ok = false;
  report->message = "invalid normalisation frame (centroid must be finite, scale > 0)";
  return false;
}

bool SurfaceModel::checkStateModel(const SurfaceModelState& state, FitReport* report) const {
  if (state.model == name()) return true;
  report->ok = false;
  report->message = "the state is of a '" + state.model + "' model, this is a '" + name() + "' model";
  return false;
}

double SurfaceModel::nearestSurfaceDistance(const Vector3& point_world,
                                            const std::vector<Vector3>& new_surface_points) const {
  double nearest = std::numeric_limits<double>::infinity();
  for (const TrainingPoint& p : observations())
    if (isSurfaceValue(p)) nearest = std::min(nearest, (p.position - point_world).squaredNorm());
  for (const Vector3& p : new_surface_points) nearest = std::min(nearest, (p - point_world).squaredNorm());
  return std::sqrt(nearest);
}

Eigen::MatrixXd SurfaceModel::varianceAfter(const Points3& x_world,
                                            const std::vector<std::vector<TrainingPoint>>& touches) const {
  Eigen::MatrixXd after(x_world.cols(), static_cast<Eigen::Index>(touches.size()));
  const Eigen::VectorXd before = predictBatch(x_world, false, false, true).variance;
  for (std::size_t b = 0; b < touches.size(); ++b) {
    std::unique_ptr<SurfaceModel> copy = clone();
    after.col(static_cast<Eigen::Index>(b)) =
        copy->addPoints(touches[b]).ok ? copy->predictBatch(x_world, false, false, true).variance : before;
  }
  return after;
}

SurfaceModelState SurfaceModel::state() const {
  SurfaceModelState s;
  s.model = name();
  const Eigen::VectorXd params = hyperparameters();
  s.hyperparameters.assign(params.data(), params.data() + params.size());
  const ModelFrame f = frame();
  s.centroid = f.centroid;
  s.scale = f.scale;
  s.observations = observations();
  s.position_sd_scale = positionSdScale();
  return s;
}


}  // namespace gpatlas_core
