#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/multiscale_gpis_model.h"
#include "gpatlas_core/observations/view_training.h"
#include "gpatlas_core/observations/support_plane.h"
#include "gpatlas_core/observations/view_free_space.h"
#include "gpatlas_core/observations/near_surface_free_space.h"
#include "gpatlas_core/observations/occluded_interior.h"
#include "gpatlas_core/observations/below_support.h"
#include "gpatlas_core/observations/support_free_space.h"

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
constexpr std::uint64_t kSeed = 1;  // the samplers' random stream

// `count` points uniform in area on the sphere |p| = kRadius that `keep` accepts.
template <typename Keep>
std::vector<Vector3> sphereSamples(int count, unsigned seed, Keep keep) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gaussian;
  std::vector<Vector3> points;
  while (static_cast<int>(points.size()) < count) {
    Vector3 d(gaussian(rng), gaussian(rng), gaussian(rng));
    if (!(d.norm() > 1e-9)) continue;
    const Vector3 p = kRadius * d.normalized();
    if (keep(p)) points.push_back(p);
  }
  return points;
}

// Where the ray from `eye` through p crosses the plane z = 0 (the bowl's opening).
Vector3 openingCrossing(const Vector3& eye, const Vector3& p) { return eye + (eye.z() / (eye.z() - p.z())) * (p - eye); }

std::vector<Vector3> visibleBowlInside(int count, unsigned seed) {
  return sphereSamples(count, seed, [](const Vector3& p) {
    return p.z() < -0.05 * kRadius && openingCrossing(kEye, p).head<2>().norm() < 0.98 * kRadius;
  });
}

TEST(ViewFreeSpace, SamplesLieOnTheRaysBeforeTheHitWithDistanceLabelsToTheView) {
  const auto view = visibleBowlInside(300, 1);
  ViewFreeSpaceConfig config;
  config.max_rays = 100;
  config.samples_per_ray = 3;
  const ViewSamples free = sampleViewFreeSpace(view, kEye, kSeed, config);
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
  auto result = sampleViewFreeSpace(view, nan_origin, kSeed);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("sensor origin"), std::string::npos);

  result = sampleViewFreeSpace({Vector3(std::nan(""), 0, 0), Vector3::Zero()}, kEye, kSeed);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("fewer than 2"), std::string::npos);

  ViewFreeSpaceConfig inverted;
  inverted.min_offset_fraction = 0.5;
  inverted.max_offset_fraction = 0.1;
  result = sampleViewFreeSpace(view, kEye, kSeed, inverted);
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
  const auto free = sampleViewFreeSpace(view, kEye, kSeed);
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

// The front of a solid ball of radius kRadius centred at the origin, as seen from kSideEye:
// a point of a convex body is visible exactly when its outward normal faces the eye.
const Vector3 kSideEye(0.5, 0.1, 0.2);

std::vector<Vector3> visibleBallFront(int count, unsigned seed) {
  return sphereSamples(count, seed, [](const Vector3& p) { return p.dot(kSideEye - p) > 0.0; });
}

// Range from `eye` to the first intersection of its ray through `x` with the sphere |p| = R,
// or infinity when the ray misses it.
double firstSphereHit(const Vector3& eye, const Vector3& x) {
  const Vector3 u = (x - eye).normalized();
  const double b = eye.dot(u);
  const double disc = b * b - (eye.squaredNorm() - kRadius * kRadius);
  if (disc < 0.0) return std::numeric_limits<double>::infinity();
  return -b - std::sqrt(disc);
}

