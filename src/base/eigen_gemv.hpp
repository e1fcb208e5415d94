#pragma once
// kfx's binding of Eigen's general matrix-vector products to the BLAS (private; docs/performance.md,
// "Matrix-vector products"). The library compiles with EIGEN_USE_BLAS, and Eigen's binding
// (Eigen/src/Core/products/GeneralMatrixVector_BLAS.h) sends every matrix-vector product to DGEMV, also
// the empty ones (DGEMV with LDA = 0: an illegal value, which OpenBLAS reports on stdout and skips) and
// the 2 x 2 ones (a BLAS call costs more than the product). KFX_EIGEN_DEFINITIONS renames the DGEMV that
// binding calls (dgemv_=kfx_eigen_dgemv, one compile definition, so every translation unit sees the same
// binding), and kfx_eigen_dgemv decides: empty products are the quick return of the reference DGEMV,
// products of at most kEigenGemvMaxEntries matrix entries run in Eigen's own kernel, larger ones in DGEMV.

namespace kfx::detail {

/// Largest m * n of A (m x n) that stays in Eigen's own kernel; larger products go to DGEMV. Measured
/// with bench/bench_gemv.cpp (docs/benchmarks.md, "Matrix-vector products"): Eigen's kernel costs
/// 0.3-0.6x DGEMV's time up to 8 x 8 and about the same at 16 x 16 (A x) to 24 x 24 (A^T x), and 1.2-2x
/// above (OpenBLAS's AVX-512 kernel against Eigen's SSE2 build).
constexpr long kEigenGemvMaxEntries = 256;

/// y = alpha op(A) x + beta y in Eigen's own kernel (no BLAS call), with DGEMV's arguments: trans 'N'
/// (op(A) = A) or 'T' / 'C' (op(A) = A^T), A m x n column-major with leading dimension lda >= max(1, m).
/// beta = 0 sets y without reading it, as DGEMV does.
void EigenGemv(char trans, int m, int n, double alpha, const double* a, int lda, const double* x, int incx, double beta,
               double* y, int incy);

}  // namespace kfx::detail
