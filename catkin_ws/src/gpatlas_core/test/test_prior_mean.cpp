#include "gpatlas_core/gpis_model.h"
#include "gpatlas_core/prior_mean.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace gpatlas_core {
namespace {

std::vector<Vector3> randomPoints(int count, double half_width, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-half_width, half_width);
  std::vector<Vector3> points;
  for (int i = 0; i < count; ++i) points.emplace_back(u(rng), u(rng), u(rng));
  return points;
}

// A smooth test prior, "material around here": m = -depth exp(-|x - c|^2 / (2 sigma^2)).
struct GaussianBumpPrior : PriorMean {
  GaussianBumpPrior(const Vector3& centre, double sigma, double depth) : c(centre), s(sigma), d(depth) {}
  double value(const Vector3& x, Vector3* gradient = nullptr) const override {
    const Vector3 r = x - c;
    const double m = -d * std::exp(-r.squaredNorm() / (2.0 * s * s));
    if (gradient) *gradient = (-m / (s * s)) * r;
    return m;
  }
  Vector3 c;
  double s, d;
};

// Data: a sphere's front cap (surface) and some free space; the priors put material behind it.
std::vector<TrainingPoint> capData(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<TrainingPoint> data;
  while (data.size() < 120) {
    Vector3 d(g(rng), g(rng), g(rng));
    d.normalize();
    if (d.x() < 0.2) continue;
    TrainingPoint t;
    t.position = 0.1 * d;
    t.noise_sigma = 0.1;
    data.push_back(t);
  }
  for (int i = 0; i < 20; ++i) {
    TrainingPoint t;
    t.position = Vector3(0.13 + 0.002 * i, 0.01 * (i % 5) - 0.02, 0.0);
    t.label = PointLabel::kOutside;
    t.noise_sigma = 0.3;
    t.surface_distance_m = t.position.norm() - 0.1;
    data.push_back(t);
  }
  return data;
}

std::shared_ptr<const PriorMean> backPrior() {
  return std::make_shared<GaussianBumpPrior>(Vector3(-0.03, 0.0, 0.0), 0.04, 0.3);
}

// The data with their targets made explicit (label value, or +-min(1, d / scale) with a
// distance, as GpisModel documents) less the prior mean: what a zero-mean GP must fit.
std::vector<TrainingPoint> residualTargets(std::vector<TrainingPoint> data, const PriorMean& prior, double scale) {
  for (auto& t : data) {
    const double label = static_cast<double>(static_cast<int>(t.label));
    const double target =
        std::isfinite(t.surface_distance_m) ? label * std::min(1.0, t.surface_distance_m / scale) : label;
    t.target_override = target - prior.value(t.position);
  }
  return data;
}

// The definition of a GP with a known mean m: it is m plus a zero-mean GP fitted to the
// residuals y - m(x). The reference model below is that zero-mean GP, its targets overridden.
TEST(GpisModelWithPrior, EqualsAZeroMeanModelOfTheResidualsPlusThePrior) {
  GpisModelConfig config;
  config.num_outside_points = 0;  // pseudo-points would carry the prior too: keep the reference exact
  config.inside_point_at_centroid = false;
  const auto data = capData(4);
  const auto prior = backPrior();

  GpisModel with_prior(config);
  ASSERT_TRUE(with_prior.setPriorMean(prior).ok);
  ASSERT_TRUE(with_prior.fit(data).ok);

  GpisModel reference(config);
  ASSERT_TRUE(reference.fit(data).ok);  // for its frame (scale) only
  auto residual_data = residualTargets(data, *prior, reference.scale());
  ASSERT_TRUE(reference.fitInFrame(residual_data, reference.centroid(), reference.scale()).ok);

  for (const auto& x : randomPoints(50, 0.12, 5)) {
    const Prediction a = with_prior.predict(x);
    const Prediction b = reference.predict(x);
    Vector3 prior_gradient;
    const double m = prior->value(x, &prior_gradient);
    EXPECT_NEAR(a.mean, b.mean + m, 1e-9);
    EXPECT_NEAR(a.variance, b.variance, 1e-12);  // the prior moves the mean only
    EXPECT_NEAR((a.gradient - b.gradient - prior_gradient).norm(), 0.0, 1e-7);
  }
  // And the batch query agrees with the single ones.
  Points3 xs(3, 2);
  xs.col(0) = Vector3(-0.05, 0.01, 0.02);
  xs.col(1) = Vector3(0.09, -0.02, 0.0);
  const BatchPrediction batch = with_prior.predictBatch(xs, true, false, false);
  for (int j = 0; j < 2; ++j) {
    EXPECT_NEAR(batch.mean[j], with_prior.mean(xs.col(j)), 1e-12);
    EXPECT_NEAR((batch.gradient.col(j) - with_prior.predict(xs.col(j)).gradient).norm(), 0.0, 1e-9);
  }
}

