#include "gpatlas_core/model/surface_projection.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace gpatlas_core {

TangentBasis tangentBasis(const Vector3& normal) {
  const Vector3 n = normal.normalized();
  // Seed with the world axis least aligned with n so the cross product is well conditioned.
  Eigen::Index least_aligned = 0;
  n.cwiseAbs().minCoeff(&least_aligned);
  const Vector3 seed = Vector3::Unit(least_aligned);
  const Vector3 t1 = (seed - seed.dot(n) * n).normalized();
  const Vector3 t2 = n.cross(t1);
  TangentBasis basis;
  basis.col(0) = t1;
  basis.col(1) = t2;
  return basis;
}

const char* toString(ProjectionFailure failure) {
  switch (failure) {
    case ProjectionFailure::kNone: return "none";
    case ProjectionFailure::kInvalidInput: return "invalid input";
    case ProjectionFailure::kOutsideDomain: return "left the model domain";
    case ProjectionFailure::kFlatGradient: return "gradient orthogonal to the projection line";
    case ProjectionFailure::kNotConverged: return "not converged";
    case ProjectionFailure::kInvalidPrediction: return "model returned NaN";
  }
  return "unknown";
}

namespace {

// The points whose start and direction are usable, their unit directions in `unit_directions`;
// the others' results get their failure.
std::vector<Eigen::Index> usableStarts(const SurfaceModel& model, const Points3& starts, const Points3& directions,
                                       Points3& unit_directions, std::vector<SurfacePoint>& results) {
  std::vector<Eigen::Index> active;
  active.reserve(static_cast<std::size_t>(starts.cols()));
  for (Eigen::Index i = 0; i < starts.cols(); ++i) {
    SurfacePoint& result = results[static_cast<std::size_t>(i)];
    const double direction_norm = directions.col(i).norm();
    if (!starts.col(i).allFinite() || !directions.col(i).allFinite() || !(direction_norm > 0.0)) {
      result.failure = ProjectionFailure::kInvalidInput;
      continue;
    }
    if (!model.inDomain(starts.col(i))) {
      result.failure = ProjectionFailure::kOutsideDomain;
      continue;
    }
    unit_directions.col(i) = directions.col(i) / direction_norm;
    active.push_back(i);
  }
  return active;
}

// The variance at the converged points (it costs O(n^2) per point: evaluated once, for them
// only); a point whose variance is not finite fails after all.
void addSurfaceVariance(const SurfaceModel& model, std::vector<SurfacePoint>& results) {
  std::vector<std::size_t> converged;
  for (std::size_t i = 0; i < results.size(); ++i)
    if (results[i].ok) converged.push_back(i);
  if (converged.empty()) return;
  Points3 positions(3, static_cast<Eigen::Index>(converged.size()));
  for (std::size_t k = 0; k < converged.size(); ++k)
    positions.col(static_cast<Eigen::Index>(k)) = results[converged[k]].position;
  const BatchPrediction at_surface = model.predictBatch(positions, false, false, true);
  for (std::size_t k = 0; k < converged.size(); ++k) {
    const double variance = at_surface.variance(static_cast<Eigen::Index>(k));
    if (std::isfinite(variance)) {
      results[converged[k]].variance = variance;
    } else {
      results[converged[k]].ok = false;
      results[converged[k]].failure = ProjectionFailure::kInvalidPrediction;
    }
  }
}

}  // namespace

