#include "gpatlas_core/model/gpis_model.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <random>

using gpatlas_core::FitReport;
using gpatlas_core::GpisModel;
using gpatlas_core::PointLabel;
using gpatlas_core::PointSource;
using gpatlas_core::TrainingPoint;
using Eigen::Vector3d;

namespace {

const Vector3d kCentre(0.6, -0.1, 0.12);
constexpr double kRadius = 0.08;
constexpr double kSigma = 0.05;

// Uniform directions with z above `min_z` (unit sphere), i.e. a cap seen from above/front.
std::vector<Vector3d> capDirections(int count, double min_z, unsigned seed) {
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

std::vector<TrainingPoint> surfacePoints(const std::vector<Vector3d>& dirs, const Vector3d& radii) {
  std::vector<TrainingPoint> pts;
  for (const auto& d : dirs) {
    TrainingPoint p;
    p.position = kCentre + d.cwiseProduct(radii);
    p.noise_sigma = kSigma;
    pts.push_back(p);
  }
  return pts;
}

std::vector<TrainingPoint> sphereCap(int count, double min_z, unsigned seed) {
  return surfacePoints(capDirections(count, min_z, seed), Vector3d::Constant(kRadius));
}

double angleDeg(const Vector3d& a, const Vector3d& b) {
  return std::acos(std::max(-1.0, std::min(1.0, a.normalized().dot(b.normalized())))) * 180.0 / M_PI;
}

TEST(GpisModel, SphereCapMeanSignsSurfaceAndNormals) {
  GpisModel model;
  const FitReport report = model.fit(sphereCap(300, -0.3, 1));
  ASSERT_TRUE(report.ok) << report.message;
  EXPECT_TRUE(report.full_refit);

  // Inside / outside signs along seen directions.
  for (const auto& d : capDirections(50, 0.0, 2)) {
    EXPECT_LT(model.mean(kCentre + 0.5 * kRadius * d), 0.0);
    EXPECT_GT(model.mean(kCentre + 1.5 * kRadius * d), 0.0);
  }
  // On the true surface near the data (fresh directions inside the cap): |mean| small and the
  // normal (gradient direction) within 5 degrees of the analytic one.
  double worst_mean = 0.0, worst_angle = 0.0;
  for (const auto& d : capDirections(100, 0.1, 3)) {
    const auto p = model.predict(kCentre + kRadius * d);
    worst_mean = std::max(worst_mean, std::abs(p.mean));
    worst_angle = std::max(worst_angle, angleDeg(p.gradient, d));
  }
  RecordProperty("worst_abs_mean_on_surface", std::to_string(worst_mean));
  RecordProperty("worst_normal_angle_deg", std::to_string(worst_angle));
  EXPECT_LT(worst_mean, 0.05);
  EXPECT_LT(worst_angle, 5.0);

  // Variance: lower near the data than on the unseen underside.
  const double seen = model.variance(kCentre + kRadius * Vector3d(0, 0, 1));
  const double unseen = model.variance(kCentre + kRadius * Vector3d(0, 0, -1));
  EXPECT_LT(seen, 0.25 * unseen);
}

TEST(GpisModel, EllipsoidPartialViewSignsAndNormals) {
  const Vector3d radii(0.10, 0.06, 0.04);
  GpisModel model;
  ASSERT_TRUE(model.fit(surfacePoints(capDirections(400, -0.2, 4), radii)).ok);
  double worst_angle = 0.0;
  for (const auto& d : capDirections(80, 0.2, 5)) {
    const Vector3d on = kCentre + d.cwiseProduct(radii);
    // Analytic ellipsoid normal: gradient of sum (x_i / a_i)^2.
    const Vector3d normal = (on - kCentre).cwiseQuotient(radii.cwiseProduct(radii));
    const auto p = model.predict(on);
    EXPECT_LT(std::abs(p.mean), 0.08);
    worst_angle = std::max(worst_angle, angleDeg(p.gradient, normal));
    EXPECT_LT(model.mean(kCentre + 0.5 * d.cwiseProduct(radii)), 0.0);
    EXPECT_GT(model.mean(kCentre + 1.5 * d.cwiseProduct(radii)), 0.0);
  }
  RecordProperty("worst_normal_angle_deg", std::to_string(worst_angle));
  EXPECT_LT(worst_angle, 5.0);
}

// The analytic mean and variance gradients at x against central differences of the model.
void expectGradientsMatchFiniteDifferences(const GpisModel& model, const Vector3d& x, const std::string& what = "") {
  const auto p = model.predict(x);
  const double h = 1e-6;
  for (int d = 0; d < 3; ++d) {
    Vector3d e = Vector3d::Zero();
    e[d] = h;
    const double fd_mean = (model.mean(x + e) - model.mean(x - e)) / (2 * h);
    const double fd_var = (model.variance(x + e) - model.variance(x - e)) / (2 * h);
    EXPECT_NEAR(p.gradient[d], fd_mean, 1e-4 * std::max(1.0, std::abs(fd_mean))) << what;
    EXPECT_NEAR(p.variance_gradient[d], fd_var, 1e-4 * std::max(1.0, std::abs(fd_var))) << what;
  }
}

TEST(GpisModel, GradientsMatchFiniteDifferences) {
  GpisModel model;
  ASSERT_TRUE(model.fit(sphereCap(150, -0.3, 6)).ok);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.2, 1.2);
  for (int t = 0; t < 20; ++t)
    expectGradientsMatchFiniteDifferences(model, kCentre + kRadius * Vector3d(u(rng), u(rng), u(rng)));
}

// A model of surface values and slope observations (along outward normals), without
// pseudo-points, so that its training set is exactly the observations.
GpisModel::Config bareConfig(const std::string& kernel = "wendland") {
  GpisModel::Config config;
  config.kernel = kernel;
  config.num_outside_points = 0;
  config.inside_point_at_centroid = false;
  return config;
}

std::vector<TrainingPoint> valuesAndSlopes(int count, unsigned seed, double slope_sigma) {
  std::vector<TrainingPoint> points = surfacePoints(capDirections(count, -0.2, seed), Vector3d::Constant(kRadius));
  for (int i = 0; i < count; i += 3) {
    TrainingPoint slope = points[static_cast<std::size_t>(i)];
    slope.slope_direction = 2.0 * (slope.position - kCentre) / kRadius;  // not unit: the model normalises it
    slope.noise_sigma = slope_sigma;
    points.push_back(slope);
    // A second slope at the same place, 45 degrees from the first: the r = 0 slope-slope
    // covariance with u.v != 0.
    if (i % 2 == 0) {
      slope.slope_direction = slope.slope_direction.normalized() + slope.slope_direction.normalized().unitOrthogonal();
      points.push_back(slope);
    }
  }
  return points;
}

// The posterior from a dense recompute in which every covariance with a slope is a central
// difference of k itself, not the model's closed forms.
struct DensePosterior {
  double mean;
  double variance;
};
DensePosterior densePosterior(const GpisModel& model, const std::vector<TrainingPoint>& points, const Vector3d& query) {
  const auto& kernel = model.kernel();
  // Wendland's k has an r^3 term, so the differences' error is O(h) near r = 0: a small step.
  const double h = 1e-5;
  struct Row {
    Vector3d x, u;
    double target, noise;
  };
  std::vector<Row> rows;
  const double noise_unit = kernel.value(0.0) / model.config().reference_prior_variance;
  for (const auto& p : points) {
    const bool slope = gpatlas_core::observesSlope(p);
    rows.push_back({model.toNormalised(p.position), slope ? Vector3d(p.slope_direction.normalized()) : Vector3d::Zero(),
                    slope ? 1.0 : 0.0, p.noise_sigma * p.noise_sigma * noise_unit});
  }
  // cov(L_a f, L_b f) with L a value or a central-difference slope.
  const auto cov = [&](const Row& a, const Row& b) {
    const auto k = [&](const Vector3d& x, const Vector3d& y) { return kernel.value((x - y).norm()); };
    const bool sa = !a.u.isZero(), sb = !b.u.isZero();
    if (!sa && !sb) return k(a.x, b.x);
    if (sa && !sb) return (k(a.x + h * a.u, b.x) - k(a.x - h * a.u, b.x)) / (2 * h);
    if (!sa && sb) return (k(a.x, b.x + h * b.u) - k(a.x, b.x - h * b.u)) / (2 * h);
    return (k(a.x + h * a.u, b.x + h * b.u) - k(a.x + h * a.u, b.x - h * b.u) - k(a.x - h * a.u, b.x + h * b.u) +
            k(a.x - h * a.u, b.x - h * b.u)) /
           (4 * h * h);
  };
  const Eigen::Index n = static_cast<Eigen::Index>(rows.size());
  Eigen::MatrixXd gram(n, n);
  Eigen::VectorXd cross(n), targets(n);
  const Row q{model.toNormalised(query), Vector3d::Zero(), 0.0, 0.0};
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) gram(i, j) = cov(rows[i], rows[j]);
    gram(i, i) += rows[i].noise;
    cross[i] = cov(rows[i], q);
    targets[i] = rows[i].target;
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(gram);
  return {cross.dot(ldlt.solve(targets)),
          (kernel.value(0.0) - cross.dot(ldlt.solve(cross))) * model.varianceUnitFactor()};
}