// The pseudo-points carry the prior too: the inside point at the centroid has residual
// -1 - m(centroid). Reference: a zero-mean model with that point given explicitly.
TEST(GpisModelWithPrior, ThePseudoPointAtTheCentroidCarriesThePrior) {
  GpisModelConfig config;
  config.num_outside_points = 0;
  config.inside_point_min_clearance = 0.0;  // always placed
  const auto data = capData(9);
  GpisModel frame_of(config);
  ASSERT_TRUE(frame_of.fit(data).ok);
  const Vector3 centroid = frame_of.centroid();
  const auto prior = std::make_shared<GaussianBumpPrior>(centroid, 0.03, 0.3);
  ASSERT_LT(prior->value(centroid), -0.2);

  GpisModel with_prior(config);
  ASSERT_TRUE(with_prior.setPriorMean(prior).ok);
  ASSERT_TRUE(with_prior.fitInFrame(data, centroid, frame_of.scale()).ok);
  ASSERT_EQ(with_prior.size(), data.size() + 1);  // the inside point is there

  GpisModelConfig bare = config;
  bare.inside_point_at_centroid = false;
  auto residual_data = residualTargets(data, *prior, frame_of.scale());
  TrainingPoint centre_point;
  centre_point.position = centroid;
  centre_point.label = PointLabel::kInside;
  centre_point.noise_sigma = 0.0;  // as the pseudo-point (pseudo_point_sigma 0)
  centre_point.target_override = -1.0 - prior->value(centroid);
  residual_data.push_back(centre_point);
  GpisModel reference(bare);
  ASSERT_TRUE(reference.fitInFrame(residual_data, centroid, frame_of.scale()).ok);
  for (const auto& x : randomPoints(40, 0.12, 11))
    EXPECT_NEAR(with_prior.mean(x), reference.mean(x) + prior->value(x), 1e-8);
}

TEST(GpisModelWithPrior, ANonFinitePriorIsRefusedAndTheModelKept) {
  struct BrokenPrior : PriorMean {
    double value(const Vector3& x, Vector3* gradient) const override {
      if (gradient) gradient->setZero();
      return (x - Vector3(0.1, 0.0, 0.0)).norm() < 0.03 ? std::numeric_limits<double>::quiet_NaN() : 0.0;
    }
  };
  const auto data = capData(12);
  GpisModel model;
  ASSERT_TRUE(model.fit(data).ok);
  const double before = model.mean(Vector3(0.0, 0.0, 0.0));
  // NaN at some observations: refused (no data is dropped for a broken prior), model kept.
  const FitReport refused = model.setPriorMean(std::make_shared<BrokenPrior>());
  EXPECT_FALSE(refused.ok);
  EXPECT_NE(refused.message.find("observation"), std::string::npos);
  EXPECT_EQ(model.observations().size(), data.size());
  EXPECT_EQ(model.priorMean(), nullptr);
  EXPECT_DOUBLE_EQ(model.mean(Vector3(0.0, 0.0, 0.0)), before);
  // NaN everywhere: the pseudo-points already fail the fit.
  struct NanPrior : PriorMean {
    double value(const Vector3&, Vector3*) const override { return std::numeric_limits<double>::quiet_NaN(); }
  };
  const FitReport failed = model.setPriorMean(std::make_shared<NanPrior>());
  EXPECT_FALSE(failed.ok);
  EXPECT_NE(failed.message.find("not finite"), std::string::npos);
  EXPECT_EQ(model.priorMean(), nullptr);
  EXPECT_DOUBLE_EQ(model.mean(Vector3(0.0, 0.0, 0.0)), before);
}

TEST(GpisModelWithPrior, IncrementalUpdateEqualsARefitAndRemovingThePriorRestoresTheModel) {
  const auto data = capData(6);
  GpisModel plain;
  ASSERT_TRUE(plain.fit(data).ok);
  GpisModel model(plain);
  ASSERT_TRUE(model.setPriorMean(backPrior()).ok);  // refits the fitted model
  ASSERT_NE(model.priorMean(), nullptr);
  const Vector3 behind(-0.06, 0.0, 0.0);
  EXPECT_LT(model.mean(behind), plain.mean(behind) - 0.05);  // the prior's material behind

  TrainingPoint contact;
  contact.position = Vector3(-0.1, 0.0, 0.0);  // the back of the sphere, by touch
  contact.noise_sigma = 0.3;
  contact.source = PointSource::kTouch;
  ASSERT_TRUE(model.addPoints({contact}).ok);
  GpisModel refitted(model);
  ASSERT_TRUE(refitted.refit().ok);
  for (const auto& x : randomPoints(30, 0.12, 7)) {
    EXPECT_NEAR(model.mean(x), refitted.mean(x), 1e-8);
    EXPECT_NEAR(model.variance(x), refitted.variance(x), 1e-8);
  }

  GpisModel without(model);
  ASSERT_TRUE(without.setPriorMean(nullptr).ok);
  GpisModel zero_mean;
  ASSERT_TRUE(zero_mean.fitInFrame(model.observations(), model.centroid(), model.scale()).ok);
  for (const auto& x : randomPoints(30, 0.12, 8)) EXPECT_NEAR(without.mean(x), zero_mean.mean(x), 1e-9);
}

}  // namespace
}  // namespace gpatlas_core
