#include "gpatlas_core/model/multiscale_gpis_model.h"
#include "gpatlas_core/model/occupancy_grid.h"
#include "gpatlas_core/model/surface_model_factory.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <algorithm>
#include <functional>
#include <iostream>
#include <map>
#include <random>
#include <set>
#include <thread>
#include <tuple>

using gpatlas_core::BatchPrediction;
using gpatlas_core::FitReport;
using gpatlas_core::GpisModel;
using gpatlas_core::MultiscaleGpisConfig;
using gpatlas_core::MultiscaleGpisModel;
using gpatlas_core::Points3;
using gpatlas_core::PointLabel;
using gpatlas_core::PointSource;
using gpatlas_core::SurfaceModel;
using gpatlas_core::TrainingPoint;
using Eigen::Vector3d;

namespace {

// Noise sigma of the test data in the coarse GPIS's reference units (as in test_gpis_model);
// the fine level uses its own metric noise.
constexpr double kNoise = 0.05;

TrainingPoint surfacePoint(const Vector3d& x, PointSource source = PointSource::kVision) {
  TrainingPoint p;
  p.position = x;
  p.noise_sigma = kNoise;
  p.source = source;
  return p;
}

// Free space seen by the camera (view_free_space's source) unless a probe's approach says so.
TrainingPoint freeSpacePoint(const Vector3d& x, double distance, PointSource source = PointSource::kVision) {
  TrainingPoint p;
  p.position = x;
  p.label = PointLabel::kOutside;
  p.surface_distance_m = distance;
  p.noise_sigma = kNoise;
  p.source = source;
  return p;
}

// ---- analytic sphere, seen from above (outward normals with z >= 0)
const Vector3d kSphereCentre(0.31, -0.04, 0.11);
constexpr double kSphereRadius = 0.05;

std::vector<Vector3d> fibonacciDirections(int count) {
  std::vector<Vector3d> dirs;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / count;
    const double rho = std::sqrt(1.0 - z * z);
    dirs.emplace_back(rho * std::cos(golden * i), rho * std::sin(golden * i), z);
  }
  return dirs;
}

// ~3500 surface points at ~2.1 mm spacing on the upper hemisphere, and free space 2 and 4 mm
// out along the normal at every third of them.
std::vector<TrainingPoint> sphereView() {
  std::vector<TrainingPoint> points;
  int k = 0;
  for (const Vector3d& d : fibonacciDirections(7000)) {
    if (d.z() < 0.0) continue;
    points.push_back(surfacePoint(kSphereCentre + kSphereRadius * d));
    if (k++ % 3 == 0)
      for (double offset : {0.002, 0.004}) points.push_back(freeSpacePoint(kSphereCentre + (kSphereRadius + offset) * d, offset));
  }
  return points;
}

std::vector<Vector3d> randomDirections(int count, double min_z, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<Vector3d> dirs;
  while (static_cast<int>(dirs.size()) < count) {
    Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    if (d.z() >= min_z) dirs.push_back(d);
  }
  return dirs;
}

// The first zero crossing of the mean along a -> b (sampled, then bisected); NaN when none.
double zeroCrossing(const SurfaceModel& model, const Vector3d& a, const Vector3d& b) {
  constexpr int kSamples = 200;
  Points3 x(3, kSamples + 1);
  for (int i = 0; i <= kSamples; ++i) x.col(i) = a + (b - a) * (static_cast<double>(i) / kSamples);
  const Eigen::VectorXd f = model.predictBatch(x, false, false, false).mean;
  for (int i = 0; i < kSamples; ++i) {
    if ((f[i] < 0.0) == (f[i + 1] < 0.0)) continue;
    double lo = static_cast<double>(i) / kSamples, hi = static_cast<double>(i + 1) / kSamples;
    const bool lo_negative = f[i] < 0.0;
    for (int it = 0; it < 40; ++it) {
      const double mid = 0.5 * (lo + hi);
      if ((model.mean(a + (b - a) * mid) < 0.0) == lo_negative) lo = mid;
      else hi = mid;
    }
    return 0.5 * (lo + hi) * (b - a).norm();
  }
  return std::numeric_limits<double>::quiet_NaN();
}

int countZeroCrossings(const SurfaceModel& model, const Vector3d& a, const Vector3d& b) {
  constexpr int kSamples = 400;
  Points3 x(3, kSamples + 1);
  for (int i = 0; i <= kSamples; ++i) x.col(i) = a + (b - a) * (static_cast<double>(i) / kSamples);
  const Eigen::VectorXd f = model.predictBatch(x, false, false, false).mean;
  int crossings = 0;
  for (int i = 0; i < kSamples; ++i) crossings += (f[i] < 0.0) != (f[i + 1] < 0.0) ? 1 : 0;
  return crossings;
}

MultiscaleGpisModel fitted(const std::vector<TrainingPoint>& points, MultiscaleGpisConfig config = {}) {
  MultiscaleGpisModel model(config);
  const FitReport report = model.fit(points);
  EXPECT_TRUE(report.ok) << report.message;
  return model;
}

const MultiscaleGpisModel& sphereModel() {
  static const MultiscaleGpisModel model = fitted(sphereView());
  return model;
}

