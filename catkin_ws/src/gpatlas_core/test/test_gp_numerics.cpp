#include "gpatlas_core/model/gp_numerics.h"
#include "gpatlas_core/model/kernel.h"

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

using gpatlas_core::CholeskyConfig;
using gpatlas_core::Matern52Kernel;

namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::MatrixXd randomMatrix(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd m(rows, cols);
  for (Eigen::Index j = 0; j < cols; ++j)
    for (Eigen::Index i = 0; i < rows; ++i) m(i, j) = normal(rng);
  return m;
}

// Lower triangle of the block, the rest zero.
Eigen::MatrixXd lowerOf(const Eigen::MatrixXd& block) { return block.triangularView<Eigen::Lower>(); }

TEST(GpNumerics, TheLadderIsNoneThenDecadesUpToTheMaximumOfThePrior) {
  const CholeskyConfig config;
  const std::vector<double> ladder = gpatlas_core::jitterLadder(config, 8.0);
  ASSERT_EQ(ladder.size(), 10u);  // 0, then 1e-12 .. 1e-4
  EXPECT_EQ(ladder[0], 0.0);
  EXPECT_NEAR(ladder[1], 8e-12, 1e-24);
  EXPECT_NEAR(ladder.back(), 8e-4, 1e-15);
  CholeskyConfig strict;
  strict.jitter_max_relative = 0.0;
  EXPECT_EQ(gpatlas_core::jitterLadder(strict, 8.0).size(), 1u);
  // No jitter and no step: the ladder is its first rung, not an endless one.
  CholeskyConfig flat;
  flat.jitter_step_relative = 0.0;
  EXPECT_EQ(gpatlas_core::jitterLadder(flat, 8.0).size(), 1u);
}

TEST(GpNumerics, ASymmetricPositiveDefiniteMatrixIsFactoredWithoutJitterAsEigensLlt) {
  const Eigen::Index n = 30;
  const Eigen::MatrixXd a = randomMatrix(n, n, 1);
  const Eigen::MatrixXd k = a * a.transpose() + Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd block = lowerOf(k);  // only the lower triangle is read
  const double jitter = gpatlas_core::factoriseWithJitter(block, k.diagonal().maxCoeff(), CholeskyConfig());
  EXPECT_EQ(jitter, 0.0);
  const Eigen::MatrixXd reference = Eigen::LLT<Eigen::MatrixXd>(k).matrixL();
  EXPECT_LT((lowerOf(block) - reference).cwiseAbs().maxCoeff(), 1e-10);
}

TEST(GpNumerics, ASingularMatrixGetsTheJitterThatMakesItFactorisable) {
  // Rank 4 of 12: singular, positive semi-definite.
  const Eigen::Index n = 12;
  const Eigen::MatrixXd b = randomMatrix(n, 4, 2);
  const Eigen::MatrixXd k = b * b.transpose();
  const double prior = k.diagonal().maxCoeff();
  Eigen::MatrixXd block = lowerOf(k);
  const double jitter = gpatlas_core::factoriseWithJitter(block, prior, CholeskyConfig());
  ASSERT_GT(jitter, 0.0);
  EXPECT_LE(jitter, 1e-4 * prior * 1.0001);
  // The factor is Eigen's of K + jitter I, and its pivots are above the conditioning floor.
  const Eigen::MatrixXd shifted = k + jitter * Eigen::MatrixXd::Identity(n, n);
  const Eigen::LLT<Eigen::MatrixXd> llt(shifted);
  ASSERT_EQ(llt.info(), Eigen::Success);
  const Eigen::MatrixXd reference = llt.matrixL();
  EXPECT_LT((lowerOf(block) - reference).cwiseAbs().maxCoeff(), 1e-8 * prior);
  EXPECT_GT(block.diagonal().array().square().minCoeff(), 1e-13 * prior);
  // Every lower step of the ladder, no jitter first, leaves pivots that are rounding noise.
  int lower_steps = 0;
  for (double step : gpatlas_core::jitterLadder(CholeskyConfig(), prior)) {
    if (step >= jitter) break;
    Eigen::MatrixXd lower_step = lowerOf(k + step * Eigen::MatrixXd::Identity(n, n));
    EXPECT_FALSE(gpatlas_core::choleskyWellConditioned(lower_step, prior, CholeskyConfig())) << step;
    ++lower_steps;
  }
  EXPECT_GE(lower_steps, 1);

  // Without a ladder, the singular matrix is refused.
  CholeskyConfig strict;
  strict.jitter_max_relative = 0.0;
  Eigen::MatrixXd again = lowerOf(k);
  EXPECT_LT(gpatlas_core::factoriseWithJitter(again, prior, strict), 0.0);
}