TEST(GpisModel, SlopeObservationsMatchADenseRecomputeFromTheKernelAlone) {
  for (const std::string kernel : {"wendland", "squared_exponential", "matern52"}) {
    GpisModel model(bareConfig(kernel));
    const std::vector<TrainingPoint> points = valuesAndSlopes(24, 11, 0.1);
    const FitReport report = model.fit(points);
    ASSERT_TRUE(report.ok) << report.message;
    ASSERT_EQ(model.size(), points.size());
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1.3, 1.3);
    for (int t = 0; t < 10; ++t) {
      const Vector3d x = kCentre + kRadius * Vector3d(u(rng), u(rng), u(rng));
      const auto dense = densePosterior(model, points, x);
      const auto p = model.predict(x);
      EXPECT_NEAR(p.mean, dense.mean, 1e-4 * std::max(1.0, std::abs(dense.mean))) << kernel;
      EXPECT_NEAR(p.variance, dense.variance, 1e-4 * std::max(1.0, dense.variance)) << kernel;
    }
  }
}

TEST(GpisModel, GradientsWithSlopeObservationsMatchFiniteDifferences) {
  GpisModel model;
  std::vector<TrainingPoint> points = valuesAndSlopes(90, 5, 0.1);
  ASSERT_TRUE(model.fit(points).ok);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1.2, 1.2);
  std::vector<Vector3d> queries;
  for (int t = 0; t < 15; ++t) queries.push_back(kCentre + kRadius * Vector3d(u(rng), u(rng), u(rng)));
  queries.push_back(points.back().position);  // on a slope observation: its r = 0 limits
  for (const Vector3d& x : queries) expectGradientsMatchFiniteDifferences(model, x);
}

