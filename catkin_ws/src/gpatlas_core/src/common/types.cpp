#include "gpatlas_core/common/types.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace gpatlas_core {

const char* toString(PointSource source) {
  switch (source) {
    case PointSource::kVision: return "vision";
    case PointSource::kTouch: return "touch";
    case PointSource::kFreeSpace: return "free_space";
    case PointSource::kPseudo: return "pseudo";
    case PointSource::kViewSupport: return "view_support";
  }
  return "unknown";
}

std::vector<Vector3> fibonacciSphere(int count) {
  std::vector<Vector3> dirs;
  dirs.reserve(static_cast<std::size_t>(std::max(count, 0)));
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / count;
    const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * i;
    dirs.emplace_back(rho * std::cos(phi), rho * std::sin(phi), z);
  }
  return dirs;
}

std::vector<Vector3> aimedPoints(const Touch& touch) {
  if (touch.kind == Touch::Kind::kPoke && !touch.points.empty()) return {touch.points.back()};
  return touch.points;
}

std::size_t approachTarget(const Touch& touch) {
  return touch.kind == Touch::Kind::kPoke && !touch.points.empty() ? touch.points.size() - 1 : 0;
}

std::size_t retreatTarget(const Touch& touch) { return touch.points.empty() ? 0 : touch.points.size() - 1; }

double quantile(std::vector<double> values, double q) {
  // NaN has no rank (nth_element's order would be undefined); infinities have theirs.
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return std::isnan(v); }), values.end());
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t k = std::min(values.size() - 1, static_cast<std::size_t>(q * static_cast<double>(values.size())));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

double median(std::vector<double> values) {
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); }), values.end());
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t middle = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle), values.end());
  const double upper = values[middle];
  if (values.size() % 2 == 1) return upper;
  return 0.5 * (upper + *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(middle)));
}

}  // namespace gpatlas_core
