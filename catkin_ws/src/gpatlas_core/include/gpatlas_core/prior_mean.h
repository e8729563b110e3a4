#pragma once

#include "gpatlas_core/types.h"

#include <memory>
#include <string>
#include <vector>

namespace gpatlas_core {

// A prior mean m(x) for the GPIS: what f is believed to be where there are no data. The GP
// then models the residual f - m, so m moves the predicted mean (and the zero level set)
// without lowering the variance anywhere. World coordinates (metres); f is unitless.
class PriorMean {
 public:
  virtual ~PriorMean() = default;
  // m(x); when `gradient` is given, also dm/dx per metre. Must be stateless and thread-safe:
  // model copies share the prior and const queries run concurrently. A non-finite m at an
  // observation or a pseudo-point fails the fit (the model keeps its previous state); a new
  // point where m is not finite is rejected by addPoints.
  virtual double value(const Vector3& x_world, Vector3* gradient = nullptr) const = 0;
};

// "Material is here, probably": m = -depth * (1 - exp(-S(x))), S the sum of compact Wendland
// bumps (1 at a centre) of radius radius_m around the centres. Zero beyond radius_m of every
// centre, smooth, and never below -depth: amid centres a grid step h apart, S is about
// 0.3 (radius_m / h)^3, so the mean saturates at -depth once radius_m is about 3 h.
//
// Why a mean and not inside observations: a guess of where the object is (e.g. the occluded
// interior of a view, see sampleOccludedInterior) should put a predicted surface where the
// object may continue, so that the planner goes and touches it. Observations would also make
// that surface confident, so the planner would never check it; a prior mean leaves its variance
// at the prior's, far above V_max, until a touch confirms or refutes it.
class InteriorPriorMean : public PriorMean {
 public:
  // Throws std::invalid_argument on a non-finite centre, radius_m <= 0 or depth < 0.
  InteriorPriorMean(std::vector<Vector3> centres, double radius_m, double depth);
  double value(const Vector3& x_world, Vector3* gradient = nullptr) const override;
  const std::vector<Vector3>& centres() const { return centres_; }
  double radius() const { return radius_; }
  double depth() const { return depth_; }

 private:
  std::vector<Vector3> centres_;
  double radius_;
  double depth_;
  // Centres bucketed on a grid of cell radius_, so a query visits only its 27 neighbour cells.
  struct Grid;
  std::shared_ptr<const Grid> grid_;
};

}  // namespace gpatlas_core
