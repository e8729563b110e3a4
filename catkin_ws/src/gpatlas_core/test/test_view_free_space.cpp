#include "gpatlas_core/gpis_model.h"
#include "gpatlas_core/view_free_space.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace gpatlas_core {
namespace {

// A bowl: the lower half (z <= 0) of a sphere of radius 0.1 m centred at the origin, a shell
// of zero thickness, open at the top. The camera above the opening sees its inside through the
// rim; a point of the shell is visible when the camera's ray to it crosses z = 0 inside the rim
// (inside the ball the ray meets no other part of the shell, the ball being convex).
constexpr double kRadius = 0.1;
const Vector3 kEye(0.03, 0.0, 0.4);

std::vector<Vector3> visibleBowlInside(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gaussian;
  std::vector<Vector3> points;
  while (static_cast<int>(points.size()) < count) {
    Vector3 d(gaussian(rng), gaussian(rng), gaussian(rng));
    if (!(d.norm() > 1e-9)) continue;
    d.normalize();
    if (d.z() > -0.05) continue;
    const Vector3 p = kRadius * d;
    const double t = kEye.z() / (kEye.z() - p.z());  // where the ray from the eye meets z = 0
    const Vector3 crossing = kEye + t * (p - kEye);
    if (crossing.head<2>().norm() < 0.98 * kRadius) points.push_back(p);
  }
  return points;
}

TEST(ViewFreeSpace, SamplesLieOnTheRaysBeforeTheHitWithDistanceLabelsToTheView) {
  const auto view = visibleBowlInside(300, 1);
  ViewFreeSpaceConfig config;
  config.max_rays = 100;
  config.samples_per_ray = 3;
  const ViewFreeSpace free = sampleViewFreeSpace(view, kEye, config);
  ASSERT_TRUE(free.ok) << free.message;
  ASSERT_GT(free.points.size(), 250u);

  double view_radius = 0.0;
  Vector3 centroid = Vector3::Zero();
  for (const auto& p : view) centroid += p;
  centroid /= static_cast<double>(view.size());
  for (const auto& p : view) view_radius = std::max(view_radius, (p - centroid).norm());

  for (const auto& t : free.points) {
    EXPECT_EQ(t.label, PointLabel::kOutside);
    EXPECT_EQ(t.source, PointSource::kVision);
    EXPECT_DOUBLE_EQ(t.noise_sigma, config.noise_sigma);
    // On the segment from the eye to one of the view's points, between min and max offset
    // before it.
    bool on_a_ray = false;
    for (const auto& p : view) {
      const Vector3 ray = (p - kEye).normalized();
      const double along = (t.position - kEye).dot(ray);
      const double off_ray = ((t.position - kEye) - along * ray).norm();
      const double before_hit = (p - kEye).norm() - along;
      if (off_ray < 1e-9 && before_hit >= config.min_offset_fraction * view_radius - 1e-9 &&
          before_hit <= config.max_offset_fraction * view_radius + 1e-9)
        on_a_ray = true;
    }
    EXPECT_TRUE(on_a_ray) << t.position.transpose();
    // The label is the distance to the nearest view point (recomputed here) ...
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& p : view) nearest = std::min(nearest, (p - t.position).norm());
    EXPECT_NEAR(t.surface_distance_m, nearest, 1e-12);
    // ... an upper bound on the true distance to the bowl; and the sample is in the air: above
    // the rim, or inside the ball (the cavity).
    const double r = t.position.norm();
    const double true_distance =
        t.position.z() >= 0.0 ? std::max(0.0, (Vector3(t.position.x(), t.position.y(), 0.0).norm() > kRadius
                                                    ? r - kRadius
                                                    : std::min(t.position.z(), kRadius - r)))
                              : std::abs(r - kRadius);
    EXPECT_GE(t.surface_distance_m + 1e-12, true_distance);
    EXPECT_TRUE(t.position.z() > 0.0 || r < kRadius) << t.position.transpose();
  }
}

TEST(ViewFreeSpace, BadInputIsRefusedWithAReason) {
  const auto view = visibleBowlInside(20, 2);
  const Vector3 nan_origin(std::nan(""), 0.0, 0.0);
  auto result = sampleViewFreeSpace(view, nan_origin);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("sensor origin"), std::string::npos);

  result = sampleViewFreeSpace({Vector3(std::nan(""), 0, 0), Vector3::Zero()}, kEye);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("fewer than 2"), std::string::npos);

  ViewFreeSpaceConfig inverted;
  inverted.min_offset_fraction = 0.5;
  inverted.max_offset_fraction = 0.1;
  result = sampleViewFreeSpace(view, kEye, inverted);
  EXPECT_FALSE(result.ok);
  EXPECT_FALSE(result.message.empty());
  EXPECT_TRUE(result.points.empty());
}

// The reason for the view's free space: with surface points alone the GP closes the bowl with
// a lid and calls its cavity inside; the camera's rays through the opening say it is air.
TEST(ViewFreeSpace, KeepsTheCavityOfABowlOpen) {
  const auto view = visibleBowlInside(300, 3);
  std::vector<TrainingPoint> surface;
  for (const auto& p : view) {
    TrainingPoint t;
    t.position = p;
    t.noise_sigma = 0.1;
    surface.push_back(t);
  }
  const Vector3 cavity(0.0, 0.0, -0.04);  // 6 cm from the shell, 4 cm below the rim
  const Vector3 lid(0.0, 0.0, 0.0);       // the centre of the opening

  GpisModel surface_only;
  ASSERT_TRUE(surface_only.fit(surface).ok);
  GpisModel with_free_space;
  auto data = surface;
  const auto free = sampleViewFreeSpace(view, kEye);
  ASSERT_TRUE(free.ok) << free.message;
  data.insert(data.end(), free.points.begin(), free.points.end());
  ASSERT_TRUE(with_free_space.fit(data).ok);

  EXPECT_GT(with_free_space.mean(cavity), 0.05);
  EXPECT_GT(with_free_space.mean(lid), 0.05);
  // No -1 pseudo-point in the cavity: free space lies near the data's centroid.
  EXPECT_EQ(with_free_space.size(),
            static_cast<std::size_t>(GpisModelConfig().num_outside_points) + data.size());
  // The contrast that makes the test meaningful: without the free space, the cavity is not
  // clearly outside.
  EXPECT_LT(surface_only.mean(cavity), with_free_space.mean(cavity) - 0.05);
  // The shell itself stays on the zero level set.
  for (std::size_t i = 0; i < view.size(); i += 10) EXPECT_NEAR(with_free_space.mean(view[i]), 0.0, 0.05);
}

}  // namespace
}  // namespace gpatlas_core