TEST(NearSurfaceFreeSpace, OneSampleInFrontOfEachViewPointLabelledWithItsNearestDistance) {
  // A 4 cm square of the plane z = 0 at 2 mm, seen from 1 m above one corner (oblique rays).
  std::vector<Vector3> view;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 20; ++j) view.emplace_back(0.002 * i, 0.002 * j, 0.0);
  const Vector3 sensor(-0.5, 0.0, 1.0);
  NearSurfaceFreeSpaceConfig config;
  config.offset_m = 0.003;
  config.max_points = 100;
  const ViewSamples near = sampleNearSurfaceFreeSpace(view, sensor, config);
  ASSERT_TRUE(near.ok) << near.message;
  ASSERT_EQ(near.points.size(), 100u);
  for (const TrainingPoint& t : near.points) {
    EXPECT_EQ(t.label, PointLabel::kOutside);
    // On the ray of some view point, offset_m towards the sensor.
    bool on_a_ray = false;
    for (const Vector3& p : view)
      on_a_ray |= (t.position - (p + config.offset_m * (sensor - p).normalized())).norm() < 1e-12;
    EXPECT_TRUE(on_a_ray);
    EXPECT_GT(t.position.z(), 0.0);
    double nearest = std::numeric_limits<double>::infinity();
    for (const Vector3& p : view) nearest = std::min(nearest, (p - t.position).norm());
    EXPECT_NEAR(t.surface_distance_m, nearest, 1e-12);
    EXPECT_LE(t.surface_distance_m, config.offset_m + 1e-12);  // its own view point is that far
  }
  config.max_points = 0;
  const ViewSamples none = sampleNearSurfaceFreeSpace(view, sensor, config);
  EXPECT_TRUE(none.ok && none.points.empty());
  config.max_points = 10;
  config.offset_m = 0.0;
  EXPECT_FALSE(sampleNearSurfaceFreeSpace(view, sensor, config).ok);
  config.offset_m = 0.003;
  EXPECT_FALSE(sampleNearSurfaceFreeSpace(view, Vector3::Constant(std::nan("")), config).ok);
}

TEST(OccludedInterior, SamplesOfASolidBallLieInsideItBehindTheVisibleSurface) {
  const auto view = visibleBallFront(3000, 4);
  OccludedInteriorConfig config;
  config.max_points = 80;
  const ViewSamples inside = sampleOccludedInterior(view, kSideEye, kSeed, config);
  ASSERT_TRUE(inside.ok) << inside.message;
  ASSERT_EQ(inside.points.size(), 80u);  // the ball's hidden half is large: the cap applies

  double view_radius = 0.0;
  Vector3 centroid = Vector3::Zero();
  for (const auto& p : view) centroid += p;
  centroid /= static_cast<double>(view.size());
  for (const auto& p : view) view_radius = std::max(view_radius, (p - centroid).norm());
  const double margin = config.margin_fraction * view_radius;

  for (const auto& t : inside.points) {
    EXPECT_EQ(t.label, PointLabel::kInside);
    EXPECT_EQ(t.source, PointSource::kVision);
    EXPECT_DOUBLE_EQ(t.noise_sigma, config.noise_sigma);
    // Inside the solid (the truth), and behind the surface the camera saw on its own ray.
    EXPECT_LT(t.position.norm(), kRadius) << t.position.transpose();
    // By the margin, less the range image's coarseness (a pixel spans several view rays, whose
    // hits on the curved surface differ in range by up to a few millimetres).
    EXPECT_GE((t.position - kSideEye).norm(), firstSphereHit(kSideEye, t.position) + margin - 0.005)
        << t.position.transpose();
    // Labelled with the distance to the nearest view point (recomputed), which clears the margin.
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& p : view) nearest = std::min(nearest, (p - t.position).norm());
    EXPECT_NEAR(t.surface_distance_m, nearest, 1e-12);
    EXPECT_GE(nearest, margin - 1e-12);
  }
}

