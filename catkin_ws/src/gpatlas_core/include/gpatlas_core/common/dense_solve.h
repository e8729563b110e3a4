#pragma once

#include <Eigen/Core>

namespace gpatlas_core {

// The GPIS's large dense steps, done by the system's optimised BLAS and LAPACK (OpenBLAS, which
// picks its kernels for the CPU it runs on) rather than by Eigen's portable code: a variance query
// is a triangular solve against an n x n factor, and Eigen, built for any x86-64, would pack that
// factor into SSE2 panels on every query. Single-threaded: callers run them in parallel already.

// Solves L X = B (or L^T X = B when `transposed`) in place, for the lower-triangular L in the
// top-left n x n block of `factor` (which may have spare rows and columns beyond n); `rhs` has n
// rows.
void solveLowerInPlace(const Eigen::MatrixXd& factor, Eigen::Index n, Eigen::Ref<Eigen::MatrixXd> rhs,
                       bool transposed = false);

// Overwrites the lower triangle of the symmetric positive definite `block` (its lower triangle is
// read) with its Cholesky factor L (block = L L^T). False when it is not positive definite; the
// lower triangle is then partly overwritten. The strict upper triangle is left as it was.
bool choleskyLowerInPlace(Eigen::Ref<Eigen::MatrixXd> block);

}  // namespace gpatlas_core
