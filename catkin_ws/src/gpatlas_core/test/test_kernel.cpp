#include "gpatlas_core/model/kernel.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>
#include <random>

using gpatlas_core::Kernel;
using gpatlas_core::makeKernel;

namespace {

std::vector<std::unique_ptr<Kernel>> allKernels() {
  std::vector<std::unique_ptr<Kernel>> kernels;
  for (const auto& name : gpatlas_core::kernelNames()) kernels.push_back(makeKernel(name));
  return kernels;
}

TEST(Kernel, ThinPlateMatchesPaperFormula) {
  gpatlas_core::ThinPlateKernel k(2.0);
  for (double r : {0.0, 0.3, 1.0, 1.7, 2.0}) EXPECT_NEAR(k.value(r), 2 * r * r * r - 6 * r * r + 8, 1e-12);
  EXPECT_NEAR(k.value(2.0), 0.0, 1e-12);
  EXPECT_NEAR(k.priorVariance(), 8.0, 1e-12);
  EXPECT_DOUBLE_EQ(k.maxValidDistance(), 2.0);
}

TEST(Kernel, RadialDerivativeMatchesFiniteDifferences) {
  for (const auto& k : allKernels()) {
    for (double r : {0.05, 0.4, 0.9, 1.6}) {
      const double h = 1e-6;
      const double fd = (k->value(r + h) - k->value(r - h)) / (2 * h);
      EXPECT_NEAR(k->derivative(r), fd, 1e-6 * std::max(1.0, std::abs(fd))) << k->name() << " r=" << r;
    }
    EXPECT_NEAR(k->derivative(0.0), 0.0, 1e-12) << k->name();
  }
}

// Slope observations need d2k/dr2: every kernel's exact form, and the base class's numerical
// default (used by kernels a user registers), against central differences of dk/dr.
class DefaultSecondDerivative : public gpatlas_core::WendlandKernel {
 public:
  double secondDerivative(double r) const override { return Kernel::secondDerivative(r); }
};

TEST(Kernel, SecondDerivativeMatchesFiniteDifferences) {
  auto kernels = allKernels();
  kernels.push_back(std::make_unique<DefaultSecondDerivative>());
  for (const auto& k : kernels) {
    for (double r : {0.05, 0.4, 0.9, 1.6, 2.5}) {
      const double h = 1e-5;
      const double fd = (k->derivative(r + h) - k->derivative(r - h)) / (2 * h);
      EXPECT_NEAR(k->secondDerivative(r), fd, 1e-5 * std::max(1.0, std::abs(fd))) << k->name() << " r=" << r;
    }
    // At the origin dk/dr = 0, so d2k/dr2 = lim dk/dr / r.
    const double h = 1e-7;
    EXPECT_NEAR(k->secondDerivative(0.0), k->derivative(h) / h, 1e-5 * std::abs(k->secondDerivative(0.0))) << k->name();
    EXPECT_LT(k->secondDerivative(0.0), 0.0) << k->name() << ": a slope's prior variance is -k''(0)";
  }
}

TEST(Kernel, SpatialGradientMatchesFiniteDifferences) {
  const Eigen::Vector3d y(0.1, -0.2, 0.3);
  const Eigen::Vector3d x(0.5, 0.1, -0.2);
  for (const auto& k : allKernels()) {
    const Eigen::Vector3d g = k->gradient(x, y);
    for (int d = 0; d < 3; ++d) {
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      e[d] = 1e-6;
      const double fd = (k->value((x + e - y).norm()) - k->value((x - e - y).norm())) / 2e-6;
      EXPECT_NEAR(g[d], fd, 1e-6) << k->name() << " dim " << d;
    }
  }
}

// The predictions use the array forms; they must give the scalar forms' numbers exactly (same
// bits), at the origin, beyond a compact support and at an infinite distance too (NaN where the
// scalar form gives NaN).
bool sameNumber(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

TEST(Kernel, ArrayFormsEqualScalarForms) {
  Eigen::ArrayXd r(10);
  r << 0.0, 1e-9, 0.05, 0.4, 0.9, 1.6, 2.0, 3.64, 5.0, std::numeric_limits<double>::infinity();
  for (const auto& k : allKernels()) {
    Eigen::ArrayXd values, slopes;
    k->values(r, &values);
    k->derivativesOverDistance(r, &slopes);
    ASSERT_EQ(values.size(), r.size()) << k->name();
    ASSERT_EQ(slopes.size(), r.size()) << k->name();
    for (Eigen::Index i = 0; i < r.size(); ++i) {
      EXPECT_TRUE(sameNumber(values[i], k->value(r[i]))) << k->name() << " r=" << r[i] << ": " << values[i];
      const double expected_slope = r[i] > 0.0 ? k->derivative(r[i]) / r[i] : 0.0;
      EXPECT_TRUE(sameNumber(slopes[i], expected_slope)) << k->name() << " r=" << r[i] << ": " << slopes[i];
      EXPECT_FALSE(std::signbit(values[i]) && values[i] == 0.0) << k->name() << " r=" << r[i];
    }
  }
}

TEST(Kernel, ParameterGradientMatchesFiniteDifferences) {
  for (const auto& k : allKernels()) {
    const Eigen::VectorXd base = k->logParams();
    for (double r : {0.0, 0.3, 1.2}) {
      std::vector<double> analytic(static_cast<std::size_t>(k->numParams()));
      k->paramGradient(r, analytic.data());
      for (int p = 0; p < k->numParams(); ++p) {
        auto probe = k->clone();
        Eigen::VectorXd plus = base, minus = base;
        plus[p] += 1e-6;
        minus[p] -= 1e-6;
        probe->setLogParams(plus);
        const double up = probe->value(r);
        probe->setLogParams(minus);
        const double down = probe->value(r);
        const double fd = (up - down) / 2e-6;
        EXPECT_NEAR(analytic[static_cast<std::size_t>(p)], fd, 1e-5 * std::max(1.0, std::abs(fd)))
            << k->name() << " param " << p << " r=" << r;
      }
    }
  }
}

// SE and Matern are positive definite in any dimension. The thin-plate "covariance" is not
// (its Gram matrix of many points in a 3-D ball has slightly negative eigenvalues), which is
// why every GPIS point carries noise and the model escalates jitter: the test pins both facts.
std::vector<Eigen::Vector3d> pointsInUnitBall(std::size_t count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> pts;
  while (pts.size() < count) {
    Eigen::Vector3d p(u(rng), u(rng), u(rng));
    if (p.norm() <= 1.0) pts.push_back(p);  // pairwise distances <= 2 = R of the default thin plate
  }
  return pts;
}

Eigen::VectorXd gramEigenvalues(const Kernel& k, const std::vector<Eigen::Vector3d>& pts) {
  Eigen::MatrixXd gram(pts.size(), pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i)
    for (std::size_t j = 0; j < pts.size(); ++j) gram(i, j) = k.value((pts[i] - pts[j]).norm());
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(gram).eigenvalues();
}

TEST(Kernel, StationaryKernelsArePositiveDefinite) {
  const auto pts = pointsInUnitBall(300, 3);
  for (const std::string name : {"squared_exponential", "matern32", "matern52", "wendland"}) {
    const Eigen::VectorXd eig = gramEigenvalues(*makeKernel(name), pts);
    EXPECT_GT(eig.minCoeff(), -1e-9 * eig.maxCoeff()) << name;
  }
}

TEST(Kernel, WendlandMatchesClosedFormAndThinPlateCurvature) {
  gpatlas_core::WendlandKernel k(2.0);
  for (double r : {0.0, 0.3, 1.0, 1.7}) {
    const double t = r / 2.0;
    EXPECT_NEAR(k.value(r), 8.0 * std::pow(1 - t, 4) * (4 * t + 1), 1e-12);
  }
  EXPECT_DOUBLE_EQ(k.value(2.0), 0.0);
  EXPECT_DOUBLE_EQ(k.value(3.0), 0.0);
  // The default R gives the correlation k(r)/k(0) the thin-plate's (R = 2) curvature at the
  // origin: 1 - 3 r^2 / R_tp^2 = 1 - 10 r^2 / R_w^2.
  gpatlas_core::WendlandKernel d;
  gpatlas_core::ThinPlateKernel tp(2.0);
  const double h = 1e-3;
  EXPECT_NEAR((d.value(h) / d.value(0.0) - 1.0) / (h * h), (tp.value(h) / tp.value(0.0) - 1.0) / (h * h), 0.01);
}

TEST(Kernel, WendlandIsPositiveDefiniteInThreeDimensionsAtAnyRadius) {
  const auto pts = pointsInUnitBall(400, 3);
  for (double radius : {0.5, 2.0, 3.65, 10.0}) {
    const Eigen::VectorXd eig = gramEigenvalues(gpatlas_core::WendlandKernel(radius), pts);
    EXPECT_GT(eig.minCoeff(), -1e-9 * eig.maxCoeff()) << "R=" << radius;
  }
}

TEST(Kernel, ThinPlateIsOnlyApproximatelyPositiveDefiniteInThreeDimensions) {
  const Eigen::VectorXd eig = gramEigenvalues(*makeKernel("thin_plate"), pointsInUnitBall(400, 3));
  // Negative, but tiny next to the noise variance 0.1 of the paper's points.
  EXPECT_LT(eig.minCoeff(), 0.0);
  EXPECT_GT(eig.minCoeff(), -0.1 * 8.0);
}

TEST(Kernel, UnknownNameListsKnownKernels) {
  try {
    makeKernel("no_such_kernel");
    FAIL() << "expected an exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("thin_plate"), std::string::npos);
  }
}

TEST(Kernel, RegistryAcceptsUserKernels) {
  EXPECT_TRUE(gpatlas_core::registerKernel("test_wide_se", [] {
    return std::make_unique<gpatlas_core::SquaredExponentialKernel>(1.0, 2.0);
  }));
  EXPECT_FALSE(gpatlas_core::registerKernel("thin_plate", [] { return std::make_unique<gpatlas_core::ThinPlateKernel>(); }));
  EXPECT_NEAR(makeKernel("test_wide_se")->value(2.0), std::exp(-0.5), 1e-12);
}

}  // namespace