TEST(OccludedInterior, NothingTheCameraSawAsAirInABowl) {
  // The zero-thickness bowl: its occluded interior is the space behind the shell. No sample may
  // lie where the camera's ray reached it unobstructed: in the cavity in view, or above the rim.
  // Seen from the side and above, so that the near rim hides part of the cavity: the shell's
  // inside is visible where the ray enters through the opening, its outside where it faces
  // the eye.
  const Vector3 eye(0.35, 0.05, 0.2);
  const auto view = sphereSamples(3000, 5, [&eye](const Vector3& p) {
    return p.z() <= 0.0 && (openingCrossing(eye, p).head<2>().norm() < kRadius || p.dot(eye - p) > 0.0);
  });
  const ViewSamples inside = sampleOccludedInterior(view, eye, kSeed);
  ASSERT_TRUE(inside.ok) << inside.message;
  ASSERT_GE(inside.points.size(), 20u);
  std::size_t grazing = 0;
  for (const auto& t : inside.points) {
    const Vector3& x = t.position;
    EXPECT_LT(x.z(), 0.0) << x.transpose();
    // The ray from the eye meets the shell (the sphere below z = 0) before x.
    const Vector3 u = (x - eye).normalized();
    const double b = eye.dot(u);
    const double disc = b * b - (eye.squaredNorm() - kRadius * kRadius);
    bool blocked = false;
    if (disc >= 0.0) {
      for (double s : {-b - std::sqrt(disc), -b + std::sqrt(disc)}) {
        const Vector3 hit = eye + s * u;
        if (hit.z() <= 0.0 && s < (x - eye).norm()) blocked = true;
      }
    }
    if (blocked) continue;
    // The range image is coarse (about 4 view points per pixel, 7 mm here): a ray that grazes
    // the rim can share a pixel with it. Allowed within a pixel of the rim, and rarely.
    ++grazing;
    EXPECT_GT(openingCrossing(eye, x).head<2>().norm(), kRadius - 0.01) << x.transpose();
  }
  EXPECT_LE(grazing, inside.points.size() / 20);
}

TEST(OccludedInterior, BadInputIsRefusedWithAReason) {
  const auto view = visibleBallFront(50, 6);
  auto result = sampleOccludedInterior(view, Vector3(std::nan(""), 0.0, 0.0), kSeed);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("sensor origin"), std::string::npos);

  result = sampleOccludedInterior({Vector3::Zero(), Vector3::UnitX(), Vector3(std::nan(""), 0, 0)}, kSideEye, kSeed);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("fewer than 4"), std::string::npos);

  result = sampleOccludedInterior(view, Vector3::Zero(), kSeed);  // the sensor amid the points
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.message.find("surround the sensor"), std::string::npos);

  OccludedInteriorConfig bad;
  bad.grid_cells = 1;
  result = sampleOccludedInterior(view, kSideEye, kSeed, bad);
  EXPECT_FALSE(result.ok);
  EXPECT_TRUE(result.points.empty());

}

// Every stride-th view point as a surface observation (the camera's noise sigma).
std::vector<TrainingPoint> surfaceData(const std::vector<Vector3>& view, std::size_t stride) {
  std::vector<TrainingPoint> data;
  for (std::size_t i = 0; i < view.size(); i += stride) {
    TrainingPoint t;
    t.position = view[i];
    t.noise_sigma = 0.1;
    data.push_back(t);
  }
  return data;
}