TEST(MultiscaleGpisModel, SphereSurfaceWithinAMillimetreOnTheObservedSide) {
  const MultiscaleGpisModel& model = sphereModel();
  ASSERT_TRUE(model.isFitted());
  EXPECT_EQ(model.name(), "multiscale");
  EXPECT_GT(model.numCells(), 20u);
  std::cout << "sphere: " << model.observations().size() << " observations, " << model.numCells() << " cells, "
            << model.coarseModel().observations().size() << " in the coarse GPIS; " << model.fineTuneReport().message
            << "\n";

  // Held-out surface points (random, not the lattice's): |f| in metres via the frame's scale.
  double sum_abs = 0.0;
  const auto held_out = randomDirections(200, 0.15, 7);
  for (const Vector3d& d : held_out) sum_abs += std::abs(model.mean(kSphereCentre + kSphereRadius * d));
  const double mean_abs_m = sum_abs / held_out.size() * model.scale();
  std::cout << "sphere: mean |f| at held-out surface points = " << mean_abs_m * 1e3 << " mm (x scale)\n";
  EXPECT_LT(mean_abs_m, 0.0003);

  double worst = 0.0;
  for (const Vector3d& d : randomDirections(60, 0.2, 8)) {
    const double root = zeroCrossing(model, kSphereCentre + 0.035 * d, kSphereCentre + 0.065 * d);
    ASSERT_TRUE(std::isfinite(root));
    worst = std::max(worst, std::abs(0.035 + root - kSphereRadius));
    EXPECT_LT(model.mean(kSphereCentre + 0.045 * d), 0.0);
    EXPECT_GT(model.mean(kSphereCentre + 0.055 * d), 0.0);
  }
  double coarse_sum_abs = 0.0;
  for (const Vector3d& d : held_out) coarse_sum_abs += std::abs(model.coarseModel().mean(kSphereCentre + kSphereRadius * d));
  std::cout << "sphere: worst radial zero-crossing error = " << worst * 1e3 << " mm; the coarse GPIS alone: mean |f| "
            << coarse_sum_abs / held_out.size() * model.scale() * 1e3 << " mm (x scale)\n";
  EXPECT_LT(sum_abs, coarse_sum_abs) << "the fine level must improve on the coarse one where data are dense";
  EXPECT_LT(worst, 0.001);
  EXPECT_LT(model.mean(kSphereCentre), 0.0);
  EXPECT_GT(model.mean(kSphereCentre + Vector3d(0.0, 0.0, 0.08)), 0.0);
}

// ---- box 4 x 6 x 8 cm, faces +x, +y, +z seen
const Vector3d kBoxCentre(0.42, 0.07, 0.06);
const Vector3d kBoxHalf(0.02, 0.03, 0.04);

std::vector<TrainingPoint> boxView() {
  std::vector<TrainingPoint> points;
  constexpr double step = 0.002;
  int k = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    const int nu = static_cast<int>(std::round(2.0 * kBoxHalf[u] / step)), nv = static_cast<int>(std::round(2.0 * kBoxHalf[v] / step));
    for (int i = 0; i <= nu; ++i)
      for (int j = 0; j <= nv; ++j) {
        Vector3d x = kBoxCentre;
        x[axis] += kBoxHalf[axis];
        x[u] += -kBoxHalf[u] + i * step;
        x[v] += -kBoxHalf[v] + j * step;
        // The edges and corner belong to several faces: sample them once.
        bool duplicate = false;
        for (int other = 0; other < axis; ++other) duplicate = duplicate || std::abs(x[other] - kBoxCentre[other] - kBoxHalf[other]) < 1e-9;
        if (duplicate) continue;
        points.push_back(surfacePoint(x));
        if (k++ % 2 == 0)
          for (double offset : {0.002, 0.004}) {
            Vector3d out = x;
            out[axis] += offset;
            points.push_back(freeSpacePoint(out, offset));
          }
      }
  }
  return points;
}

TEST(MultiscaleGpisModel, BoxFacesAndEdges) {
  const MultiscaleGpisModel model = fitted(boxView());
  const Vector3d top = kBoxCentre + Vector3d(0.0, 0.0, kBoxHalf.z());
  // Face centres of +z and +x, along their normals.
  const double face = zeroCrossing(model, top - Vector3d(0, 0, 0.01), top + Vector3d(0, 0, 0.01)) - 0.01;
  const Vector3d side = kBoxCentre + Vector3d(kBoxHalf.x(), 0.005, -0.01);
  const double face_x = zeroCrossing(model, side - Vector3d(0.01, 0, 0), side + Vector3d(0.01, 0, 0)) - 0.01;
  // 3 mm from the edge between the +x and +z faces, along +z.
  const Vector3d near_edge = kBoxCentre + Vector3d(kBoxHalf.x() - 0.003, -0.004, kBoxHalf.z());
  const double edge = zeroCrossing(model, near_edge - Vector3d(0, 0, 0.01), near_edge + Vector3d(0, 0, 0.01)) - 0.01;
  std::cout << "box: face errors " << face * 1e3 << ", " << face_x * 1e3 << " mm, near-edge error " << edge * 1e3
            << " mm\n";
  EXPECT_LT(std::abs(face), 0.001);
  EXPECT_LT(std::abs(face_x), 0.001);
  EXPECT_LT(std::abs(edge), 0.002);
  EXPECT_LT(model.mean(kBoxCentre + Vector3d(0.015, 0.02, 0.035)), 0.0);  // 5 mm inside the corner
  EXPECT_GT(model.mean(kBoxCentre + Vector3d(0.025, 0.0, 0.0)), 0.0);     // 5 mm out of +x
}

// ---- thin plate: 8 x 8 cm, 5 mm thick, both faces seen
const Vector3d kPlateCentre(0.5, -0.2, 0.15);
constexpr double kPlateHalfThickness = 0.0025;

// Both faces of a square plate of side 2 * half_side_m sampled at 2 mm, free space 2 and 5 mm
// off every other sample.
std::vector<TrainingPoint> plateData(double half_side_m = 0.04) {
  std::vector<TrainingPoint> points;
  int k = 0;
  const int n = static_cast<int>(std::round(2.0 * half_side_m / 0.002));
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j)
      for (double side : {-1.0, 1.0}) {
        const Vector3d x = kPlateCentre + Vector3d(-half_side_m + 0.002 * i, -half_side_m + 0.002 * j, side * kPlateHalfThickness);
        points.push_back(surfacePoint(x));
        if (k++ % 2 == 0)
          for (double offset : {0.002, 0.005}) points.push_back(freeSpacePoint(x + Vector3d(0, 0, side * offset), offset));
      }
  return points;
}