std::vector<SurfacePoint> projectOntoSurface(const SurfaceModel& model, const Points3& starts,
                                             const Points3& directions,
                                             const ProjectionConfig& config) {
  const Eigen::Index count = starts.cols();
  std::vector<SurfacePoint> results(static_cast<std::size_t>(count));
  if (count == 0) return results;
  if (!model.isFitted() || directions.cols() != count) return results;  // all kInvalidInput

  const double max_step = config.max_step_fraction * model.domainRadiusWorld();
  Points3 unit_directions(3, count);
  Points3 current = starts;
  std::vector<Eigen::Index> active = usableStarts(model, starts, directions, unit_directions, results);

  // The constraint Phi^T (x - x0) = 0 is linear, so once satisfied (it is at x0) every Newton
  // step of the 3x3 system [grad f^T; Phi^T] dx = -[f; 0] stays on the line x0 + s n and
  // reduces exactly to the scalar step ds = -f / (grad f . n) solved below.
  for (int iteration = 0; !active.empty(); ++iteration) {
    Points3 queries(3, static_cast<Eigen::Index>(active.size()));
    for (std::size_t k = 0; k < active.size(); ++k) queries.col(static_cast<Eigen::Index>(k)) = current.col(active[k]);
    const BatchPrediction prediction = model.predictBatch(queries, /*with_gradient=*/true,
                                                          /*with_variance_gradient=*/false,
                                                          /*with_variance=*/false);
    std::vector<Eigen::Index> still_active;
    for (std::size_t k = 0; k < active.size(); ++k) {
      const Eigen::Index i = active[k];
      const Eigen::Index q = static_cast<Eigen::Index>(k);
      SurfacePoint& result = results[static_cast<std::size_t>(i)];
      result.iterations = iteration;
      const double f = prediction.mean(q);
      const Vector3 gradient = prediction.gradient.col(q);
      if (!prediction.in_domain(q)) {
        result.failure = ProjectionFailure::kOutsideDomain;
        continue;
      }
      if (!std::isfinite(f) || !gradient.allFinite()) {
        result.failure = ProjectionFailure::kInvalidPrediction;
        continue;
      }
      if (std::abs(f) < config.f_tolerance) {
        result.ok = true;
        result.failure = ProjectionFailure::kNone;
        result.position = current.col(i);
        result.gradient = gradient;
        result.mean = f;
        continue;
      }
      if (iteration >= config.max_iterations) {
        result.failure = ProjectionFailure::kNotConverged;
        continue;
      }
      const double slope = gradient.dot(unit_directions.col(i));
      const double gradient_norm = gradient.norm();
      if (!(gradient_norm > 0.0) || std::abs(slope) < config.min_gradient_alignment * gradient_norm) {
        result.failure = ProjectionFailure::kFlatGradient;
        continue;
      }
      const double step = std::clamp(-f / slope, -max_step, max_step);
      current.col(i) += step * unit_directions.col(i);
      if (!model.inDomain(current.col(i))) {
        result.failure = ProjectionFailure::kOutsideDomain;
        continue;
      }
      still_active.push_back(i);
    }
    active.swap(still_active);
  }
  addSurfaceVariance(model, results);
  return results;
}

std::vector<SurfacePoint> projectAlongGradient(const SurfaceModel& model, const Points3& starts,
                                               const ProjectionConfig& config) {
  if (!model.isFitted() || starts.cols() == 0) return std::vector<SurfacePoint>(static_cast<std::size_t>(starts.cols()));
  Points3 directions = Points3::Zero(3, starts.cols());
  std::vector<Eigen::Index> valid;
  for (Eigen::Index i = 0; i < starts.cols(); ++i)
    if (starts.col(i).allFinite() && model.inDomain(starts.col(i))) valid.push_back(i);
  if (!valid.empty()) {
    Points3 valid_starts(3, static_cast<Eigen::Index>(valid.size()));
    for (std::size_t k = 0; k < valid.size(); ++k) valid_starts.col(static_cast<Eigen::Index>(k)) = starts.col(valid[k]);
    const BatchPrediction prediction = model.predictBatch(valid_starts, true, false, false);
    for (std::size_t k = 0; k < valid.size(); ++k)
      directions.col(valid[k]) = prediction.gradient.col(static_cast<Eigen::Index>(k));
  }
  // Points left with a zero direction fail inside projectOntoSurface as invalid input.
  return projectOntoSurface(model, starts, directions, config);
}

}  // namespace gpatlas_core
