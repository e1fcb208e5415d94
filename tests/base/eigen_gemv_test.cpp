// kfx's binding of Eigen's matrix-vector products to the BLAS (src/base/eigen_gemv.hpp): products with an
// empty operand make no BLAS call (Eigen's own binding sent them to DGEMV with LDA = 0, an illegal value
// that OpenBLAS reports on stdout and skips), small products stay in Eigen's kernel, large ones go to
// DGEMV, and every one of them equals a plain loop. This executable defines xerbla_, the routine every
// BLAS calls on an illegal argument (OpenBLAS's is weak), and dgemv_ / dgemm_, which count the calls and
// forward them to the library (the definitions in the executable take precedence over the shared BLAS).
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "base/eigen_gemv.hpp"
#include "support/matrix_testing.hpp"

#undef dgemv_  // this file defines the BLAS's own DGEMV (KFX_EIGEN_DEFINITIONS renames Eigen's calls to it)

namespace {
std::atomic<long> g_illegal{0}, g_dgemv{0}, g_dgemm{0};
std::string g_last_illegal;

using DgemvFn = void (*)(const char*, const int*, const int*, const double*, const double*, const int*, const double*,
                         const int*, const double*, double*, const int*, std::size_t);
using DgemmFn = int (*)(const char*, const char*, const int*, const int*, const int*, const double*, const double*,
                        const int*, const double*, const int*, const double*, double*, const int*);
}  // namespace

extern "C" {
// Eigen's blas.h declaration. Counts instead of printing.
int xerbla_(const char* name, int* info, int len) {
  ++g_illegal;
  g_last_illegal =
      std::string(name, static_cast<std::size_t>(len > 0 && len < 8 ? len : 6)) + " parameter " + std::to_string(*info);
  return 0;
}

void dgemv_(const char* trans, const int* m, const int* n, const double* alpha, const double* a, const int* lda,
            const double* x, const int* incx, const double* beta, double* y, const int* incy, std::size_t len) {
  ++g_dgemv;
  static const auto next = reinterpret_cast<DgemvFn>(dlsym(RTLD_NEXT, "dgemv_"));
  if (next == nullptr) std::abort();  // no BLAS after this executable: the test would compare nothing
  next(trans, m, n, alpha, a, lda, x, incx, beta, y, incy, len);
}

int dgemm_(const char* ta, const char* tb, const int* m, const int* n, const int* k, const double* alpha,
           const double* a, const int* lda, const double* b, const int* ldb, const double* beta, double* c,
           const int* ldc) {
  ++g_dgemm;
  static const auto next = reinterpret_cast<DgemmFn>(dlsym(RTLD_NEXT, "dgemm_"));
  if (next == nullptr) std::abort();
  return next(ta, tb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc);
}
}