TEST(MultiscaleGpisModel, ThinPlateHasTwoFacesFiveMillimetresApart) {
  const MultiscaleGpisModel model = fitted(plateData());
  std::cout << "plate: " << model.fineTuneReport().message << "\n";
  for (const Vector3d& offset : {Vector3d(0.0013, 0.0007, 0.0), Vector3d(-0.0171, 0.0123, 0.0), Vector3d(0.021, -0.03, 0.0)}) {
    const Vector3d mid = kPlateCentre + offset;
    const Vector3d normal(0, 0, 1);
    EXPECT_LT(model.mean(mid), 0.0) << "mid-plane at " << offset.transpose();
    EXPECT_GT(model.mean(mid + (kPlateHalfThickness + 0.004) * normal), 0.0);
    EXPECT_GT(model.mean(mid - (kPlateHalfThickness + 0.004) * normal), 0.0);
    const double upper = zeroCrossing(model, mid, mid + 0.01 * normal);
    const double lower = zeroCrossing(model, mid, mid - 0.01 * normal);
    std::cout << "plate at " << offset.transpose() * 1e3 << " mm: faces at +" << upper * 1e3 << " / -" << lower * 1e3
              << " mm (truth 2.5)\n";
    EXPECT_NEAR(upper, kPlateHalfThickness, 0.001);
    EXPECT_NEAR(lower, kPlateHalfThickness, 0.001);
  }
  // The global GPIS alone (the coarse level, at its 1,200-point cap) cannot hold the plate's
  // thickness: along the normal it finds no interior at all, or not the two faces.
  const GpisModel& global = model.coarseModel();
  const Vector3d mid = kPlateCentre + Vector3d(0.0013, 0.0007, 0.0);
  const int global_crossings = countZeroCrossings(global, mid - Vector3d(0, 0, 0.0065), mid + Vector3d(0, 0, 0.0065));
  std::cout << "plate: the global GPIS has " << global_crossings << " zero crossing(s) across the plate, f(mid) = "
            << global.mean(mid) << ", faces at +" << zeroCrossing(global, mid, mid + Vector3d(0, 0, 0.01)) * 1e3 << " / -"
            << zeroCrossing(global, mid, mid - Vector3d(0, 0, 0.01)) * 1e3 << " mm\n";
  EXPECT_EQ(countZeroCrossings(model, mid - Vector3d(0, 0, 0.0065), mid + Vector3d(0, 0, 0.0065)), 2);
}

// A 5 mm plate 24 cm wide: the coarse level's 1,200 points are ~1 cm apart, twice the thickness.
TEST(MultiscaleGpisModel, WidePlateKeepsItsThickness) {
  const std::vector<TrainingPoint> data = plateData(0.12);
  const auto t0 = std::chrono::steady_clock::now();
  const MultiscaleGpisModel model = fitted(data);
  std::cout << "wide plate: " << data.size() << " observations fitted in "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() << " s\n";
  const GpisModel& global = model.coarseModel();
  for (const Vector3d& offset : {Vector3d(0.0013, 0.0007, 0.0), Vector3d(-0.061, 0.043, 0.0), Vector3d(0.09, -0.1, 0.0)}) {
    const Vector3d mid = kPlateCentre + offset, normal(0, 0, 1);
    const double upper = zeroCrossing(model, mid, mid + 0.01 * normal), lower = zeroCrossing(model, mid, mid - 0.01 * normal);
    std::cout << "wide plate at " << offset.transpose() * 1e3 << " mm: faces at +" << upper * 1e3 << " / -" << lower * 1e3
              << " mm; the global GPIS: " << countZeroCrossings(global, mid - 0.0065 * normal, mid + 0.0065 * normal)
              << " crossing(s), f(mid) " << global.mean(mid) << ", faces at +" << zeroCrossing(global, mid, mid + 0.01 * normal) * 1e3
              << " / -" << zeroCrossing(global, mid, mid - 0.01 * normal) * 1e3 << " mm\n";
    EXPECT_LT(model.mean(mid), 0.0);
    EXPECT_NEAR(upper, kPlateHalfThickness, 0.001);
    EXPECT_NEAR(lower, kPlateHalfThickness, 0.001);
    // Why the model exists: the global GPIS on the thinned data (what GpisModel can afford) does
    // not hold the faces where they are.
    const double global_upper = zeroCrossing(global, mid, mid + 0.01 * normal);
    const double global_lower = zeroCrossing(global, mid, mid - 0.01 * normal);
    EXPECT_FALSE(std::abs(global_upper - kPlateHalfThickness) < 0.001 && std::abs(global_lower - kPlateHalfThickness) < 0.001)
        << "the global GPIS alone holds the plate";
  }
}

// ---- a mug's handle: a torus of tube radius 4 mm around a 3 cm circle, seen all round
const Vector3d kTorusCentre(0.2, 0.1, 0.2);
constexpr double kTorusMajor = 0.03, kTorusMinor = 0.004;

Vector3d torusPoint(double phi, double theta, double radius) {
  const Vector3d ring(std::cos(phi), std::sin(phi), 0.0);
  return kTorusCentre + kTorusMajor * ring + radius * (std::cos(theta) * ring + std::sin(theta) * Vector3d::UnitZ());
}

std::vector<TrainingPoint> torusData() {
  std::vector<TrainingPoint> points;
  const int n_phi = static_cast<int>(2 * M_PI * kTorusMajor / 0.002), n_theta = static_cast<int>(2 * M_PI * kTorusMinor / 0.002);
  for (int i = 0; i < n_phi; ++i)
    for (int j = 0; j < n_theta; ++j) {
      const double phi = 2 * M_PI * i / n_phi, theta = 2 * M_PI * j / n_theta;
      points.push_back(surfacePoint(torusPoint(phi, theta, kTorusMinor)));
      for (double offset : {0.002, 0.004}) points.push_back(freeSpacePoint(torusPoint(phi, theta, kTorusMinor + offset), offset));
    }
  return points;
}

TEST(MultiscaleGpisModel, HandleTubeKeepsItsEightMillimetreDiameter) {
  const MultiscaleGpisModel model = fitted(torusData());
  const GpisModel& global = model.coarseModel();
  double worst = 0.0, global_worst = 0.0;
  for (double phi : {0.3, 1.7, 2.9, 4.4}) {
    for (double theta : {0.0, M_PI / 2, M_PI / 4}) {
      // Across the tube through its axis: faces at -4 and +4 mm.
      const Vector3d axis = torusPoint(phi, 0.0, 0.0);
      const Vector3d dir = (torusPoint(phi, theta, 1.0) - axis).normalized();
      const Vector3d a = axis - 0.008 * dir, b = axis + 0.008 * dir;
      EXPECT_LT(model.mean(axis), 0.0);
      const double first = zeroCrossing(model, a, b), second = 0.016 - zeroCrossing(model, b, a);
      worst = std::max({worst, std::abs(first - 0.004), std::abs(second - 0.012)});
      const double g_first = zeroCrossing(global, a, b), g_second = 0.016 - zeroCrossing(global, b, a);
      global_worst = std::max({global_worst, std::isfinite(g_first) ? std::abs(g_first - 0.004) : 1.0,
                               std::isfinite(g_second) ? std::abs(g_second - 0.012) : 1.0});
    }
  }
  std::cout << "handle: worst face error across the tube " << worst * 1e3 << " mm (the global GPIS: "
            << global_worst * 1e3 << " mm, f on the tube's axis " << global.mean(torusPoint(0.3, 0.0, 0.0)) << ")\n";
  EXPECT_LT(worst, 0.001);
}

