// Analytic sphere shared by the planner tests and the planner benchmark: surface samples for
// the initial "camera view" and a prober that ray-casts touches against the exact sphere.
#pragma once

#include "gpatlas_core/exploration/prober.h"
#include "gpatlas_core/common/types.h"

#include <cmath>
#include <random>
#include <vector>

namespace gpatlas_core {
namespace testing {

struct AnalyticSphere {
  Vector3 centre{0.6, -0.1, 0.12};
  double radius{0.1};

  double signedDistance(const Vector3& x) const { return (x - centre).norm() - radius; }

  // Points on the part of the sphere whose outward direction has z >= min_z (a view from
  // above), uniformly distributed in area.
  std::vector<TrainingPoint> view(int count, double min_z, double noise_sigma, unsigned seed) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> gaussian;
    std::vector<TrainingPoint> points;
    while (static_cast<int>(points.size()) < count) {
      Vector3 direction(gaussian(rng), gaussian(rng), gaussian(rng));
      if (!(direction.norm() > 1e-9)) continue;
      direction.normalize();
      if (direction.z() < min_z) continue;
      TrainingPoint point;
      point.position = centre + radius * direction;
      point.noise_sigma = noise_sigma;
      point.source = PointSource::kVision;
      points.push_back(point);
    }
    return points;
  }
};

// Executes each waypoint of a touch as a ray along -normal that starts `standoff` metres
// outside the waypoint (the approach) and is `2 * standoff` long. The entry point into the
// sphere is a contact (with the exact normal); the ray's start is free space. A ray that
// misses yields only free space; a start inside the sphere (a wildly wrong prediction) is a
// collision and yields nothing for that waypoint.
class AnalyticSphereProber : public Prober {
 public:
  explicit AnalyticSphereProber(AnalyticSphere sphere, double standoff = 0.1)
      : sphere_(sphere), standoff_(standoff) {}

  ProbeResult probe(const Touch& touch) override {
    ProbeResult result;
    ++touches_;
    for (std::size_t k = 0; k < touch.points.size() && k < touch.normals.size(); ++k) {
      const Vector3 normal = touch.normals[k].normalized();
      const Vector3 origin = touch.points[k] + standoff_ * normal;
      const Vector3 direction = -normal;
      const Vector3 offset = origin - sphere_.centre;
      const double c = offset.squaredNorm() - sphere_.radius * sphere_.radius;
      if (c <= 0.0) continue;  // approach start inside the object
      const double b = offset.dot(direction);
      const double discriminant = b * b - c;
      result.free_space.push_back(origin);
      if (discriminant < 0.0) continue;
      const double entry = -b - std::sqrt(discriminant);
      if (entry < 0.0 || entry > 2.0 * standoff_) continue;
      Contact contact;
      contact.position = origin + entry * direction;
      contact.normal = (contact.position - sphere_.centre).normalized();
      result.contacts.push_back(contact);
    }
    result.success = !result.contacts.empty();
    if (!result.success) result.reason = "no contact along the approach rays";
    return result;
  }

  int touches() const { return touches_; }

 private:
  AnalyticSphere sphere_;
  double standoff_;
  int touches_{0};
};

}  // namespace testing
}  // namespace gpatlas_core
