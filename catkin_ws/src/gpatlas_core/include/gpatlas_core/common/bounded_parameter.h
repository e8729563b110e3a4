#pragma once

#include <algorithm>
#include <cmath>

namespace gpatlas_core {

// A (log-)parameter kept inside [lo, hi] by a smooth change of variables,
// theta = lo + (hi - lo) * sigmoid(z), so that an unconstrained solver (Ceres' GradientProblem)
// never leaves the box. The multiscale model's tuning of its local GPs uses it.
struct BoundedParameter {
  double lo;
  double hi;

  static double sigmoid(double z) { return 1.0 / (1.0 + std::exp(-z)); }
  double fromUnbounded(double z) const { return lo + (hi - lo) * sigmoid(z); }
  // Clamped a hair inside the box, where the inverse is finite.
  double toUnbounded(double theta) const {
    const double eps = 1e-9;
    const double s = std::min(1.0 - eps, std::max(eps, (theta - lo) / (hi - lo)));
    return std::log(s / (1.0 - s));
  }
  // d theta / d z, for the chain rule of a gradient.
  double derivative(double z) const {
    const double s = sigmoid(z);
    return (hi - lo) * s * (1.0 - s);
  }
};

}  // namespace gpatlas_core