// Nearly noise-free slopes of 1 per normalised unit along the outward normals of every
// `every`-th point, and the check that the model's mean meets them: its slope along each is then
// 1 / scale per metre.
std::vector<TrainingPoint> outwardSlopes(const std::vector<TrainingPoint>& points, std::size_t every) {
  std::vector<TrainingPoint> slopes;
  for (std::size_t i = 0; i < points.size(); i += every) {
    TrainingPoint slope = points[i];
    slope.slope_direction = (slope.position - kCentre).normalized();
    slope.noise_sigma = 0.001;
    slopes.push_back(slope);
  }
  return slopes;
}
void expectSlopesMet(const GpisModel& model, const std::vector<TrainingPoint>& slopes) {
  for (const auto& slope : slopes)
    EXPECT_NEAR(model.predict(slope.position).gradient.dot(slope.slope_direction), 1.0 / model.scale(),
                0.01 / model.scale());
}

TEST(GpisModel, SlopeObservationsSetTheSlopeAndAreAddedIncrementallyAsAFitWould) {
  // Surface values alone, then slope 1 per normalised unit along the normals, nearly noise-free:
  // the mean's slope along each observed normal becomes 1 / scale per metre.
  std::vector<TrainingPoint> points = surfacePoints(capDirections(80, -0.5, 4), Vector3d::Constant(kRadius));
  const std::vector<TrainingPoint> slopes = outwardSlopes(points, 4);
  GpisModel incremental;
  ASSERT_TRUE(incremental.fit(points).ok);
  const FitReport added = incremental.addPoints(slopes);
  ASSERT_TRUE(added.ok) << added.message;
  EXPECT_FALSE(added.full_refit);
  EXPECT_EQ(added.num_added, slopes.size());
  expectSlopesMet(incremental, slopes);

  std::vector<TrainingPoint> all = points;
  all.insert(all.end(), slopes.begin(), slopes.end());
  GpisModel full;
  ASSERT_TRUE(full.fit(all).ok);
  EXPECT_NEAR(full.scale(), incremental.scale(), 1e-12) << "slope observations must not move the frame";
  for (int t = 0; t < 20; ++t) {
    const Vector3d x = kCentre + kRadius * 1.1 * capDirections(20, -1.0, 9)[static_cast<std::size_t>(t)];
    const auto a = incremental.predict(x), b = full.predict(x);
    EXPECT_NEAR(a.mean, b.mean, 1e-7);
    EXPECT_NEAR(a.variance, b.variance, 1e-7);
    EXPECT_LT((a.gradient - b.gradient).norm(), 1e-5);
  }
  // The same slope again is a duplicate; the same place along another direction is not.
  TrainingPoint again = slopes.front();
  TrainingPoint sideways = slopes.front();
  sideways.slope_direction = sideways.slope_direction.unitOrthogonal();
  const FitReport second = incremental.addPoints({again, sideways});
  ASSERT_TRUE(second.ok) << second.message;
  EXPECT_EQ(second.num_added, 1u);
  // A vanishing direction is rejected with a reason.
  TrainingPoint broken = slopes.front();
  broken.slope_direction = Vector3d(1e-12, 0.0, 0.0);
  const FitReport third = incremental.addPoints({broken});
  EXPECT_EQ(third.num_added, 0u);
  ASSERT_FALSE(third.warnings.empty());
  EXPECT_NE(third.warnings.front().find("direction"), std::string::npos);
}

TEST(GpisModel, GradientsOfOtherKernelsMatchFiniteDifferences) {
  for (const std::string name : {"squared_exponential", "matern32", "matern52"}) {
    GpisModel::Config config;
    config.kernel = name;
    GpisModel model(config);
    ASSERT_TRUE(model.fit(sphereCap(120, -0.3, 8)).ok) << name;
    expectGradientsMatchFiniteDifferences(model, kCentre + Vector3d(0.03, -0.05, 0.07), name);
  }
}

TEST(GpisModel, BatchEqualsSinglePointQueries) {
  GpisModel model;
  ASSERT_TRUE(model.fit(sphereCap(200, -0.3, 9)).ok);
  std::mt19937 rng(10);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  gpatlas_core::Points3 queries(3, 40);
  for (int j = 0; j < queries.cols(); ++j) queries.col(j) = kCentre + kRadius * Vector3d(u(rng), u(rng), u(rng));
  const auto batch = model.predictBatch(queries);
  for (int j = 0; j < queries.cols(); ++j) {
    const auto p = model.predict(queries.col(j));
    EXPECT_NEAR(batch.mean[j], p.mean, 1e-12);
    EXPECT_NEAR(batch.variance[j], p.variance, 1e-10);
    EXPECT_LT((batch.gradient.col(j) - p.gradient).norm(), 1e-9);
    EXPECT_LT((batch.variance_gradient.col(j) - p.variance_gradient).norm(), 1e-8);
  }
}