// The reason for the occluded interior: with the front of a ball, its view's free space and no
// inside pseudo-point, the GP has no evidence of material, and the ball's centre is not
// clearly inside. The occluded interior says it is.
TEST(OccludedInterior, TellsTheModelTheHiddenBulkIsMaterial) {
  const auto view = visibleBallFront(1500, 7);
  std::vector<TrainingPoint> data = surfaceData(view, 4);
  const auto free = sampleViewFreeSpace(view, kSideEye, kSeed);
  ASSERT_TRUE(free.ok) << free.message;
  data.insert(data.end(), free.points.begin(), free.points.end());
  GpisModelConfig config;
  config.inside_point_at_centroid = false;
  GpisModel without(config);
  ASSERT_TRUE(without.fit(data).ok);

  const auto inside = sampleOccludedInterior(view, kSideEye, kSeed);
  ASSERT_TRUE(inside.ok) << inside.message;
  data.insert(data.end(), inside.points.begin(), inside.points.end());
  GpisModel with(config);
  ASSERT_TRUE(with.fit(data).ok);

  const Vector3 centre = Vector3::Zero();
  const Vector3 hidden_back = -0.6 * kRadius * kSideEye.normalized();
  EXPECT_LT(with.mean(centre), -0.1);
  EXPECT_LT(with.mean(hidden_back), -0.05);
  EXPECT_LT(with.mean(centre), without.mean(centre) - 0.1);
  // The visible surface stays on the zero level set.
  for (std::size_t i = 0; i < view.size(); i += 50) EXPECT_NEAR(with.mean(view[i]), 0.0, 0.05);
}

TEST(SupportPlane, SamplesLieBelowThePlaneUnderTheViewLabelledWithTheirDepth) {
  const auto view = visibleBallFront(500, 13);
  double view_radius = 0.0;
  Vector3 centroid = Vector3::Zero();
  for (const auto& p : view) centroid += p;
  centroid /= static_cast<double>(view.size());
  for (const auto& p : view) view_radius = std::max(view_radius, (p - centroid).norm());

  SupportPlane plane;  // tilted, under the ball
  plane.normal = Vector3(0.2, -0.1, 1.0).normalized();
  plane.offset = 0.12;
  BelowSupportConfig config;
  const ViewSamples below = sampleBelowSupport(view, plane, config);
  ASSERT_TRUE(below.ok) << below.message;
  // Every layer has the same cells, and the ball's footprint (a disc) fills most of the grid.
  ASSERT_EQ(below.points.size() % config.depth_fractions.size(), 0u);
  const std::size_t per_layer = below.points.size() / config.depth_fractions.size();
  EXPECT_GT(per_layer, static_cast<std::size_t>(config.grid_cells * config.grid_cells) / 2);
  const double grow = config.footprint_margin_fraction * view_radius;
  for (const auto& t : below.points) {
    EXPECT_EQ(t.label, PointLabel::kOutside);
    const double depth = -(plane.normal.dot(t.position) + plane.offset);  // recomputed
    EXPECT_NEAR(t.surface_distance_m, depth, 1e-12);
    bool a_layer = false;
    for (double f : config.depth_fractions) a_layer = a_layer || std::abs(depth - f * view_radius) < 1e-9;
    EXPECT_TRUE(a_layer) << depth;
    // Under the view: its projection on the plane is within the margin of a projected view
    // point (recomputed).
    const Vector3 projected = t.position + depth * plane.normal;
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& p : view) nearest = std::min(nearest, (p - plane.height(p) * plane.normal - projected).norm());
    EXPECT_LE(nearest, grow + 1e-9);
  }
  // A flipped normal puts the view below the plane: refused.
  SupportPlane flipped = plane;
  flipped.normal = -plane.normal;
  flipped.offset = -plane.offset;
  const ViewSamples refused = sampleBelowSupport(view, flipped);
  EXPECT_FALSE(refused.ok);
  EXPECT_NE(refused.message.find("flipped"), std::string::npos);

  SupportPlane bad;
  bad.normal = Vector3(0.0, 0.0, 2.0);
  EXPECT_FALSE(sampleBelowSupport(view, bad).ok);
  BelowSupportConfig no_depths;
  no_depths.depth_fractions.clear();
  EXPECT_FALSE(sampleBelowSupport(view, plane, no_depths).ok);
}