// Points near the sphere's surface that lie in the overlap of cells along x and y (within the
// overlap of a cell face), where the blend of several cells and its weights' gradients matter.
std::vector<Vector3d> overlapPoints(const MultiscaleGpisModel& model, int count) {
  const double s = model.config().cell_size_m, overlap = model.config().overlap_m;
  const auto nearFace = [&](double c) {
    const double u = c / s - std::floor(c / s);  // position in the cell, 0..1
    return std::min(u, 1.0 - u) * s < overlap;
  };
  std::vector<Vector3d> points;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> radius(0.047, 0.053);
  for (const Vector3d& d : randomDirections(5000, 0.2, 12)) {
    const Vector3d x = kSphereCentre + radius(rng) * d;
    if (nearFace(x.x()) && nearFace(x.y())) points.push_back(x);
    if (static_cast<int>(points.size()) == count) break;
  }
  return points;
}

TEST(MultiscaleGpisModel, GradientsMatchFiniteDifferencesInOverlaps) {
  const MultiscaleGpisModel& model = sphereModel();
  const auto points = overlapPoints(model, 25);
  ASSERT_EQ(points.size(), 25u);
  constexpr double h = 1e-6;
  for (const Vector3d& x : points) {
    const auto p = model.predict(x);
    Vector3d mean_fd, var_fd;
    for (int d = 0; d < 3; ++d) {
      const Vector3d e = Vector3d::Unit(d) * h;
      mean_fd[d] = (model.mean(x + e) - model.mean(x - e)) / (2 * h);
      var_fd[d] = (model.variance(x + e) - model.variance(x - e)) / (2 * h);
    }
    EXPECT_LT((p.gradient - mean_fd).norm(), 1e-5 * mean_fd.norm() + 1e-6) << x.transpose();
    EXPECT_LT((p.variance_gradient - var_fd).norm(), 1e-4 * var_fd.norm() + 1e-7) << x.transpose();
  }
  // The batch honours its flags: the same numbers with and without the optional parts.
  Points3 q(3, static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) q.col(static_cast<Eigen::Index>(i)) = points[i];
  const BatchPrediction full = model.predictBatch(q, true, true, true);
  const BatchPrediction mean_only = model.predictBatch(q, false, false, false);
  EXPECT_TRUE(mean_only.variance.array().isNaN().all());
  EXPECT_LT((full.mean - mean_only.mean).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((full.variance - model.predictBatch(q, false, false, true).variance).cwiseAbs().maxCoeff(), 1e-12);
}

// A slide's contacts 2.5 mm apart, each with two slopes across its normal: the cells take them
// all, the coarse level one contact per 1 cm voxel (coarse_probe_voxel_m) with its slopes, the
// voxels counted here anew; an update gives what a fit from scratch gives.
TEST(MultiscaleGpisModel, ASlidesDenseContactsReachTheCoarseLevelOnePerVoxel) {
  MultiscaleGpisConfig config;
  MultiscaleGpisModel model = fitted(sphereView(), config);
  std::vector<TrainingPoint> slide;
  std::vector<Vector3d> contacts;
  for (int k = 0; k < 30; ++k) {
    const double angle = 0.3 + 0.05 * k;  // 2.5 mm steps along a meridian of the 5 cm sphere
    const Vector3d d(std::sin(angle), 0.0, -std::cos(angle));
    contacts.push_back(kSphereCentre + kSphereRadius * d);
    slide.push_back(surfacePoint(contacts.back(), PointSource::kTouch));
  }
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const Vector3d n = (contacts[k] - kSphereCentre).normalized();
    for (const Vector3d& t : {Vector3d(n.unitOrthogonal()), Vector3d(n.cross(n.unitOrthogonal()))}) {
      TrainingPoint slope = surfacePoint(contacts[k], PointSource::kTouch);
      slope.slope_direction = t;
      slope.target_override = 0.0;
      slide.push_back(slope);
    }
  }
  const FitReport report = model.addPoints(slide);
  ASSERT_TRUE(report.ok) << report.message;
  EXPECT_FALSE(report.full_refit);
  std::set<std::tuple<int, int, int>> voxels;
  for (const Vector3d& c : contacts) {
    const Eigen::Vector3i v = (c / config.coarse_probe_voxel_m).array().floor().cast<int>();
    voxels.insert({v.x(), v.y(), v.z()});
  }
  int all = 0, coarse_contacts = 0, coarse_slopes = 0;
  for (const TrainingPoint& p : model.observations()) all += p.source == PointSource::kTouch && !observesSlope(p);
  std::vector<Vector3d> kept;
  for (const TrainingPoint& p : model.coarseModel().observations())
    if (p.source == PointSource::kTouch && !observesSlope(p)) {
      ++coarse_contacts;
      kept.push_back(p.position);
    }
  for (const TrainingPoint& p : model.coarseModel().observations())
    if (observesSlope(p)) {
      ++coarse_slopes;
      EXPECT_TRUE(std::any_of(kept.begin(), kept.end(), [&](const Vector3d& c) { return c == p.position; }))
          << "a slope whose contact the coarse level does not hold";
    }
  EXPECT_EQ(all, 30);
  EXPECT_EQ(coarse_contacts, static_cast<int>(voxels.size()));
  EXPECT_LT(coarse_contacts, 15);
  EXPECT_EQ(coarse_slopes, 2 * coarse_contacts);
  MultiscaleGpisModel scratch(config);
  ASSERT_TRUE(scratch.restore(model.state()).ok);
  for (const Vector3d& c : contacts) {
    const Vector3d x = c + 0.004 * (c - kSphereCentre).normalized();
    EXPECT_NEAR(scratch.mean(x), model.mean(x), 1e-9);
    EXPECT_NEAR(scratch.variance(x), model.variance(x), 1e-9);
  }
}