TEST(GpNumerics, LogMarginalLikelihoodIsTheGaussianDensity) {
  const Eigen::Index n = 15;
  const Eigen::MatrixXd a = randomMatrix(n, n, 3);
  const Eigen::MatrixXd k = a * a.transpose() / static_cast<double>(n) + 0.5 * Eigen::MatrixXd::Identity(n, n);
  const Eigen::VectorXd y = randomMatrix(n, 1, 4);
  Eigen::MatrixXd factor = lowerOf(k);
  ASSERT_TRUE(gpatlas_core::choleskyWellConditioned(factor, 1.0, CholeskyConfig()));
  const Eigen::VectorXd alpha = gpatlas_core::solveWithFactor(factor, y);
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(k);
  EXPECT_LT((alpha - lu.solve(y)).norm(), 1e-10 * alpha.norm());
  const double expected = -0.5 * y.dot(lu.inverse() * y) - 0.5 * std::log(lu.determinant()) -
                          0.5 * static_cast<double>(n) * std::log(2.0 * kPi);
  EXPECT_NEAR(gpatlas_core::logMarginalLikelihood(factor, y, alpha), expected, 1e-9 * std::abs(expected));
}

// A GP with a Matern 5/2 kernel and noise: K(theta)_ij = k(|x_i - x_j|) + delta_ij noise^2, in
// theta = (log sigma, log length, log noise).
struct MaternGp {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;

  Eigen::MatrixXd covariance(const Eigen::Vector3d& theta) const {
    const Matern52Kernel kernel(std::exp(theta[0]), std::exp(theta[1]));
    const Eigen::Index n = x.cols();
    Eigen::MatrixXd k(n, n);
    for (Eigen::Index j = 0; j < n; ++j)
      for (Eigen::Index i = 0; i < n; ++i) k(i, j) = kernel.value((x.col(i) - x.col(j)).norm());
    k.diagonal().array() += std::exp(2.0 * theta[2]);
    return k;
  }
  double logLikelihood(const Eigen::Vector3d& theta, Eigen::Vector3d* gradient) const {
    Eigen::MatrixXd factor = covariance(theta);
    if (!gpatlas_core::choleskyWellConditioned(factor, 1.0, CholeskyConfig())) return std::nan("");
    const Eigen::VectorXd alpha = gpatlas_core::solveWithFactor(factor, y);
    if (gradient) {
      const Matern52Kernel kernel(std::exp(theta[0]), std::exp(theta[1]));
      *gradient = gpatlas_core::logMarginalLikelihoodGradient(factor, alpha, 3, [&](Eigen::Index i, Eigen::Index j, double* d) {
        kernel.paramGradient((x.col(i) - x.col(j)).norm(), d);
        d[2] = i == j ? 2.0 * std::exp(2.0 * theta[2]) : 0.0;
      });
    }
    return gpatlas_core::logMarginalLikelihood(factor, y, alpha);
  }
};

MaternGp randomGp(unsigned seed) {
  MaternGp gp;
  gp.x = randomMatrix(3, 25, seed) * 0.5;
  gp.y = Eigen::VectorXd(25);
  for (Eigen::Index i = 0; i < 25; ++i) gp.y[i] = std::sin(3.0 * gp.x(0, i)) + 0.5 * gp.x(1, i) * gp.x(2, i);
  return gp;
}

TEST(GpNumerics, TheLikelihoodGradientMatchesFiniteDifferences) {
  const MaternGp gp = randomGp(5);
  for (const Eigen::Vector3d& theta : {Eigen::Vector3d(0.0, std::log(0.4), std::log(0.1)),
                                      Eigen::Vector3d(std::log(0.3), std::log(1.2), std::log(0.02))}) {
    Eigen::Vector3d gradient;
    ASSERT_TRUE(std::isfinite(gp.logLikelihood(theta, &gradient)));
    for (int p = 0; p < 3; ++p) {
      const double h = 1e-5;
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(p) * h;
      const double fd = (gp.logLikelihood(theta + e, nullptr) - gp.logLikelihood(theta - e, nullptr)) / (2.0 * h);
      EXPECT_NEAR(gradient[p], fd, 1e-5 * std::max(1.0, std::abs(fd))) << "parameter " << p;
    }
  }
}

