#pragma once

#include "gpatlas_core/types.h"

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

}  // namespace gpatlas_core