// Mean, variance and gradient of two models at 30 random points around the sphere, to 1e-8.
void expectSamePredictions(const GpisModel& a_model, const GpisModel& b_model, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.2, 1.2);
  for (int t = 0; t < 30; ++t) {
    const Vector3d x = kCentre + kRadius * Vector3d(u(rng), u(rng), u(rng));
    const auto a = a_model.predict(x);
    const auto b = b_model.predict(x);
    EXPECT_NEAR(a.mean, b.mean, 1e-8 * std::max(1.0, std::abs(b.mean)));
    EXPECT_NEAR(a.variance, b.variance, 1e-8 * std::max(1.0, b.variance));
    EXPECT_LT((a.gradient - b.gradient).norm(), 1e-8 * std::max(1.0, b.gradient.norm()));
  }
}

TEST(GpisModel, IncrementalUpdateEqualsFullRefit) {
  const auto initial = sphereCap(200, 0.0, 11);
  auto extra = surfacePoints(capDirections(25, -1.0, 12), Vector3d::Constant(kRadius));
  // Touch contacts anywhere on the sphere (within the renormalisation radius) and free space.
  for (auto& p : extra) {
    p.source = PointSource::kTouch;
    p.noise_sigma = 0.01;
  }
  TrainingPoint free_point;
  free_point.position = kCentre + Vector3d(0, 0, 1.3 * kRadius);
  free_point.label = PointLabel::kOutside;
  free_point.noise_sigma = 0.1;
  free_point.source = PointSource::kFreeSpace;
  extra.push_back(free_point);

  GpisModel incremental;
  ASSERT_TRUE(incremental.fit(initial).ok);
  const std::vector<TrainingPoint> first(extra.begin(), extra.begin() + 10);
  const std::vector<TrainingPoint> second(extra.begin() + 10, extra.end());
  FitReport r1 = incremental.addPoints(first);
  ASSERT_TRUE(r1.ok) << r1.message;
  ASSERT_FALSE(r1.full_refit) << "the first batch should not need renormalisation";
  ASSERT_TRUE(incremental.addPoints(second).ok);

  // A full refit (new K, new Cholesky) of the same data in the same frame.
  GpisModel full(incremental);
  const FitReport refit = full.refit();
  ASSERT_TRUE(refit.ok && refit.full_refit && !refit.renormalised) << refit.message;
  ASSERT_EQ(full.centroid(), incremental.centroid());
  expectSamePredictions(incremental, full, 13);
  EXPECT_NEAR(incremental.logMarginalLikelihood(), full.logMarginalLikelihood(),
              1e-8 * std::abs(full.logMarginalLikelihood()));
}

TEST(GpisModel, FarSurfacePointRenormalisesConsistently) {
  GpisModel model;
  ASSERT_TRUE(model.fit(sphereCap(150, 0.3, 14)).ok);
  const double scale_before = model.scale();
  // A contact on the unseen far side: beyond the renormalisation radius of the partial view.
  TrainingPoint far;
  far.position = kCentre + Vector3d(0, 0, -kRadius);
  far.noise_sigma = 0.01;
  far.source = PointSource::kTouch;
  ASSERT_GT(model.toNormalised(far.position).norm(), model.config().renormalise_radius);
  const FitReport report = model.addPoints({far});
  ASSERT_TRUE(report.ok) << report.message;
  EXPECT_TRUE(report.renormalised);
  EXPECT_GT(model.scale(), scale_before);
  // The new point is in the data and the model is consistent with a fresh fit of the same data.
  GpisModel fresh;
  ASSERT_TRUE(fresh.fit(model.observations()).ok);
  EXPECT_NEAR(model.mean(far.position), fresh.mean(far.position), 1e-9);
  EXPECT_LT(std::abs(model.mean(far.position)), 0.05);
}

TEST(GpisModel, FitInFrameReplicatesAnIncrementallyUpdatedModel) {
  GpisModel original;
  ASSERT_TRUE(original.fit(sphereCap(120, 0.0, 21)).ok);
  auto touches = surfacePoints(capDirections(8, -0.2, 22), Vector3d::Constant(kRadius));
  for (auto& t : touches) t.source = PointSource::kTouch;
  ASSERT_TRUE(original.addPoints(touches).ok);

  GpisModel fresh;  // a fresh fit recomputes the centroid from all surface points
  ASSERT_TRUE(fresh.fit(original.observations()).ok);
  EXPECT_GT((fresh.centroid() - original.centroid()).norm(), 1e-6);

  GpisModel replica;
  const FitReport r = replica.fitInFrame(original.observations(), original.centroid(), original.scale());
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_FALSE(r.renormalised);
  EXPECT_EQ(replica.centroid(), original.centroid());
  const Vector3d q = kCentre + Vector3d(0.02, 0.01, -0.07);
  EXPECT_NEAR(replica.mean(q), original.mean(q), 1e-9);
  EXPECT_NEAR(replica.variance(q), original.variance(q), 1e-9);
  EXPECT_FALSE(replica.fitInFrame(original.observations(), original.centroid(), -1.0).ok);
}