TEST(GpNumerics, TheBoundedMaximiserFindsAnInteriorMaximumAndStopsAtABound) {
  // f = -(x0 - 0.3)^2 - 2 (x1 - 5)^2 on [-1, 1] x [-1, 2]: the maximum is at (0.3, 2).
  const gpatlas_core::BoundedObjective f = [](const Eigen::VectorXd& x, Eigen::VectorXd* gradient) {
    if (gradient) *gradient = Eigen::Vector2d(-2.0 * (x[0] - 0.3), -4.0 * (x[1] - 5.0));
    return -(x[0] - 0.3) * (x[0] - 0.3) - 2.0 * (x[1] - 5.0) * (x[1] - 5.0);
  };
  const gpatlas_core::BoundedMaximum best =
      gpatlas_core::maximiseBounded(f, Eigen::Vector2d(-0.5, 0.0), Eigen::Vector2d(-1.0, -1.0), Eigen::Vector2d(1.0, 2.0), 100);
  ASSERT_TRUE(best.usable) << best.message;
  EXPECT_NEAR(best.x[0], 0.3, 1e-3);
  EXPECT_GT(best.x[1], 1.99);
  EXPECT_NEAR(best.value, -18.0, 0.1);  // f(0.3, 2)
  EXPECT_GT(best.iterations, 0);
}

TEST(GpNumerics, TheBoundedMaximiserRaisesAGpsLikelihood) {
  const MaternGp gp = randomGp(6);
  const Eigen::Vector3d start(0.0, std::log(0.1), std::log(0.3));
  const gpatlas_core::BoundedObjective f = [&](const Eigen::VectorXd& theta, Eigen::VectorXd* gradient) {
    Eigen::Vector3d g;
    const double value = gp.logLikelihood(theta, gradient ? &g : nullptr);
    if (gradient) *gradient = g;
    return value;
  };
  const Eigen::Vector3d lower(std::log(0.01), std::log(0.05), std::log(1e-3)), upper(std::log(10.0), std::log(5.0), 0.0);
  const gpatlas_core::BoundedMaximum best = gpatlas_core::maximiseBounded(f, start, lower, upper, 50);
  ASSERT_TRUE(best.usable) << best.message;
  EXPECT_GT(best.value, f(start, nullptr) + 1.0);
  EXPECT_TRUE((best.x.array() >= lower.array()).all() && (best.x.array() <= upper.array()).all());
  // At an interior maximum the gradient vanishes.
  Eigen::VectorXd gradient;
  f(best.x, &gradient);
  for (int p = 0; p < 3; ++p) {
    if (best.x[p] > lower[p] + 0.1 && best.x[p] < upper[p] - 0.1) {
      EXPECT_LT(std::abs(gradient[p]), 1e-2) << p;
    }
  }
}

TEST(GpNumerics, MaternFiveHalvesIsItsClosedForm) {
  const double sigma = 0.3, length = 0.004;
  const Matern52Kernel kernel(sigma, length);
  for (double r : {0.0, 0.001, 0.004, 0.01, 0.03}) {
    // Rasmussen and Williams eq. 4.17 with nu = 5/2.
    const double s = std::sqrt(5.0) * r / length;
    const double expected = sigma * sigma * (1.0 + s + 5.0 * r * r / (3.0 * length * length)) * std::exp(-s);
    EXPECT_NEAR(kernel.value(r), expected, 1e-15) << r;
    // (dk/dr) / r, from central differences of k.
    if (r > 0.0) {
      const double h = 1e-8;
      const double fd = (kernel.value(r + h) - kernel.value(r - h)) / (2.0 * h);
      EXPECT_NEAR(kernel.derivativeOverDistance(r) * r, fd, 1e-5 * std::abs(fd)) << r;
      EXPECT_NEAR(kernel.derivative(r), fd, 1e-5 * std::abs(fd)) << r;
    }
  }
  // At the origin (dk/dr) / r tends to k''(0).
  EXPECT_NEAR(kernel.derivativeOverDistance(0.0), kernel.secondDerivative(0.0), 1e-9 * std::abs(kernel.secondDerivative(0.0)));
}

}  // namespace