TEST(MultiscaleGpisModel, IncrementalContactsAndFreeSpaceEqualAFitFromScratch) {
  // The view's far free space (beyond the fine level's overlap: the coarse level's) at its cap,
  // so that more of it changes which of it the coarse level keeps.
  MultiscaleGpisConfig config;
  config.coarse_max_other_points = 20;
  std::vector<TrainingPoint> view = sphereView();
  for (const Vector3d& d : randomDirections(30, 0.0, 25))
    view.push_back(freeSpacePoint(kSphereCentre + (kSphereRadius + 0.012) * d, 0.012));
  MultiscaleGpisModel incremental = fitted(view, config);
  // Contacts on the unseen lower half (new cells), free space 3 mm out of them (which also
  // changes which free-space points the coarse thinning keeps), and measured normals.
  std::vector<TrainingPoint> first, second;
  const auto dirs = randomDirections(400, -1.0, 21);
  int contacts = 0;
  for (const Vector3d& d : dirs) {
    if (d.z() > -0.2) continue;
    auto& batch = contacts < 30 ? first : second;
    batch.push_back(surfacePoint(kSphereCentre + kSphereRadius * d, PointSource::kTouch));
    batch.push_back(freeSpacePoint(kSphereCentre + (kSphereRadius + 0.003) * d, 0.003, PointSource::kFreeSpace));
    if (contacts % 5 == 0) {
      TrainingPoint slope = surfacePoint(kSphereCentre + kSphereRadius * d, PointSource::kTouch);
      slope.slope_direction = d;
      batch.push_back(slope);
    }
    if (++contacts == 60) break;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const FitReport r1 = incremental.addPoints(first);
  ASSERT_TRUE(r1.ok) << r1.message;
  EXPECT_FALSE(r1.full_refit);
  EXPECT_NE(r1.message.find("coarse extended"), std::string::npos) << r1.message;
  const FitReport r2 = incremental.addPoints(second);
  ASSERT_TRUE(r2.ok) << r2.message;
  EXPECT_FALSE(r2.full_refit);
  std::cout << "incremental: " << r1.message << "\n             " << r2.message << " ("
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() << " s for both)\n";

  // Free space seen by the camera below the sphere: changes the coarse level's thinning of the
  // view's free space, so the coarse level is refitted in its frame.
  std::vector<TrainingPoint> view_free;
  for (const Vector3d& d : randomDirections(40, -1.0, 24))
    if (d.z() < 0.0) {
      view_free.push_back(freeSpacePoint(kSphereCentre + (kSphereRadius + 0.012) * d, 0.012));
    }
  const FitReport r_view = incremental.addPoints(view_free);
  ASSERT_TRUE(r_view.ok) << r_view.message;
  EXPECT_FALSE(r_view.full_refit);
  EXPECT_NE(r_view.message.find("coarse refitted in its frame"), std::string::npos) << r_view.message;
  std::cout << "             " << r_view.message << "\n";

  // Contacts and normals alone.
  std::vector<TrainingPoint> third;
  for (const Vector3d& d : randomDirections(12, -1.0, 23)) {
    if (d.z() > -0.1) continue;
    third.push_back(surfacePoint(kSphereCentre + kSphereRadius * d, PointSource::kTouch));
    third.push_back(third.back());
    third.back().slope_direction = d;
  }
  const FitReport r3 = incremental.addPoints(third);
  ASSERT_TRUE(r3.ok) << r3.message;
  EXPECT_FALSE(r3.full_refit);
  EXPECT_NE(r3.message.find("coarse extended"), std::string::npos) << r3.message;
  std::cout << "             " << r3.message << "\n";

  MultiscaleGpisModel scratch(config);
  const FitReport r = scratch.restore(incremental.state());
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(scratch.numCells(), incremental.numCells());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> radius(0.04, 0.06);
  Points3 q(3, 50);
  const auto query_dirs = randomDirections(50, -1.0, 22);
  for (int j = 0; j < 50; ++j) q.col(j) = kSphereCentre + radius(rng) * query_dirs[static_cast<std::size_t>(j)];
  const BatchPrediction a = incremental.predictBatch(q), b = scratch.predictBatch(q);
  for (int j = 0; j < 50; ++j) {
    EXPECT_NEAR(a.mean[j], b.mean[j], 1e-6 * std::max(1.0, std::abs(b.mean[j])));
    EXPECT_NEAR(a.variance[j], b.variance[j], 1e-6 * std::max(1e-3, std::abs(b.variance[j])));
  }
  // The contacts moved the unseen side onto the sphere.
  for (const TrainingPoint& p : second)
    if (p.label == PointLabel::kSurface && !gpatlas_core::observesSlope(p))
      EXPECT_LT(std::abs(incremental.mean(p.position)) * incremental.scale(), 0.001);
}

// The Explorer refits in the model's own frame when a touch retracts guessed interior: that is
// an update, like addPoints, and keeps the hyperparameters the fit from scratch tuned.
TEST(MultiscaleGpisModel, ARefitInItsOwnFrameKeepsTheTunedHyperparameters) {
  MultiscaleGpisModel model = sphereModel();
  ASSERT_TRUE(model.fineTuneReport().ok) << model.fineTuneReport().message;
  const Eigen::VectorXd tuned = model.hyperparameters();
  // Some of the view's free space dropped, contacts on the unseen lower half appended.
  std::vector<TrainingPoint> data;
  std::size_t dropped = 0;
  for (const TrainingPoint& p : model.observations()) {
    if (p.label == PointLabel::kOutside && dropped < 40 && ++dropped) continue;
    data.push_back(p);
  }
  for (const Vector3d& d : randomDirections(40, -1.0, 31))
    if (d.z() < -0.3) data.push_back(surfacePoint(kSphereCentre + kSphereRadius * d, PointSource::kTouch));
  const FitReport report = model.fitInFrame(data, model.centroid(), model.scale());
  ASSERT_TRUE(report.ok) << report.message;
  EXPECT_EQ(model.hyperparameters(), tuned);

  // The same as a fit of these data in this frame with these hyperparameters, without tuning.
  MultiscaleGpisConfig untuned_config;
  untuned_config.tune_on_fit = false;
  MultiscaleGpisModel reference(untuned_config);
  ASSERT_TRUE(reference.setHyperparameters(tuned).ok);
  ASSERT_TRUE(reference.fitInFrame(data, model.centroid(), model.scale()).ok);
  Points3 q(3, 40);
  const auto query_dirs = randomDirections(40, -1.0, 32);
  for (int j = 0; j < 40; ++j) q.col(j) = kSphereCentre + 1.02 * kSphereRadius * query_dirs[static_cast<std::size_t>(j)];
  const BatchPrediction a = model.predictBatch(q), b = reference.predictBatch(q);
  for (int j = 0; j < 40; ++j) {
    EXPECT_NEAR(a.mean[j], b.mean[j], 1e-8);
    EXPECT_NEAR(a.variance[j], b.variance[j], 1e-8);
  }
}

TEST(MultiscaleGpisModel, TheTableBesideTheObjectIsLeftToTheCells) {
  // A ring of the table seen beside the sphere's equator, 8 mm out (sampleSupportFreeSpace's
  // source): the coarse level does not see it, the cells there do.
  MultiscaleGpisConfig config;
  config.tune_on_fit = false;  // the same hyperparameters with and without the ring
  const std::vector<TrainingPoint> view = sphereView();
  std::vector<TrainingPoint> with_table = view;
  std::vector<Vector3d> ring;
  for (int k = 0; k < 60; ++k) {
    const double a = 2.0 * M_PI * k / 60;
    ring.push_back(kSphereCentre + (kSphereRadius + 0.008) * Vector3d(std::cos(a), std::sin(a), 0.0) -
                   Vector3d(0.0, 0.0, 0.002));
    with_table.push_back(freeSpacePoint(ring.back(), 0.008, PointSource::kViewSupport));
  }
  const MultiscaleGpisModel plain = fitted(view, config);
  const MultiscaleGpisModel model = fitted(with_table, config);
  for (const TrainingPoint& p : model.coarseModel().observations()) EXPECT_NE(p.source, PointSource::kViewSupport);
  ASSERT_EQ(model.coarseModel().observations().size(), plain.coarseModel().observations().size());
  double changed = 0.0;
  for (const Vector3d& x : ring) {
    EXPECT_NEAR(model.coarseModel().mean(x), plain.coarseModel().mean(x), 1e-12);
    changed = std::max(changed, std::abs(model.mean(x) - plain.mean(x)));
  }
  EXPECT_GT(changed, 1e-4);
  // The ring's points are training data of the model (a replica must get them).
  std::size_t kept = 0;
  for (const TrainingPoint& p : model.observations()) kept += p.source == PointSource::kViewSupport ? 1 : 0;
  EXPECT_EQ(kept, ring.size());
}

TEST(MultiscaleGpisModel, TuningImprovesTheLocalLikelihoodWithinBounds) {
  MultiscaleGpisConfig untuned_config;
  untuned_config.tune_on_fit = false;
  const MultiscaleGpisModel untuned = fitted(sphereView(), untuned_config);
  const MultiscaleGpisModel& tuned = sphereModel();
  const double before = untuned.fineLogMarginalLikelihood();
  const double after = tuned.fineLogMarginalLikelihood();
  std::cout << "tuning: summed local log likelihood " << before << " -> " << after << " ("
            << tuned.fineTuneReport().message << ", " << tuned.fineTuneReport().seconds << " s)\n";
  ASSERT_TRUE(tuned.fineTuneReport().ok) << tuned.fineTuneReport().message;
  EXPECT_GT(after, before + 1.0);
  EXPECT_NEAR(tuned.fineTuneReport().log_likelihood_before, before, 1e-6 * std::abs(before));
  const Eigen::VectorXd params = tuned.hyperparameters().tail(3).array().exp();
  const MultiscaleGpisConfig& c = tuned.config();
  EXPECT_GE(params[0], c.sigma_min);
  EXPECT_LE(params[0], c.sigma_max);
  EXPECT_GE(params[1], c.length_min_m);
  EXPECT_LE(params[1], c.overlap_m);
  EXPECT_GE(params[2], c.noise_min_m);
  EXPECT_LE(params[2], c.noise_max_m);
  // The analytic gradient the tuner follows, against finite differences.
  const Eigen::Vector3d theta = untuned.hyperparameters().tail(3);
  Eigen::Vector3d gradient;
  untuned.fineLogMarginalLikelihood(theta, &gradient);
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(i) * 1e-5;
    const double fd =
        (untuned.fineLogMarginalLikelihood(theta + e) - untuned.fineLogMarginalLikelihood(theta - e)) / 2e-5;
    EXPECT_NEAR(gradient[i], fd, 1e-4 * std::abs(fd) + 1e-3) << "parameter " << i;
  }
}