// A copy made to be extended (room for more observations) is the same model, and grows like it.
TEST(GpisModel, ACopyWithRoomPredictsAndGrowsLikeTheOriginal) {
  GpisModel original;
  ASSERT_TRUE(original.fit(sphereCap(120, 0.0, 41)).ok);
  auto touches = surfacePoints(capDirections(12, -0.5, 42), Vector3d::Constant(kRadius));
  for (auto& t : touches) t.source = PointSource::kTouch;
  for (const std::size_t room : {std::size_t{0}, original.observations().size() + 4, original.observations().size() + 60}) {
    GpisModel copy(original, room);
    expectSamePredictions(copy, original, 43);
    GpisModel grown(original);
    ASSERT_TRUE(grown.addPoints(touches).ok);
    ASSERT_TRUE(copy.addPoints(touches).ok);
    EXPECT_EQ(copy.observations().size(), grown.observations().size());
    expectSamePredictions(copy, grown, 44);
  }
}

// A touch that retracts interior guesses refits the model in its frame with those guesses'
// depths changed and its own points appended: done as an update of the factor, it must give the
// model a fresh fit of the same points in the same frame gives. A moved point is a refit.
TEST(GpisModel, FitInFrameWithChangedTargetsAndNewPointsEqualsAFreshFit) {
  GpisModel model;
  auto points = sphereCap(150, 0.0, 31);
  for (int g = 0; g < 6; ++g) {  // interior guesses at a depth
    TrainingPoint guess;
    guess.position = kCentre + Vector3d(0.01 * g - 0.025, 0.0, -0.3 * kRadius);
    guess.label = PointLabel::kInside;
    guess.noise_sigma = 0.3;
    guess.surface_distance_m = 0.5 * kRadius;
    points.push_back(guess);
  }
  ASSERT_TRUE(model.fit(points).ok);
  std::vector<TrainingPoint> next = model.observations();
  ASSERT_EQ(next.size(), points.size());
  next[next.size() - 2].surface_distance_m = 0.2 * kRadius;  // retracted
  next[next.size() - 5].surface_distance_m = 0.1 * kRadius;
  auto touches = surfacePoints(capDirections(10, -0.6, 32), Vector3d::Constant(kRadius));
  for (auto& t : touches) {
    t.source = PointSource::kTouch;
    t.noise_sigma = 0.01;
  }
  next.insert(next.end(), touches.begin(), touches.end());

  GpisModel updated(model);
  const FitReport report = updated.fitInFrame(next, model.centroid(), model.scale());
  ASSERT_TRUE(report.ok) << report.message;
  EXPECT_NE(report.message.find("by update: 0 point(s) removed, 2 target(s) changed, 10 point(s) appended"),
            std::string::npos)
      << report.message;
  GpisModel fresh;
  ASSERT_TRUE(fresh.fitInFrame(next, model.centroid(), model.scale()).ok);
  ASSERT_EQ(updated.observations().size(), fresh.observations().size());
  expectSamePredictions(updated, fresh, 33);
  EXPECT_GT(std::abs(updated.mean(touches[0].position) - model.mean(touches[0].position)), 1e-3);  // it did change

  // Only targets changed, nothing appended.
  std::vector<TrainingPoint> retargeted = model.observations();
  retargeted.back().surface_distance_m = 0.05 * kRadius;
  GpisModel only_targets(model), only_targets_fresh;
  EXPECT_NE(only_targets.fitInFrame(retargeted, model.centroid(), model.scale()).message.find("by update"), std::string::npos);
  ASSERT_TRUE(only_targets_fresh.fitInFrame(retargeted, model.centroid(), model.scale()).ok);
  const Vector3d q = retargeted.back().position;
  EXPECT_NEAR(only_targets.mean(q), only_targets_fresh.mean(q), 1e-9);
  EXPECT_GT(only_targets.mean(q), model.mean(q) + 0.01);  // a shallower guess: less deep inside

  // Guesses dropped as well: the last one held, and one whose target had changed.
  std::vector<TrainingPoint> dropped = next;
  dropped.erase(dropped.begin() + static_cast<std::ptrdiff_t>(model.observations().size()) - 1);
  dropped.erase(dropped.begin() + static_cast<std::ptrdiff_t>(model.observations().size()) - 2);
  GpisModel without(model), without_fresh;
  const FitReport removal = without.fitInFrame(dropped, model.centroid(), model.scale());
  ASSERT_TRUE(removal.ok) << removal.message;
  EXPECT_NE(removal.message.find("by update: 2 point(s) removed, 1 target(s) changed, 10 point(s) appended"),
            std::string::npos)
      << removal.message;
  ASSERT_TRUE(without_fresh.fitInFrame(dropped, model.centroid(), model.scale()).ok);
  ASSERT_EQ(without.observations().size(), without_fresh.observations().size());
  expectSamePredictions(without, without_fresh, 34);
  EXPECT_NEAR(without.logMarginalLikelihood(), without_fresh.logMarginalLikelihood(),
              1e-8 * std::abs(without_fresh.logMarginalLikelihood()));

  // A moved point: a refit, as before.
  std::vector<TrainingPoint> moved = next;
  moved[3].position += Vector3d(0.001, 0.0, 0.0);
  GpisModel refitted(model);
  const FitReport refit = refitted.fitInFrame(moved, model.centroid(), model.scale());
  ASSERT_TRUE(refit.ok) << refit.message;
  EXPECT_EQ(refit.message.find("by update"), std::string::npos) << refit.message;
}