TEST(SupportPlane, DropsExactlyThePointsTooCloseToOrBelowIt) {
  SupportPlane plane;
  plane.offset = -0.01;  // z = 0.01
  std::vector<TrainingPoint> points;
  for (double z : {-0.05, 0.0, 0.012, 0.0149, 0.0151, 0.2}) {
    TrainingPoint t;
    t.position = Vector3(0.3, -0.2, z);
    points.push_back(t);
  }
  EXPECT_EQ(dropNearOrBelowPlane(&points, plane, 0.005), 4u);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_DOUBLE_EQ(points[0].position.z(), 0.0151);
  EXPECT_DOUBLE_EQ(points[1].position.z(), 0.2);
}

// Guesses claim a solid ball of radius surface_distance_m around them; evidence inside that
// ball cuts the claim to the evidence's distance, or removes the guess when that is below the
// minimum depth. Expectations computed by hand from the layout.
TEST(OccludedInterior, TouchEvidenceShrinksOrDropsExactlyTheGuessesItContradicts) {
  const auto guess = [](double x, double depth) {
    TrainingPoint t;
    t.position = Vector3(x, 0.0, 0.0);
    t.label = PointLabel::kInside;
    t.source = PointSource::kVision;
    t.surface_distance_m = depth;
    return t;
  };
  std::vector<TrainingPoint> points{guess(0.0, 0.03), guess(1.0, 0.03), guess(2.0, 0.03), guess(3.0, 0.03)};
  // Not guesses: a contact's inside point and a vision surface point, both right at the evidence.
  TrainingPoint touch_inside = guess(1.0, 0.03);
  touch_inside.source = PointSource::kTouch;
  TrainingPoint surface;
  surface.position = Vector3(2.0, 0.0, 0.0);
  points.push_back(touch_inside);
  points.push_back(surface);
  const std::vector<Vector3> evidence{
      Vector3(0.0, 0.02, 0.0),    // 20 mm from guess 0: shrinks it to 20 mm
      Vector3(1.004, 0.0, 0.0),   // 4 mm from guess 1: below the 5 mm minimum, dropped
      Vector3(2.0, 0.0, 0.031),   // 31 mm from guess 2: outside its claim
      Vector3(std::numeric_limits<double>::quiet_NaN(), 3.0, 0.0)};  // ignored
  const InteriorRetraction retraction = retractContradictedInterior(&points, evidence, 0.005);
  EXPECT_EQ(retraction.shrunk, 1u);
  EXPECT_EQ(retraction.dropped, 1u);
  ASSERT_EQ(points.size(), 5u);
  EXPECT_DOUBLE_EQ(points[0].position.x(), 0.0);
  EXPECT_NEAR(points[0].surface_distance_m, 0.02, 1e-12);
  EXPECT_DOUBLE_EQ(points[1].position.x(), 2.0);
  EXPECT_DOUBLE_EQ(points[1].surface_distance_m, 0.03);
  EXPECT_DOUBLE_EQ(points[2].surface_distance_m, 0.03);  // guess 3, no evidence near it
  EXPECT_EQ(points[3].source, PointSource::kTouch);
  EXPECT_DOUBLE_EQ(points[3].surface_distance_m, 0.03);
  EXPECT_EQ(points[4].label, PointLabel::kSurface);

  // No evidence near any guess: nothing changes.
  const std::vector<TrainingPoint> before = points;
  EXPECT_FALSE(retractContradictedInterior(&points, {Vector3(10.0, 0.0, 0.0)}, 0.005).any());
  ASSERT_EQ(points.size(), before.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(points[i].position, before[i].position);
    if (std::isfinite(before[i].surface_distance_m))
      EXPECT_DOUBLE_EQ(points[i].surface_distance_m, before[i].surface_distance_m);
  }
  EXPECT_FALSE(retractContradictedInterior(nullptr, evidence, 0.005).any());
}

// A ball resting on a table, seen from the side and above, the table hiding its lowest band:
// without the table the model leaves the unseen bottom to the GP's smoothness (here it cuts the
// ball off above its lowest point); the plane's outside points, labelled with their small depth,
// say the surface is right there, and nothing of the prediction may go below the table top.
// A 6 x 4 x 1 cm box standing on the table z = 0, seen from above one side. Segmentation removes
// everything within 4 mm of the table with it, so the view starts 4 mm up.
constexpr double kBoxHalfX = 0.03, kBoxHalfY = 0.02, kBoxHeight = 0.01, kCutHeight = 0.004;
const Vector3 kBoxEye(0.35, 0.12, 0.3);

