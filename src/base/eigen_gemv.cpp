// kfx_eigen_dgemv, the DGEMV that Eigen's matrix-vector BLAS binding calls in kfx (src/base/eigen_gemv.hpp).
#include "base/eigen_gemv.hpp"

#include <Eigen/Core>
#include <cstddef>

// This file calls the BLAS's own DGEMV: the renaming of KFX_EIGEN_DEFINITIONS is lifted here, after
// Eigen's blas.h has declared kfx_eigen_dgemv.
#undef dgemv_

extern "C" {
// gfortran convention (src/base/lapack_fortran.hpp): the hidden length of trans last.
void dgemv_(const char* trans, const int* m, const int* n, const double* alpha, const double* a, const int* lda,
            const double* x, const int* incx, const double* beta, double* y, const int* incy, std::size_t trans_len);
}

namespace kfx::detail {
namespace {

using Eigen::Index;
using Eigen::internal::const_blas_data_mapper;
using Eigen::internal::general_matrix_vector_product;

// res(0 : rows) += alpha A x, A rows x cols column-major: Eigen's generic (BuiltIn) kernel, the one Eigen
// uses without EIGEN_USE_BLAS. res contiguous; x with increment incx.
void KernelN(Index rows, Index cols, double alpha, const double* a, Index lda, const double* x, Index incx,
             double* res) {
  using Lhs = const_blas_data_mapper<double, Index, Eigen::ColMajor>;
  using Rhs = const_blas_data_mapper<double, Index, Eigen::RowMajor>;
  general_matrix_vector_product<Index, double, Lhs, Eigen::ColMajor, false, double, Rhs, false, Eigen::BuiltIn>::run(
      rows, cols, Lhs(a, lda), Rhs(x, incx), res, 1, alpha);
}

// res(0 : cols) += alpha A^T x (increment incy), A rows x cols column-major, i.e. the row-major cols x rows
// matrix A^T; x contiguous.
void KernelT(Index rows, Index cols, double alpha, const double* a, Index lda, const double* x, double* res,
             Index incy) {
  using Lhs = const_blas_data_mapper<double, Index, Eigen::RowMajor>;
  using Rhs = const_blas_data_mapper<double, Index, Eigen::ColMajor>;
  general_matrix_vector_product<Index, double, Lhs, Eigen::RowMajor, false, double, Rhs, false, Eigen::BuiltIn>::run(
      cols, rows, Lhs(a, lda), Rhs(x, 1), res, incy, alpha);
}

// y = beta y over len entries (beta = 0: set, without reading y, as DGEMV does).
void Scale(int len, double beta, double* y, int incy) {
  if (beta == 1.0) return;
  for (std::ptrdiff_t i = 0; i < len; ++i) {
    double& yi = y[i * incy];
    yi = beta == 0.0 ? 0.0 : beta * yi;
  }
}

}  // namespace

void EigenGemv(char trans, int m, int n, double alpha, const double* a, int lda, const double* x, int incx, double beta,
               double* y, int incy) {
  const bool transposed = trans != 'N' && trans != 'n';
  const int len_y = transposed ? n : m, len_x = transposed ? m : n;
  Scale(len_y, beta, y, incy);
  if (m == 0 || n == 0 || alpha == 0.0) return;
  using Strided = Eigen::Map<Eigen::VectorXd, 0, Eigen::InnerStride<>>;
  if (!transposed) {
    // The column-major kernel needs a contiguous result (Eigen's own product evaluator guarantees it).
    if (incy == 1) return KernelN(m, n, alpha, a, lda, x, incx, y);
    Eigen::VectorXd res = Eigen::VectorXd::Zero(len_y);
    KernelN(m, n, alpha, a, lda, x, incx, res.data());
    Strided(y, len_y, Eigen::InnerStride<>(incy)) += res;
    return;
  }
  // The row-major kernel needs a contiguous x (likewise).
  if (incx == 1) return KernelT(m, n, alpha, a, lda, x, y, incy);
  const Eigen::VectorXd xc =
      Eigen::Map<const Eigen::VectorXd, 0, Eigen::InnerStride<>>(x, len_x, Eigen::InnerStride<>(incx));
  KernelT(m, n, alpha, a, lda, xc.data(), y, incy);
}

}  // namespace kfx::detail

// Eigen's binding calls this function for every matrix-vector product of doubles (its DGEMV, renamed
// by KFX_EIGEN_DEFINITIONS; the declaration is Eigen's blas.h).
extern "C" int kfx_eigen_dgemv(const char* trans, const int* m, const int* n, const double* alpha, const double* a,
                               const int* lda, const double* x, const int* incx, const double* beta, double* y,
                               const int* incy) {
  const bool positive_increments = *incx > 0 && *incy > 0;
  // Empty products (m = 0 or n = 0, LDA possibly 0) and small ones stay in Eigen, as do the negative
  // increments Eigen never passes (DGEMV would walk them backwards).
  if (positive_increments && static_cast<long>(*m) * static_cast<long>(*n) <= kfx::detail::kEigenGemvMaxEntries) {
    kfx::detail::EigenGemv(*trans, *m, *n, *alpha, a, *lda, x, *incx, *beta, y, *incy);
    return 0;
  }
  dgemv_(trans, m, n, alpha, a, lda, x, incx, beta, y, incy, 1);
  return 0;
}
