// The BLAS- and LAPACK-backed dense steps against Eigen's own factorisation and solves, on
// factors stored with spare capacity as GpisModel keeps them.
#include "gpatlas_core/common/dense_solve.h"

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <cstdlib>
#include <stdexcept>

namespace gpatlas_core {
namespace {

Eigen::MatrixXd randomSpd(Eigen::Index n, unsigned seed) {
  std::srand(seed);
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  return a * a.transpose() / static_cast<double>(n) + 0.1 * Eigen::MatrixXd::Identity(n, n);
}

TEST(DenseSolve, CholeskyOfABlockWithSpareCapacityReproducesTheMatrix) {
  const Eigen::Index n = 300, capacity = 345;
  const Eigen::MatrixXd k = randomSpd(n, 1);
  Eigen::MatrixXd storage = Eigen::MatrixXd::Constant(capacity, capacity, 7.0);
  storage.topLeftCorner(n, n) = k;
  ASSERT_TRUE(choleskyLowerInPlace(storage.topLeftCorner(n, n)));
  const Eigen::MatrixXd l = storage.topLeftCorner(n, n).triangularView<Eigen::Lower>();
  EXPECT_LT((l * l.transpose() - k).cwiseAbs().maxCoeff(), 1e-12);
  // The same factor as Eigen's (positive diagonal: the factor is unique).
  const Eigen::MatrixXd eigen_l = k.llt().matrixL();
  EXPECT_LT((l - eigen_l).cwiseAbs().maxCoeff(), 1e-12);
  // Outside the block, and above the diagonal, nothing changed.
  EXPECT_TRUE((storage.rightCols(capacity - n).array() == 7.0).all());
  EXPECT_TRUE((storage.bottomRows(capacity - n).array() == 7.0).all());
  EXPECT_DOUBLE_EQ(storage(0, n - 1), k(0, n - 1));
}

TEST(DenseSolve, CholeskyRefusesAnIndefiniteMatrix) {
  Eigen::MatrixXd k = randomSpd(50, 2);
  k(20, 20) = -1.0;
  EXPECT_FALSE(choleskyLowerInPlace(k));
  Eigen::MatrixXd not_square(3, 4);
  EXPECT_THROW(choleskyLowerInPlace(not_square), std::invalid_argument);
  Eigen::MatrixXd empty(0, 0);
  EXPECT_TRUE(choleskyLowerInPlace(empty));
}

TEST(DenseSolve, TriangularSolvesMatchEigenForBlocksVectorsAndTransposes) {
  const Eigen::Index n = 257, capacity = 300;
  const Eigen::MatrixXd k = randomSpd(n, 3);
  Eigen::MatrixXd factor = Eigen::MatrixXd::Zero(capacity, capacity);
  factor.topLeftCorner(n, n) = k.llt().matrixL();
  const auto lower = factor.topLeftCorner(n, n).triangularView<Eigen::Lower>();
  for (const Eigen::Index columns : {1, 7, 130}) {
    const Eigen::MatrixXd b = Eigen::MatrixXd::Random(n, columns);
    Eigen::MatrixXd x = b;
    solveLowerInPlace(factor, n, x);
    EXPECT_LT((lower * x - b).cwiseAbs().maxCoeff(), 1e-10) << columns << " columns";
    Eigen::MatrixXd xt = b;
    solveLowerInPlace(factor, n, xt, /*transposed=*/true);
    EXPECT_LT((lower.transpose() * xt - b).cwiseAbs().maxCoeff(), 1e-10) << columns << " columns";
  }
  // A vector, and K^-1 b by the two solves.
  const Eigen::VectorXd b = Eigen::VectorXd::Random(n);
  Eigen::VectorXd alpha = b;
  solveLowerInPlace(factor, n, alpha);
  solveLowerInPlace(factor, n, alpha, /*transposed=*/true);
  EXPECT_LT((k * alpha - b).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(DenseSolve, RefusesARightHandSideOfTheWrongHeight) {
  Eigen::MatrixXd factor = Eigen::MatrixXd::Identity(10, 10);
  Eigen::MatrixXd rhs(9, 2);
  EXPECT_THROW(solveLowerInPlace(factor, 10, rhs), std::invalid_argument);
  EXPECT_THROW(solveLowerInPlace(factor, 11, rhs), std::invalid_argument);
  Eigen::MatrixXd none(0, 3);
  EXPECT_NO_THROW(solveLowerInPlace(factor, 0, none));
}

}  // namespace
}  // namespace gpatlas_core