// Signed distance to the box (negative inside).
double boxDistance(const Vector3& x) {
  const Vector3 q = (x - Vector3(0.0, 0.0, kBoxHeight / 2)).cwiseAbs() - Vector3(kBoxHalfX, kBoxHalfY, kBoxHeight / 2);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// True when the segment from the eye to x passes through the box (slab test), x excluded.
bool boxBlocks(const Vector3& eye, const Vector3& x) {
  const Vector3 lo(-kBoxHalfX, -kBoxHalfY, 0.0), hi(kBoxHalfX, kBoxHalfY, kBoxHeight);
  const Vector3 d = x - eye;
  double t0 = 0.0, t1 = 1.0 - 1e-9;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-15) {
      if (eye[a] < lo[a] || eye[a] > hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - eye[a]) / d[a], tb = (hi[a] - eye[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

// The box's faces the eye sees (their outward normal faces it), on a 2 mm grid, above the cut.
std::vector<Vector3> visibleBoxView() {
  std::vector<Vector3> view;
  const double step = 0.002;
  for (double x = -kBoxHalfX; x <= kBoxHalfX + 1e-9; x += step)
    for (double y = -kBoxHalfY; y <= kBoxHalfY + 1e-9; y += step) view.emplace_back(x, y, kBoxHeight);  // top
  for (double z = kCutHeight; z <= kBoxHeight + 1e-9; z += step) {
    for (double y = -kBoxHalfY; y <= kBoxHalfY + 1e-9; y += step) view.emplace_back(kBoxHalfX, y, z);  // +x side
    for (double x = -kBoxHalfX; x <= kBoxHalfX + 1e-9; x += step) view.emplace_back(x, kBoxHalfY, z);  // +y side
  }
  return view;
}

TEST(SupportFreeSpace, SamplesOnlyTheTableTheCameraSawBesideTheObject) {
  const std::vector<Vector3> view = visibleBoxView();
  const SupportPlane table;
  SupportFreeSpaceConfig config;
  const ViewSamples beside = sampleSupportFreeSpace(view, kBoxEye, table, config);
  ASSERT_TRUE(beside.ok) << beside.message;
  std::size_t in_front = 0, on_the_side = 0;
  for (const TrainingPoint& t : beside.points) {
    EXPECT_EQ(t.label, PointLabel::kOutside);
    EXPECT_EQ(t.source, PointSource::kViewSupport);
    EXPECT_NEAR(t.position.z(), config.height_m, 1e-12);
    // The camera's ray to it misses the box (recomputed analytically): the table was seen there.
    EXPECT_FALSE(boxBlocks(kBoxEye, t.position)) << t.position.transpose();
    // Outside the true box by the planar margin.
    const double truth = boxDistance(t.position);
    EXPECT_GE(truth, config.min_distance_m - 1e-9) << t.position.transpose();
    double planar = std::numeric_limits<double>::infinity(), nearest = planar;
    for (const Vector3& p : view) {
      planar = std::min(planar, (p - t.position).head<2>().norm());
      nearest = std::min(nearest, (p - t.position).norm());
    }
    // The label is the middle of the two bounds, which bracket the true distance (the planar one
    // up to the 1 mm height) and lie within max_bound_gap_m of each other.
    EXPECT_NEAR(t.surface_distance_m, 0.5 * (planar + nearest), 1e-12);
    EXPECT_LE(nearest - planar, config.max_bound_gap_m + 1e-12);
    EXPECT_GE(truth, planar - 0.0011);
    EXPECT_LE(truth, nearest + 1e-12);
    EXPECT_GE(planar, config.min_distance_m);
    EXPECT_LT(planar, config.max_distance_m);
    in_front += t.position.x() > kBoxHalfX ? 1 : 0;
    on_the_side += t.position.y() > kBoxHalfY ? 1 : 0;
  }
  // Both sides the camera sees get samples; most of the seen table within the band is taken
  // (the silhouette test is conservative by a pixel or two).
  EXPECT_GT(in_front, 20u);
  EXPECT_GT(on_the_side, 20u);
  std::size_t seen_in_band = 0;
  for (double x = -0.06; x <= 0.06; x += config.spacing_m)
    for (double y = -0.05; y <= 0.05; y += config.spacing_m) {
      const Vector3 q(x, y, config.height_m);
      double planar = std::numeric_limits<double>::infinity();
      for (const Vector3& p : view) planar = std::min(planar, (p - q).head<2>().norm());
      if (planar >= config.min_distance_m + 0.004 && planar < config.max_distance_m && !boxBlocks(kBoxEye, q))
        ++seen_in_band;
    }
  EXPECT_GT(beside.points.size(), seen_in_band * 3 / 4);

  // max_points: an even subset; 0 gives none.
  config.max_points = 10;
  EXPECT_EQ(sampleSupportFreeSpace(view, kBoxEye, table, config).points.size(), 10u);
  config.max_points = 0;
  const ViewSamples none = sampleSupportFreeSpace(view, kBoxEye, table, config);
  EXPECT_TRUE(none.ok && none.points.empty());
}

// Where f first turns positive along the table (at height z) from the box's centre outwards in
// direction `d`: the predicted extent of the box there.
double predictedExtent(const SurfaceModel& model, const Vector3& d, double z) {
  for (double r = 0.0; r < 0.08; r += 0.0005)
    if (model.mean(Vector3(0.0, 0.0, z) + r * d) > 0.0) return r;
  return std::numeric_limits<double>::infinity();
}

TEST(SupportFreeSpace, KeepsALowObjectFromSpreadingOverTheTable) {
  const std::vector<Vector3> view = visibleBoxView();
  const SupportPlane table;
  ViewTrainingConfig with_config;
  ViewTrainingConfig without_config = with_config;
  without_config.support_free_space.max_points = 0;
  const ViewTraining with = buildViewTraining(view, kBoxEye, table, with_config, 1);
  const ViewTraining without = buildViewTraining(view, kBoxEye, table, without_config, 1);
  ASSERT_TRUE(with.ok && without.ok);
  ASSERT_GT(with.support_free_space, 50u);
  MultiscaleGpisModel aware, unaware;
  ASSERT_TRUE(aware.fit(with.points).ok);
  ASSERT_TRUE(unaware.fit(without.points).ok);
  // At 2 mm, in the band segmentation removed, in 16 directions from the box's centre. The -y
  // side (directions 10-14) is hidden from the camera, but the table beyond it is not; behind the
  // -x side the box hides the table too (nothing to learn there); +x and +y are seen.
  double hidden_aware = 0.0, hidden_unaware = 0.0;
  for (int k = 0; k < 16; ++k) {
    const double a = 2.0 * M_PI * k / 16;
    const Vector3 d(std::cos(a), std::sin(a), 0.0);
    const double truth = std::min(kBoxHalfX / std::max(std::abs(d.x()), 1e-12), kBoxHalfY / std::max(std::abs(d.y()), 1e-12));
    const double aware_error = std::abs(predictedExtent(aware, d, 0.002) - truth);
    const double unaware_error = std::abs(predictedExtent(unaware, d, 0.002) - truth);
    EXPECT_LE(aware_error, unaware_error + 0.0005) << "direction " << k;  // nowhere worse
    if (k <= 6) EXPECT_LE(aware_error, 0.001) << "direction " << k;         // the seen sides
    if (k >= 10 && k <= 14) {
      hidden_aware += aware_error / 5;
      hidden_unaware += unaware_error / 5;
    }
  }
  EXPECT_LT(hidden_aware, 0.004);
  EXPECT_LT(hidden_aware, 0.7 * hidden_unaware) << hidden_aware << " against " << hidden_unaware;
}

TEST(SupportFreeSpace, BadInputIsRefusedWithAReason) {
  const std::vector<Vector3> view = visibleBoxView();
  const SupportPlane table;
  SupportFreeSpaceConfig config;
  const ViewSamples below = sampleSupportFreeSpace(view, Vector3(0.3, 0.0, -0.1), table, config);
  EXPECT_FALSE(below.ok);
  EXPECT_NE(below.message.find("not above"), std::string::npos);
  EXPECT_FALSE(sampleSupportFreeSpace(view, Vector3::Constant(std::nan("")), table, config).ok);
  EXPECT_FALSE(sampleSupportFreeSpace({Vector3::Zero(), Vector3::UnitX()}, kBoxEye, table, config).ok);
  std::vector<Vector3> with_nan = view;
  with_nan.push_back(Vector3::Constant(std::nan("")));
  EXPECT_TRUE(sampleSupportFreeSpace(with_nan, kBoxEye, table, config).ok);
  config.min_distance_m = config.max_distance_m;
  const ViewSamples bad = sampleSupportFreeSpace(view, kBoxEye, table, config);
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.message.find("invalid"), std::string::npos);
}

TEST(SupportPlane, PutsTheUnseenBottomOfABallOnTheTable) {
  const Vector3 lift(0.0, 0.0, kRadius);  // the ball rests on z = 0
  std::vector<Vector3> view;
  for (const auto& p : visibleBallFront(1500, 14))
    if (p.z() > -0.8 * kRadius) view.push_back(p + lift);  // the table hides the lowest band
  const Vector3 eye = kSideEye + lift;
  std::vector<TrainingPoint> data = surfaceData(view, 4);
  const auto free = sampleViewFreeSpace(view, eye, kSeed);
  auto inside = sampleOccludedInterior(view, eye, kSeed);
  ASSERT_TRUE(free.ok && inside.ok);
  data.insert(data.end(), free.points.begin(), free.points.end());
  auto without_plane = data;
  without_plane.insert(without_plane.end(), inside.points.begin(), inside.points.end());

  const SupportPlane table;
  dropNearOrBelowPlane(&inside.points, table, 0.005);
  const auto below = sampleBelowSupport(view, table);
  ASSERT_TRUE(below.ok) << below.message;
  auto with_plane = data;
  with_plane.insert(with_plane.end(), inside.points.begin(), inside.points.end());
  with_plane.insert(with_plane.end(), below.points.begin(), below.points.end());

  GpisModel unaware, aware;
  ASSERT_TRUE(unaware.fit(without_plane).ok);
  ASSERT_TRUE(aware.fit(with_plane).ok);
  // 1 cm above the ball's lowest point: inside the ball (the truth).
  const Vector3 low_inside(0.0, 0.0, 0.01);
  EXPECT_LT(aware.mean(low_inside), 0.0);
  EXPECT_GT(unaware.mean(low_inside), aware.mean(low_inside) + 0.05);
  // Under the table top, everywhere under the ball: outside.
  for (double x = -0.08; x <= 0.08 + 1e-9; x += 0.02)
    for (double y = -0.08; y <= 0.08 + 1e-9; y += 0.02) EXPECT_GT(aware.mean(Vector3(x, y, -0.015)), 0.0);
  // The ball's visible surface stays on the zero level set, its centre inside.
  for (std::size_t i = 0; i < view.size(); i += 50) EXPECT_NEAR(aware.mean(view[i]), 0.0, 0.05);
  EXPECT_LT(aware.mean(lift), -0.05);
}

}  // namespace
}  // namespace gpatlas_core