TEST(MultiscaleGpisModel, RestoreCloneAndFactory) {
  const MultiscaleGpisModel& model = sphereModel();
  gpatlas_core::SurfaceModelConfig config;
  config.type = "multiscale";
  std::unique_ptr<SurfaceModel> replica = gpatlas_core::makeSurfaceModel(config);
  ASSERT_EQ(replica->name(), "multiscale");
  const FitReport r = replica->restore(model.state());
  ASSERT_TRUE(r.ok) << r.message;
  const std::unique_ptr<SurfaceModel> copy = model.clone();
  const auto dirs = randomDirections(30, -1.0, 31);
  Points3 q(3, 30);
  for (int j = 0; j < 30; ++j) q.col(j) = kSphereCentre + 0.05 * dirs[static_cast<std::size_t>(j)] * (0.9 + 0.007 * j);
  const BatchPrediction a = model.predictBatch(q), b = replica->predictBatch(q), c = copy->predictBatch(q);
  for (int j = 0; j < 30; ++j) {
    EXPECT_EQ(a.mean[j], b.mean[j]);
    EXPECT_EQ(a.variance[j], b.variance[j]);
    EXPECT_EQ(a.mean[j], c.mean[j]);
    EXPECT_EQ(a.gradient.col(j), b.gradient.col(j));
  }
  EXPECT_EQ(replica->hyperparameters(), model.hyperparameters());
  EXPECT_EQ(replica->hyperparameterNames().size(), static_cast<std::size_t>(model.hyperparameters().size()));
  // A state of another model, or of the wrong size, is refused and leaves the replica as it was.
  const double before = replica->mean(q.col(0));
  auto bad = model.state();
  bad.hyperparameters.pop_back();
  EXPECT_FALSE(replica->restore(bad).ok);
  bad = model.state();
  bad.model = "gpis";
  EXPECT_FALSE(replica->restore(bad).ok);
  EXPECT_EQ(replica->mean(q.col(0)), before);
}

