#include "gpatlas_core/common/dense_solve.h"

#include <cblas.h>

#include <limits>
#include <mutex>
#include <stdexcept>

extern "C" {
// LAPACK's Cholesky factorisation (OpenBLAS ships LAPACK), with OpenBLAS's integer type so that a
// 64-bit-index build links the matching symbol.
void dpotrf_(const char* uplo, const blasint* n, double* a, const blasint* lda, blasint* info);
}

namespace gpatlas_core {
namespace {

// OpenBLAS would otherwise start a thread per core inside calls that TBB already runs on every
// core.
void useOneBlasThread() {
  static std::once_flag once;
  std::call_once(once, [] { openblas_set_num_threads(1); });
}

blasint checkedInt(Eigen::Index value) {
  if (value > static_cast<Eigen::Index>(std::numeric_limits<blasint>::max()))
    throw std::length_error("dense solve: a dimension exceeds BLAS's integer range");
  return static_cast<blasint>(value);
}

}  // namespace

void solveLowerInPlace(const Eigen::MatrixXd& factor, Eigen::Index n, Eigen::Ref<Eigen::MatrixXd> rhs, bool transposed) {
  if (n < 0 || n > factor.rows() || n > factor.cols() || rhs.rows() != n)
    throw std::invalid_argument("solveLowerInPlace: the right-hand side must have n rows, n within the factor");
  if (n == 0 || rhs.cols() == 0) return;
  useOneBlasThread();
  const CBLAS_TRANSPOSE op = transposed ? CblasTrans : CblasNoTrans;
  if (rhs.cols() == 1) {
    // One right-hand side: the matrix-vector solve reads the factor once without packing it.
    cblas_dtrsv(CblasColMajor, CblasLower, op, CblasNonUnit, checkedInt(n), factor.data(), checkedInt(factor.rows()),
                rhs.data(), 1);
    return;
  }
  cblas_dtrsm(CblasColMajor, CblasLeft, CblasLower, op, CblasNonUnit, checkedInt(n), checkedInt(rhs.cols()), 1.0,
              factor.data(), checkedInt(factor.rows()), rhs.data(), checkedInt(rhs.outerStride()));
}

bool choleskyLowerInPlace(Eigen::Ref<Eigen::MatrixXd> block) {
  if (block.rows() != block.cols()) throw std::invalid_argument("choleskyLowerInPlace: the block must be square");
  if (block.rows() == 0) return true;
  useOneBlasThread();
  const char lower = 'L';
  const blasint n = checkedInt(block.rows()), lda = checkedInt(block.outerStride());
  blasint info = 0;
  dpotrf_(&lower, &n, block.data(), &lda, &info);
  return info == 0;
}

}  // namespace gpatlas_core