namespace kfx {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

void ResetCounts() {
  g_illegal = 0;
  g_dgemv = 0;
  g_dgemm = 0;
}

// A B by loops (an empty sum is 0).
MatrixXd LoopProduct(const MatrixXd& A, const MatrixXd& B) {
  MatrixXd C = MatrixXd::Zero(A.rows(), B.cols());
  for (Index i = 0; i < A.rows(); ++i)
    for (Index j = 0; j < B.cols(); ++j)
      for (Index l = 0; l < A.cols(); ++l) C(i, j) += A(i, l) * B(l, j);
  return C;
}

// Every product shape with an empty operand, as a matrix-vector product (both orientations, plain and
// accumulated) and as a matrix-matrix product, at sizes below and above Eigen's lazy-product threshold.
TEST(EigenGemv, ProductsWithAnEmptyOperandMakeNoBlasCallAndAreEmptyOrZero) {
  ResetCounts();
  testing::TestRng rng(1);
  for (const Index k : {1, 3, 40}) {
    for (const auto& [m, inner] : std::vector<std::pair<Index, Index>>{{0, k}, {k, 0}, {0, 0}}) {
      SCOPED_TRACE("m = " + std::to_string(m) + ", inner = " + std::to_string(inner));
      const MatrixXd A = rng.Gaussian(m, inner);  // m x inner
      const VectorXd x = rng.Gaussian(inner, 1);
      const VectorXd y = A * x;  // 0 x k times k x 1, k x 0 times 0 x 1, 0 x 0 times 0 x 1
      EXPECT_EQ(y.size(), m);
      EXPECT_TRUE(y.isZero(0.0));
      const VectorXd w = rng.Gaussian(m, 1);
      const VectorXd yt = A.transpose() * w;  // transposed: k x 0 times 0 x 1, 0 x k times k x 1
      EXPECT_EQ(yt.size(), inner);
      EXPECT_TRUE(yt.isZero(0.0));
      const Eigen::RowVectorXd row = w.transpose() * A;  // a row vector from the left
      EXPECT_EQ(row.size(), inner);
      EXPECT_TRUE(row.isZero(0.0));
      VectorXd acc = VectorXd::Constant(m, 2.0);
      acc.noalias() += A * x;  // an accumulated empty product leaves the result as it was
      EXPECT_TRUE(acc.isApproxToConstant(2.0, 0.0));
      for (const Index cols : {Index{0}, Index{1}, k}) {
        const MatrixXd B = rng.Gaussian(inner, cols);
        const MatrixXd C = A * B;  // GEMM with an empty operand (or an empty result)
        EXPECT_EQ(C.rows(), m);
        EXPECT_EQ(C.cols(), cols);
        EXPECT_TRUE(C.isZero(0.0));
        MatrixXd D = MatrixXd::Constant(m, cols, -1.0);
        D.noalias() -= A * B;
        EXPECT_TRUE(D.isApproxToConstant(-1.0, 0.0));
      }
    }
  }
  EXPECT_EQ(g_illegal.load(), 0) << g_last_illegal;
  EXPECT_EQ(g_dgemv.load(), 0);
  EXPECT_EQ(g_dgemm.load(), 0);
}

// Small products stay in Eigen's kernel, large ones go to DGEMV; both equal the loop product: A x with x
// of increment 3 (a row of a matrix), A^T v accumulated, and A^T v into a result of increment 2.
TEST(EigenGemv, SmallProductsStayInEigenAndLargeOnesGoToDgemv) {
  testing::TestRng rng(2);
  for (const bool large : {false, true}) {
    for (const Index cols : {Index{2}, Index{7}, Index{64}}) {  // (one column: Eigen makes A^T v a dot product)
      const Index rows = detail::kEigenGemvMaxEntries / cols + (large ? 1 : 0);
      SCOPED_TRACE(std::to_string(rows) + " x " + std::to_string(cols));
      const MatrixXd A = rng.Gaussian(rows, cols);
      const MatrixXd X = rng.Gaussian(3, cols);
      const VectorXd v = rng.Gaussian(rows, 1);
      ResetCounts();
      const VectorXd y = A * X.row(1).transpose();
      VectorXd z = VectorXd::Ones(cols);
      z.noalias() += A.transpose() * v;
      MatrixXd Y = MatrixXd::Zero(2, cols);
      Y.row(1).transpose().noalias() += A.transpose() * v;
      EXPECT_EQ(g_dgemv.load(), large ? 3 : 0);
      EXPECT_EQ(g_illegal.load(), 0) << g_last_illegal;
      // Rounding of sums of `inner` products of standard normals, with a wide margin.
      EXPECT_MATRICES_NEAR(y, LoopProduct(A, X.row(1).transpose()), 1e-13 * static_cast<double>(cols));
      const MatrixXd Atv = LoopProduct(A.transpose(), v);
      EXPECT_MATRICES_NEAR(z, VectorXd(VectorXd::Ones(cols) + Atv), 1e-13 * static_cast<double>(rows));
      EXPECT_MATRICES_NEAR(Y.row(1).transpose(), Atv, 1e-13 * static_cast<double>(rows));
    }
  }
}

// The kernel itself with DGEMV's full argument set: beta (0 without reading y, 1, other), increments of
// x and y, trans 'N' and 'T', alpha = 0, and empty shapes with LDA = 0.
TEST(EigenGemv, KernelFollowsDgemvArguments) {
  testing::TestRng rng(3);
  const int m = 5, n = 3, lda = 7;
  const MatrixXd storage = rng.Gaussian(lda, n);  // A = its top m rows, leading dimension 7
  const MatrixXd A = storage.topRows(m);
  for (const char trans : {'N', 'T'}) {
    const int len_x = trans == 'N' ? n : m, len_y = trans == 'N' ? m : n;
    const MatrixXd opA = trans == 'N' ? A : MatrixXd(A.transpose());
    for (const int incx : {1, 2}) {
      for (const int incy : {1, 3}) {
        for (const double beta : {0.0, 1.0, -0.5}) {
          const VectorXd xs = rng.Gaussian(len_x * incx, 1);
          VectorXd ys = rng.Gaussian(len_y * incy, 1);
          if (beta == 0.0) ys.setConstant(std::numeric_limits<double>::quiet_NaN());  // not read
          VectorXd x(len_x), y0(len_y);
          for (int i = 0; i < len_x; ++i) x(i) = xs(i * incx);
          for (int i = 0; i < len_y; ++i) y0(i) = beta == 0.0 ? 0.0 : ys(i * incy);
          detail::EigenGemv(trans, m, n, 1.5, storage.data(), lda, xs.data(), incx, beta, ys.data(), incy);
          VectorXd y(len_y);
          for (int i = 0; i < len_y; ++i) y(i) = ys(i * incy);
          EXPECT_MATRICES_NEAR(y, VectorXd(1.5 * LoopProduct(opA, x) + beta * y0), 1e-14);
        }
      }
    }
  }
  VectorXd y = VectorXd::Constant(4, 3.0);
  const VectorXd x = VectorXd::Ones(4);
  detail::EigenGemv('N', 4, 4, 0.0, nullptr, 4, x.data(), 1, 2.0, y.data(), 1);  // alpha = 0: y = beta y
  EXPECT_TRUE(y.isApproxToConstant(6.0, 0.0));
  detail::EigenGemv('N', 4, 0, 1.0, nullptr, 0, nullptr, 1, 0.5, y.data(), 1);  // n = 0, LDA = 0
  EXPECT_TRUE(y.isApproxToConstant(3.0, 0.0));
  detail::EigenGemv('T', 0, 4, 1.0, nullptr, 0, nullptr, 1, 1.0, y.data(), 1);  // m = 0, LDA = 0
  EXPECT_TRUE(y.isApproxToConstant(3.0, 0.0));
}

}  // namespace
}  // namespace kfx