TEST(GpisModel, FreeSpaceDistanceTargetsFollowTheFrame) {
  GpisModel model;
  const auto cap = sphereCap(150, 0.0, 23);
  ASSERT_TRUE(model.fit(cap).ok);
  // Right above an observation, 5 mm out: the nearest surface observation is at most 5 mm away;
  // a new contact 1 mm away is nearer; far away the distance is large.
  const Vector3d top = cap[0].position;
  const Vector3d out = top + 0.005 * (top - kCentre).normalized();
  double nearest = 1e9;
  for (const auto& p : cap) nearest = std::min(nearest, (p.position - out).norm());
  EXPECT_NEAR(model.nearestSurfaceDistance(out), nearest, 1e-12);
  EXPECT_LE(nearest, 0.005 + 1e-12);
  EXPECT_NEAR(model.nearestSurfaceDistance(out, {out + Vector3d(0.001, 0, 0)}), 0.001, 1e-12);

  // A free point with its distance: the model behaves as with target d / scale (< 1) ...
  TrainingPoint free_point;
  free_point.position = out;
  free_point.label = PointLabel::kOutside;
  free_point.noise_sigma = 0.05;
  free_point.surface_distance_m = nearest;
  TrainingPoint explicit_target = free_point;
  explicit_target.surface_distance_m = std::numeric_limits<double>::quiet_NaN();
  explicit_target.target_override = nearest / model.scale();
  GpisModel with_distance(model), with_target(model);
  ASSERT_TRUE(with_distance.addPoints({free_point}).ok);
  ASSERT_TRUE(with_target.addPoints({explicit_target}).ok);
  EXPECT_NEAR(with_distance.mean(out), with_target.mean(out), 1e-12);
  // ... and after a renormalisation the target follows the new scale (a fresh fit of the same
  // observations in the new frame gives the same model).
  TrainingPoint far_contact;
  far_contact.position = kCentre + Vector3d(0, 0, -kRadius);
  far_contact.noise_sigma = 0.05;
  ASSERT_TRUE(with_distance.addPoints({far_contact}).ok);
  GpisModel fresh;
  ASSERT_TRUE(fresh.fitInFrame(with_distance.observations(), with_distance.centroid(), with_distance.scale()).ok);
  EXPECT_NEAR(fresh.mean(out), with_distance.mean(out), 1e-9);
}

TEST(GpisModel, InsideDistanceTargetsAreTheNegativeDistanceInTheFrame) {
  GpisModel model;
  const auto cap = sphereCap(150, 0.0, 29);
  ASSERT_TRUE(model.fit(cap).ok);
  const Vector3d top = cap[0].position;
  const Vector3d in = top - 0.01 * (top - kCentre).normalized();
  TrainingPoint inside_point;
  inside_point.position = in;
  inside_point.label = PointLabel::kInside;
  inside_point.noise_sigma = 0.05;
  inside_point.surface_distance_m = 0.01;
  TrainingPoint explicit_target = inside_point;
  explicit_target.surface_distance_m = std::numeric_limits<double>::quiet_NaN();
  explicit_target.target_override = -0.01 / model.scale();
  TrainingPoint plain = explicit_target;
  plain.target_override = std::numeric_limits<double>::quiet_NaN();
  GpisModel with_distance(model), with_target(model), with_minus_one(model);
  ASSERT_TRUE(with_distance.addPoints({inside_point}).ok);
  ASSERT_TRUE(with_target.addPoints({explicit_target}).ok);
  ASSERT_TRUE(with_minus_one.addPoints({plain}).ok);
  EXPECT_NEAR(with_distance.mean(in), with_target.mean(in), 1e-12);
  // Without a distance an inside point keeps its -1: a different (steeper) model.
  EXPECT_LT(with_minus_one.mean(in), with_distance.mean(in) - 0.05);
}

TEST(GpisModel, ContactNearTheCentroidDropsTheInsidePointAsARefitWould) {
  GpisModel model;
  ASSERT_TRUE(model.fit(sphereCap(200, -0.5, 24)).ok);
  ASSERT_LT(model.mean(model.centroid()), -0.5);  // the inside point (-1) is there
  TrainingPoint wall;  // a surface observation right at the centroid, as in a cup's cavity
  wall.position = model.centroid() + Vector3d(0.001, 0, 0);
  wall.noise_sigma = 0.05;
  ASSERT_TRUE(model.addPoints({wall}).ok);
  GpisModel replica;
  ASSERT_TRUE(replica.fitInFrame(model.observations(), model.centroid(), model.scale()).ok);
  for (const Vector3d& q : {model.centroid(), Vector3d(kCentre + Vector3d(0.02, -0.01, 0.03))})
    EXPECT_NEAR(model.mean(q), replica.mean(q), 1e-9);
  EXPECT_GT(model.mean(model.centroid()), -0.5);
}

