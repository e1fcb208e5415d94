// Class 16 of docs/robustness.md: kfx sends no symmetric matrix-vector product to the BLAS. Eigen's
// BLAS binding would send every selfadjointView() * vector to DSYMV, down to the 1 x 1 steps of the
// tridiagonalization inside SelfAdjointEigenSolver (the health monitor's smallest eigenvalue, the PSD
// checks of validation), and OpenBLAS 0.3.21's Prescott DSYMV reads past small operands. This
// executable defines dsymv_ itself (the definition in the executable takes precedence over the
// shared OpenBLAS), counts the calls and forwards them to the library's DSYMV.
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <atomic>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/simulation.hpp"
#include "kfx/validation.hpp"
#include "support/matrix_testing.hpp"

namespace {
std::atomic<long> g_dsymv_calls{0};
using DsymvFn = void (*)(const char*, const int*, const double*, const double*, const int*, const double*, const int*,
                         const double*, double*, const int*);
}  // namespace

// The declaration of Eigen's blas.h (EIGEN_USE_BLAS), which returns int.
extern "C" int dsymv_(const char* uplo, const int* n, const double* alpha, const double* a, const int* lda,
                      const double* x, const int* incx, const double* beta, double* y, const int* incy) {
  ++g_dsymv_calls;
  static const auto next = reinterpret_cast<DsymvFn>(dlsym(RTLD_NEXT, "dsymv_"));
  if (next != nullptr) next(uplo, n, alpha, a, lda, x, incx, beta, y, incy);
  return 0;
}

namespace kfx {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

TEST(BlasCalls, SymmetricMatrixVectorProductsStayInEigen) {
  g_dsymv_calls = 0;
  // The products themselves, small and large, against the plain product of the full matrix.
  testing::TestRng rng(3);
  for (const int n : {1, 2, 3, 8, 200}) {
    const MatrixXd S = rng.Spd(n, 1.0);
    const VectorXd v = rng.Gaussian(n, 1);
    const VectorXd y = S.selfadjointView<Eigen::Lower>() * v;
    EXPECT_MATRICES_NEAR(y, S * v, 1e-12 * n);
    // The eigen solver tridiagonalizes with symmetric products.
    Eigen::SelfAdjointEigenSolver<MatrixXd> eig(S);
    EXPECT_MATRICES_NEAR(eig.eigenvectors() * eig.eigenvalues().asDiagonal() * eig.eigenvectors().transpose(), S,
                         1e-10 * n);
  }
  // kfx's own call sites: validation's definiteness check and the health monitor of a filter run.
  EXPECT_THROW(RequirePositiveSemidefinite("P", (MatrixXd(2, 2) << 1, 2, 2, 1).finished()), Error);
  const int n = 2, m = 1;
  const MatrixXd A = rng.WithSpectralRadius(n, 0.9);
  const MatrixXd P0 = rng.Spd(n, 1.0);  // one draw per statement, in GCC's former order of the arguments
  const MatrixXd R = rng.Spd(m, 0.2);
  const MatrixXd Q = rng.Spd(n, 0.1);
  const MatrixXd C = rng.Gaussian(m, n);
  const Model model(MakeStep(A, C, Q, R), VectorXd::Zero(n), P0);
  FilterRunOptions o;
  o.monitor_health = true;
  const FilterRun run = RunFilter(model, Simulate(model, {100, 5}).y, o);
  EXPECT_EQ(run.health.steps, 100);
  EXPECT_GT(run.health.min_eigenvalue, 0.0);
  EXPECT_EQ(g_dsymv_calls.load(), 0);
}

}  // namespace
}  // namespace kfx