TEST(MultiscaleGpisModel, ConcurrentQueriesAgreeWithSerialOnes) {
  const MultiscaleGpisModel& model = sphereModel();
  Points3 q(3, 200);
  const auto dirs = randomDirections(200, -1.0, 51);
  for (int j = 0; j < 200; ++j) q.col(j) = kSphereCentre + (0.045 + 0.00005 * j) * dirs[static_cast<std::size_t>(j)];
  const BatchPrediction serial = model.predictBatch(q);
  std::vector<BatchPrediction> results(4);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < results.size(); ++t)
    threads.emplace_back([&, t] { results[t] = model.predictBatch(q); });
  for (std::thread& t : threads) t.join();
  for (const BatchPrediction& r : results) {
    EXPECT_EQ(r.mean, serial.mean);
    EXPECT_EQ(r.variance, serial.variance);
    EXPECT_EQ(r.gradient, serial.gradient);
  }
}

TEST(MultiscaleGpisModel, FailedFitLeavesTheModelUnchanged) {
  MultiscaleGpisModel model = sphereModel();
  const double before = model.mean(kSphereCentre);
  EXPECT_FALSE(model.fit({surfacePoint(kSphereCentre)}).ok);
  EXPECT_EQ(model.mean(kSphereCentre), before);
  EXPECT_THROW(MultiscaleGpisModel().mean(kSphereCentre), std::logic_error);
}

TEST(MultiscaleGpisModel, FitsTenThousandViewPoints) {
  // A 10 cm sphere seen from above and the side, random points (~2.9 mm apart).
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  std::vector<TrainingPoint> points;
  const Vector3d centre(0.7, 0.0, 0.1);
  while (points.size() < 10000) {
    Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    if (d.z() < -0.3) continue;
    points.push_back(surfacePoint(centre + 0.1 * d));
  }
  MultiscaleGpisModel model;
  const auto t0 = std::chrono::steady_clock::now();
  const FitReport r = model.fit(points);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(r.ok) << r.message;
  std::cout << "10,000 view points: fit in " << seconds << " s (" << model.numCells() << " cells; "
            << model.fineTuneReport().message << ", tuning " << model.fineTuneReport().seconds << " s)\n";
  EXPECT_LT(std::abs(model.mean(centre + 0.1 * Vector3d(0.3, 0.2, 0.5).normalized())) * model.scale(), 0.001);
}

// The collision map's variance lattice against the variance at every node: the same occupied
// nodes (that depends on the mean alone) and nearly the same probabilities, on a sphere whose
// lower half was never seen, so that the variance runs from the data's to the prior's.
// A wall thinner than the map's voxels stays in the map: the 5 mm plate lies across the boundary
// between two layers of 1 cm voxels, and neither layer's centre is inside it (2.5 mm out on each
// side), yet one of them is occupied in every column the plate crosses, and the layers beyond are
// free.
TEST(MultiscaleGpisModel, CollisionMapKeepsAPlateThinnerThanAVoxel) {
  const MultiscaleGpisModel model = fitted(plateData());
  gpatlas_core::OccupancyGridBuilder::Config config;
  config.resolution_m = 0.01;
  config.min_corner = kPlateCentre - Vector3d(0.05, 0.05, 0.05);
  config.max_corner = kPlateCentre + Vector3d(0.05, 0.05, 0.05);
  const gpatlas_core::OccupancyGrid grid = gpatlas_core::OccupancyGridBuilder(config).build(model);
  ASSERT_TRUE(grid.ok) << grid.message;
  // The nodes are the centres of voxels on the resolution's lattice (OctoMap's).
  const Vector3d lattice = grid.origin / config.resolution_m - Vector3d::Constant(0.5);
  EXPECT_LT((lattice - lattice.array().round().matrix()).norm(), 1e-9);
  const auto node = [&](const Vector3d& x) {
    const Eigen::Vector3i c = ((x - grid.origin) / grid.resolution).array().round().cast<int>();
    return grid.probabilities[grid.index(c.x(), c.y(), c.z())];
  };
  int checked = 0;
  // Voxel columns over the plate away from its edges (it spans 4 cm each way).
  for (double dx = -0.025; dx <= 0.0251; dx += 0.01)
    for (double dy = -0.025; dy <= 0.0251; dy += 0.01) {
      const Vector3d column = kPlateCentre + Vector3d(dx, dy, 0.0);
      int occupied = 0;
      for (double z : {-0.005, 0.005}) {  // the two layers the plate passes through
        occupied += node(column + Vector3d(0, 0, z)) > 0.5f ? 1 : 0;
        EXPECT_GT(model.mean(column + Vector3d(0, 0, z)), 0.0);  // its centre is outside the plate
      }
      EXPECT_GE(occupied, 1) << "no voxel for the plate at " << column.transpose();
      for (double z : {-0.025, 0.025})  // 1.75 cm from the plate's faces
        EXPECT_LT(node(column + Vector3d(0, 0, z)), 0.5f) << "voxel at " << (column + Vector3d(0, 0, z)).transpose();
      ++checked;
    }
  EXPECT_EQ(checked, 36);

  // A solid is not grown: on the sphere's observed upper half, no voxel whose centre is outside
  // the true sphere (beyond the model's millimetre of error) is occupied, though the surface
  // passes within half a voxel of many.
  config.min_corner.reset();
  config.max_corner.reset();
  const gpatlas_core::OccupancyGrid sphere = gpatlas_core::OccupancyGridBuilder(config).build(sphereModel());
  ASSERT_TRUE(sphere.ok) << sphere.message;
  int near_surface_outside = 0, occupied_upper = 0;
  for (int k = 0; k < sphere.size.z(); ++k)
    for (int j = 0; j < sphere.size.y(); ++j)
      for (int i = 0; i < sphere.size.x(); ++i) {
        const Vector3d x = sphere.position(i, j, k);
        if (x.z() < kSphereCentre.z() + 0.01) continue;
        const double outside_by = (x - kSphereCentre).norm() - kSphereRadius;
        const bool occupied = sphere.probabilities[sphere.index(i, j, k)] > 0.5f;
        occupied_upper += occupied ? 1 : 0;
        near_surface_outside += outside_by > 0.0015 && outside_by < 0.005 ? 1 : 0;
        if (outside_by > 0.0015) EXPECT_FALSE(occupied) << "voxel " << outside_by * 1e3 << " mm outside the sphere";
      }
  EXPECT_GT(occupied_upper, 50);
  EXPECT_GT(near_surface_outside, 20);
}