// Free space near the centroid (a camera ray or a probe's approach through a cup's cavity)
// says the centroid is air: the inside point goes, incrementally exactly as in a refit.
TEST(GpisModel, FreeSpaceNearTheCentroidDropsTheInsidePointAsARefitWould) {
  GpisModel model;
  ASSERT_TRUE(model.fit(sphereCap(200, -0.5, 24)).ok);
  const std::size_t with_inside_point = model.size();
  ASSERT_LT(model.mean(model.centroid()), -0.5);
  TrainingPoint air;
  air.position = model.centroid() + Vector3d(0.0, 0.002, 0.0);
  air.label = PointLabel::kOutside;
  air.source = PointSource::kFreeSpace;
  air.noise_sigma = 0.3;
  air.surface_distance_m = 0.03;
  ASSERT_TRUE(model.addPoints({air}).ok);
  EXPECT_EQ(model.size(), with_inside_point);  // one observation in, the -1 pseudo-point out
  GpisModel replica;
  ASSERT_TRUE(replica.fitInFrame(model.observations(), model.centroid(), model.scale()).ok);
  EXPECT_EQ(replica.size(), model.size());
  for (const Vector3d& q : {model.centroid(), Vector3d(kCentre + Vector3d(0.02, -0.01, 0.03))})
    EXPECT_NEAR(model.mean(q), replica.mean(q), 1e-9);
  EXPECT_GT(model.mean(model.centroid()), 0.0);
}

TEST(GpisModel, RejectsBadInputWithClearMessages) {
  GpisModel model;
  EXPECT_FALSE(model.isFitted());
  EXPECT_THROW(model.predict(kCentre), std::logic_error);

  // Too few points.
  FitReport r = model.fit(sphereCap(3, -1.0, 15));
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("at least 4"), std::string::npos) << r.message;
  EXPECT_FALSE(model.isFitted());

  // NaN coordinates are dropped with a warning; the rest is fitted.
  auto pts = sphereCap(50, -0.3, 16);
  pts[3].position.x() = std::numeric_limits<double>::quiet_NaN();
  pts[7].position.z() = std::numeric_limits<double>::infinity();
  r = model.fit(pts);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.num_rejected, 2u);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_NE(r.warnings.front().find("NaN"), std::string::npos);
  EXPECT_EQ(model.observations().size(), 48u);

  // Exact duplicates are dropped.
  auto dup = sphereCap(40, -0.3, 17);
  dup.push_back(dup[0]);
  dup.push_back(dup[1]);
  r = model.fit(dup);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(model.observations().size(), 40u);

  // A failed fit keeps the previous model.
  const double before = model.mean(kCentre);
  r = model.fit({});
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(model.isFitted());
  EXPECT_DOUBLE_EQ(model.mean(kCentre), before);
}

TEST(GpisModel, ContradictoryPointsEscalateJitterThenFailClearly) {
  // The same position labelled on-surface and outside with zero noise: K is singular.
  auto pts = sphereCap(40, -0.3, 18);
  for (auto& p : pts) p.noise_sigma = 0.0;
  TrainingPoint contradiction = pts[5];
  contradiction.label = PointLabel::kOutside;
  pts.push_back(contradiction);

  GpisModel tolerant;  // no jitter first, then the ladder climbs from 1e-12 of the prior variance

  FitReport r = tolerant.fit(pts);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_GT(r.jitter, 0.0);
  ASSERT_FALSE(r.warnings.empty());

  GpisModel::Config strict;
  strict.cholesky.jitter_max_relative = 0.0;
  GpisModel model(strict);
  r = model.fit(pts);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("not positive definite"), std::string::npos) << r.message;
  EXPECT_FALSE(model.isFitted());
}

// A new point that needs more jitter than the model has: the update escalates it on every
// point alike (a full refit), so the model equals a fresh fit of the same data in its frame.
TEST(GpisModel, AnUpdateNeedingMoreJitterEqualsAFullRefit) {
  auto pts = sphereCap(40, -0.3, 18);
  for (auto& p : pts) p.noise_sigma = 0.0;
  GpisModel::Config config;
  ASSERT_EQ(config.cholesky.jitter_first_relative, 0.0);  // an exact data fit without jitter first
  GpisModel model(config);
  ASSERT_TRUE(model.fit(pts).ok);
  ASSERT_EQ(model.fit(pts).jitter, 0.0);
  TrainingPoint contradiction = pts[5];  // the same position, outside, no noise: K is singular
  contradiction.label = PointLabel::kOutside;
  const FitReport update = model.addPoints({contradiction});
  ASSERT_TRUE(update.ok) << update.message;
  EXPECT_TRUE(update.full_refit);
  EXPECT_GT(update.jitter, 0.0);
  EXPECT_EQ(update.num_added, 1u);
  GpisModel replica(config);
  const FitReport fresh = replica.fitInFrame(model.observations(), model.centroid(), model.scale());
  ASSERT_TRUE(fresh.ok) << fresh.message;
  EXPECT_EQ(fresh.jitter, update.jitter);
  for (const Vector3d& q : {Vector3d(kCentre + Vector3d(0.02, -0.01, 0.03)), Vector3d(kCentre + Vector3d(0, 0, 0.2))}) {
    EXPECT_NEAR(model.mean(q), replica.mean(q), 1e-9);
    EXPECT_NEAR(model.variance(q), replica.variance(q), 1e-9);
  }
}

