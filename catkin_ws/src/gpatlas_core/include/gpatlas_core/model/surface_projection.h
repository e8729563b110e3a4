#pragma once

#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/common/types.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace gpatlas_core {

using TangentBasis = Eigen::Matrix<double, 3, 2>;

// An orthonormal basis of the plane orthogonal to `normal` (paper eq. 11: grad f * Phi = 0,
// Phi^T Phi = I). Deterministic in the normal so that equal inputs give equal charts.
// `normal` must be finite and non-zero; it does not need to be unit length.
TangentBasis tangentBasis(const Vector3& normal);

// Newton projection onto the predicted surface f = 0 (paper eq. 13).
struct ProjectionConfig {
  // Converged when |f| (unitless: the GP's targets are 0 on the surface, +-1 off it) is below.
  double f_tolerance{1e-4};
  int max_iterations{30};
  // Longest Newton step, as a fraction of the model's domain radius: far from the level set
  // the GP mean flattens out and a full Newton step can throw the iterate across the domain.
  double max_step_fraction{0.15};
  // |grad f . n| / |grad f| below this means the projection line runs (nearly) along the
  // surface and Newton has no reliable direction: the projection fails instead of wandering.
  double min_gradient_alignment{0.2};
};

enum class ProjectionFailure : std::uint8_t {
  kNone = 0,
  kInvalidInput,      // NaN/Inf start or direction, zero direction
  kOutsideDomain,     // the start or an iterate left the model's domain
  kFlatGradient,      // gradient (nearly) orthogonal to the projection line or zero
  kNotConverged,      // iteration cap reached
  kInvalidPrediction  // the model returned NaN/Inf
};
const char* toString(ProjectionFailure failure);

// A point on the predicted surface with the prediction there (so callers need no second query).
struct SurfacePoint {
  bool ok{false};
  ProjectionFailure failure{ProjectionFailure::kInvalidInput};
  Vector3 position{Vector3::Zero()};
  Vector3 gradient{Vector3::Zero()};  // per metre, world frame; outward
  double mean{0.0};
  double variance{0.0};  // reported units
  int iterations{0};
  Vector3 outwardNormal() const { return gradient.normalized(); }
};

// Solves eq. 13, f(x) = 0 and Phi^T (x - x0) = 0, for every column of `starts` (x0), where Phi
// is the tangent basis orthogonal to the matching column of `directions` (the chart's normal,
// or the gradient at x0 for a free point). All points iterate together so that each Newton
// iteration costs one batched GP query.
std::vector<SurfacePoint> projectOntoSurface(const SurfaceModel& model, const Points3& starts,
                                             const Points3& directions,
                                             const ProjectionConfig& config);

// Projects free points: the projection line of each is the mean's gradient at the point.
std::vector<SurfacePoint> projectAlongGradient(const SurfaceModel& model, const Points3& starts,
                                               const ProjectionConfig& config);

}  // namespace gpatlas_core