TEST(MultiscaleGpisModel, CollisionMapOnAVarianceLatticeMatchesTheFullEvaluation) {
  const MultiscaleGpisModel& model = sphereModel();
  gpatlas_core::OccupancyGridBuilder::Config config;
  config.resolution_m = 0.01;
  config.variance_stride = 1;
  const gpatlas_core::OccupancyGrid full = gpatlas_core::OccupancyGridBuilder(config).build(model);
  for (int stride : {2, 3}) {
    config.variance_stride = stride;
    const gpatlas_core::OccupancyGrid lattice = gpatlas_core::OccupancyGridBuilder(config).build(model);
    ASSERT_TRUE(full.ok && lattice.ok) << full.message << lattice.message;
    ASSERT_EQ(full.probabilities.size(), lattice.probabilities.size());
    EXPECT_EQ(full.exact_variance_nodes, full.domain_nodes);
    double worst = 0.0, sum = 0.0;
    std::size_t occupied = 0, disagree = 0, uncertain = 0;
    for (std::size_t n = 0; n < full.probabilities.size(); ++n) {
      const double p = full.probabilities[n], q = lattice.probabilities[n];
      worst = std::max(worst, std::abs(p - q));
      sum += std::abs(p - q);
      occupied += p > 0.5 ? 1 : 0;
      disagree += (p > 0.5) != (q > 0.5) ? 1 : 0;
      uncertain += p > 0.05 && p < 0.95 ? 1 : 0;
    }
    std::cout << "collision map, variance stride " << stride << ": " << lattice.exact_variance_nodes << " of "
              << lattice.domain_nodes << " nodes' variances evaluated (" << occupied << " occupied, " << uncertain
              << " with 0.05 < P < 0.95); difference in P: mean " << sum / full.domain_nodes << ", largest " << worst
              << "\n";
    EXPECT_GT(occupied, 100u);
    EXPECT_GT(uncertain, 100u);
    EXPECT_EQ(disagree, 0u);
    EXPECT_LT(lattice.exact_variance_nodes, full.domain_nodes / 2);
    if (stride == 2) {  // the default
      EXPECT_LT(sum / full.domain_nodes, 0.01);
      EXPECT_LT(worst, 0.25);  // near the domain's edge, where the outside pseudo-points pin the variance
    }
  }
}

// The approach planner's map, occupied or not at a threshold, against the probabilities of the
// full map: the same nodes above the threshold, on the sphere whose unseen half carries the
// prior's variance (so that the thresholds 0.2 and 0.8 draw different maps) and on the thin plate.
// At 0.5 no variance is evaluated, and the mean only near the surface.
TEST(MultiscaleGpisModel, CollisionMapAtAThresholdHasTheNodesWhoseProbabilityExceedsIt) {
  gpatlas_core::OccupancyGridBuilder::Config config;
  config.resolution_m = 0.01;
  const MultiscaleGpisModel plate = fitted(plateData());
  for (const MultiscaleGpisModel* model : {&sphereModel(), &plate}) {
    const gpatlas_core::OccupancyGrid full = gpatlas_core::OccupancyGridBuilder(config).build(*model);
    ASSERT_TRUE(full.ok) << full.message;
    std::map<double, std::size_t> occupied_at;
    for (double threshold : {0.2, 0.5, 0.8}) {
      const gpatlas_core::OccupancyGrid occupancy =
          gpatlas_core::OccupancyGridBuilder(config).buildOccupancy(*model, threshold);
      ASSERT_TRUE(occupancy.ok) << occupancy.message;
      ASSERT_EQ(occupancy.probabilities.size(), full.probabilities.size());
      EXPECT_EQ((occupancy.origin - full.origin).norm(), 0.0);
      if (threshold == 0.5) {
        EXPECT_EQ(occupancy.exact_variance_nodes, 0u);
        EXPECT_LT(occupancy.exact_mean_nodes, full.domain_nodes);
        std::cout << "collision map at 0.5: " << occupancy.exact_mean_nodes << " of " << occupancy.domain_nodes
                  << " nodes' means evaluated\n";
      } else {
        EXPECT_EQ(occupancy.exact_mean_nodes, full.domain_nodes);
      }
      std::size_t occupied = 0, disagree = 0;
      for (std::size_t n = 0; n < full.probabilities.size(); ++n) {
        const float q = occupancy.probabilities[n];
        EXPECT_TRUE(q == 0.0f || q == 1.0f);
        occupied += q == 1.0f ? 1 : 0;
        // The full map stores P as a float: a node within its rounding of the threshold may go either way.
        if (std::abs(full.probabilities[n] - threshold) > 1e-6) disagree += (full.probabilities[n] > threshold) != (q == 1.0f) ? 1 : 0;
      }
      EXPECT_EQ(disagree, 0u) << "threshold " << threshold;
      occupied_at[threshold] = occupied;
    }
    EXPECT_GT(occupied_at[0.5], 50u);
    if (model != &plate) {
      EXPECT_GT(occupied_at[0.2], occupied_at[0.5]);
      EXPECT_LT(occupied_at[0.8], occupied_at[0.5]);
    }
  }
  for (double bad : {0.0, 1.0, std::nan("")})
    EXPECT_FALSE(gpatlas_core::OccupancyGridBuilder(config).buildOccupancy(sphereModel(), bad).ok);
}

}  // namespace