TEST(GpisModel, InvalidConfigurationIsRefused) {
  GpisModel::Config config = GpisModel::Config::thinPlateReference();
  config.domain_radius = 1.5;  // diameter 3 > thin-plate R = 2
  config.renormalise_radius = 1.2;
  EXPECT_THROW(GpisModel{config}, std::invalid_argument);
  GpisModel::Config unknown;
  unknown.kernel = "nope";
  EXPECT_THROW(GpisModel{unknown}, std::invalid_argument);
}

TEST(GpisModel, DomainAndUnits) {
  GpisModel model(GpisModel::Config::thinPlateReference());
  ASSERT_TRUE(model.fit(sphereCap(100, -0.3, 19)).ok);
  EXPECT_TRUE(model.inDomain(kCentre));
  EXPECT_FALSE(model.inDomain(kCentre + Vector3d(10, 0, 0)));
  const Vector3d x = kCentre + Vector3d(0.01, 0.02, 0.03);
  EXPECT_LT((model.toWorld(model.toNormalised(x)) - x).norm(), 1e-12);
  // Reported variance equals the raw variance for the paper's kernel (k(0) = 8).
  EXPECT_DOUBLE_EQ(model.varianceUnitFactor(), 1.0);
  // Far from any data the posterior approaches the prior (reported units: 8).
  const auto batch = model.predictBatch(gpatlas_core::Points3(kCentre + Vector3d(0, 0, -0.5 * model.domainRadiusWorld())), false, false);
  EXPECT_LE(batch.variance[0], 8.0 + 1e-9);
  EXPECT_TRUE(batch.in_domain[0]);
}

TEST(GpisModel, DefaultIsWendlandInTheUnitBallFrameWithADomainTwiceAsLarge) {
  GpisModel model;
  EXPECT_EQ(model.kernel().name(), "wendland");
  ASSERT_TRUE(model.fit(sphereCap(100, -0.3, 19)).ok);
  double farthest = 0.0;
  for (const auto& p : model.observations()) farthest = std::max(farthest, model.toNormalised(p.position).norm());
  EXPECT_NEAR(farthest, 1.0, 1e-9);
  EXPECT_DOUBLE_EQ(model.domainRadiusWorld(), 2.0 * model.scale());
  EXPECT_DOUBLE_EQ(model.varianceUnitFactor(), 8.0 / model.kernel().priorVariance());
  // The whole sphere (the cap's unseen far side included) lies inside the domain.
  EXPECT_TRUE(model.inDomain(kCentre - Vector3d(0, 0, kRadius)));
}

TEST(GpisModel, ScalingTheKernelChangesNeitherMeanNorReportedVariance) {
  // Noise sigmas and variances are in reference units: a kernel scaled by c^2 (the signal
  // sigma of a squared exponential) gives the same posterior mean and reported variance.
  GpisModel::Config config;
  config.kernel = "squared_exponential";
  GpisModel a(config);
  config.initial_params = {std::log(3.0), std::log(0.3)};
  GpisModel b(config);
  const auto pts = sphereCap(80, -0.3, 5);
  ASSERT_TRUE(a.fit(pts).ok);
  ASSERT_TRUE(b.fit(pts).ok);
  const gpatlas_core::Points3 q = (gpatlas_core::Points3(3, 2) << kCentre + Vector3d(0.02, 0.0, kRadius),
                                   kCentre - Vector3d(0.0, 0.0, kRadius)).finished();
  const auto pa = a.predictBatch(q, false, false);
  const auto pb = b.predictBatch(q, false, false);
  for (int j = 0; j < 2; ++j) {
    EXPECT_NEAR(pa.mean[j], pb.mean[j], 1e-6);
    EXPECT_NEAR(pa.variance[j], pb.variance[j], 1e-6 * pa.variance[j] + 1e-9);
  }
  EXPECT_GT(pa.variance[1], 10.0 * pa.variance[0]);  // the far side is the uncertain one
}

TEST(GpisModel, InsidePointIsSkippedWhenTheCentroidIsCloseToTheSurfaceData) {
  GpisModel::Config config;
  config.inside_point_min_clearance = 0.3;
  GpisModel far_enough(config);
  ASSERT_TRUE(far_enough.fit(sphereCap(100, -0.3, 19)).ok);
  // A flat patch: its centroid lies on the data.
  std::vector<TrainingPoint> patch;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) {
      TrainingPoint p;
      p.position = Vector3d(0.01 * i, 0.01 * j, 0.0);
      p.noise_sigma = 0.1;
      patch.push_back(p);
    }
  GpisModel flat(config);
  ASSERT_TRUE(flat.fit(patch).ok);
  EXPECT_EQ(far_enough.size(), far_enough.observations().size() + 33u);
  EXPECT_EQ(flat.size(), flat.observations().size() + 32u);
}

}  // namespace
