// Tests of the Stein solvers on the real Schur form (src/riccati/schur_stein.cpp). Oracles: the
// Kronecker-product linear systems (I - B (x) A) vec Y = vec F and (I - A (x) A) vec X = vec Q for small
// sizes, SLICOT SB04QD (SolveDiscreteSylvester) and the squared Smith iteration at larger seeded random
// sizes across the recursion's base size (32) and 2 x 2 blocks at the splits, residuals, and the
// singular case.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "kfx/riccati.hpp"
#include "riccati/schur_stein.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using kfx::testing::RelativeDifference;
using kfx::testing::TestRng;

// Y = A Y B^T + F:  (I - B (x) A) vec Y = vec F (column-major vec).
MatrixXd KroneckerStein(const MatrixXd& A, const MatrixXd& B, const MatrixXd& F) {
  const Eigen::Index n = A.rows(), m = B.rows();
  MatrixXd K(n * m, n * m);
  for (Eigen::Index i = 0; i < m; ++i)
    for (Eigen::Index j = 0; j < m; ++j) K.block(i * n, j * n, n, n) = B(i, j) * A;
  K = MatrixXd::Identity(n * m, n * m) - K;
  const Eigen::VectorXd f = Eigen::Map<const Eigen::VectorXd>(F.data(), n * m);
  const Eigen::VectorXd y = K.fullPivLu().solve(f);
  return Eigen::Map<const MatrixXd>(y.data(), n, m);
}

double SteinResidual(const MatrixXd& A, const MatrixXd& B, const MatrixXd& F, const MatrixXd& Y) {
  return (Y - A * Y * B.transpose() - F).norm() / Y.norm();
}

TEST(SchurStein, SchurFormReproducesTheMatrix) {
  TestRng rng(11);
  for (int n : {1, 2, 5, 40}) {
    const MatrixXd A = rng.Gaussian(n, n);
    const detail::RealSchur s = detail::ComputeRealSchur(A);
    ASSERT_TRUE(s.ok());
    EXPECT_LE(RelativeDifference(s.U * s.T * s.U.transpose(), A), 1e-13) << n;
    EXPECT_LE((s.U.transpose() * s.U - MatrixXd::Identity(n, n)).norm(), 1e-13) << n;
    EXPECT_NEAR(s.SpectralRadius(), SpectralRadius(A), 1e-12 * SpectralRadius(A)) << n;
  }
}

TEST(SchurStein, SylvesterAgreesWithKroneckerForSmallSizes) {
  TestRng rng(12);
  for (int n : {1, 2, 3, 6, 9})
    for (int m : {1, 2, 4, 7}) {
      const MatrixXd A = rng.WithSpectralRadius(n, 0.9);
      const MatrixXd B = rng.WithSpectralRadius(m, 0.97);
      const MatrixXd F = rng.Gaussian(n, m);
      MatrixXd Y;
      ASSERT_TRUE(detail::SolveSteinBySchur(detail::ComputeRealSchur(A), detail::ComputeRealSchur(B), F, &Y));
      EXPECT_LE(RelativeDifference(Y, KroneckerStein(A, B, F)), 1e-12) << n << " x " << m;
    }
}

TEST(SchurStein, LyapunovAgreesWithKroneckerForSmallSizes) {
  TestRng rng(13);
  for (int n : {1, 2, 3, 5, 8, 13}) {
    const MatrixXd A = rng.WithSpectralRadius(n, 0.95);
    const MatrixXd Q = rng.Spd(n);
    MatrixXd X;
    ASSERT_TRUE(detail::SolveLyapunovBySchur(detail::ComputeRealSchur(A), Q, &X));
    EXPECT_LE(RelativeDifference(X, KroneckerStein(A, A, Q)), 1e-12) << n;
    EXPECT_EQ((X - X.transpose()).norm(), 0.0) << n;
  }
}

// Seeded random sizes across the base size, unstable and stable A (no reciprocal pairs), against SB04QD
// and by the residual; and the Lyapunov case against the squared Smith iteration.
TEST(SchurStein, RandomSizesAgreeWithSb04qdAndSmith) {
  std::mt19937 sizes(2024);
  std::uniform_int_distribution<int> size(20, 140);
  TestRng rng(14);
  for (int trial = 0; trial < 8; ++trial) {
    const int n = size(sizes);
    const int m = size(sizes);
    const double rho_a = trial % 2 == 0 ? 0.99 : 0.6, rho_b = trial % 4 == 1 ? 1.4 : 0.95;
    const MatrixXd A = rng.WithSpectralRadius(n, rho_a);
    const MatrixXd B = rng.WithSpectralRadius(m, rho_b);
    const MatrixXd F = rng.Gaussian(n, m);
    MatrixXd Y;
    ASSERT_TRUE(detail::SolveSteinBySchur(detail::ComputeRealSchur(A), detail::ComputeRealSchur(B), F, &Y));
    EXPECT_LE(SteinResidual(A, B, F, Y), 1e-13) << n << " x " << m;
    // SB04QD: A X B - X + C = 0 is X = A X B + C, so B there is our B^T.
    const SteinSolution sb = SolveDiscreteSylvester(A, B.transpose(), F);
    ASSERT_TRUE(sb.summary.ok());
    EXPECT_LE(RelativeDifference(Y, sb.X), 1e-11) << n << " x " << m;

    const MatrixXd Q = rng.Spd(n);
    MatrixXd X;
    ASSERT_TRUE(detail::SolveLyapunovBySchur(detail::ComputeRealSchur(A), Q, &X));
    EXPECT_LE(SteinResidual(A, A, Q, X), 5e-14) << n;  // rho(A) up to 0.99
    LyapunovOptions smith;
    smith.method = LyapunovMethod::kSmith;
    const LyapunovSolution s = SolveDiscreteLyapunov(A, Q, smith);
    ASSERT_TRUE(s.summary.ok());
    EXPECT_LE(RelativeDifference(X, s.X), 1e-11) << n;
  }
}

// A rotation has eigenvalues e^{+-i theta}, whose product is 1: X = A X A^T + Q is singular.
TEST(SchurStein, ReciprocalPairIsReportedSingular) {
  const double c = std::cos(0.3), s = std::sin(0.3);
  MatrixXd A(2, 2);
  A << c, -s, s, c;
  MatrixXd X;
  EXPECT_FALSE(detail::SolveLyapunovBySchur(detail::ComputeRealSchur(A), MatrixXd::Identity(2, 2), &X));
  // 0.5 and 2 in A and B: lambda_i(A) lambda_j(B) = 1.
  const MatrixXd A2 = MatrixXd::Identity(3, 3) * 0.5, B2 = MatrixXd::Identity(2, 2) * 2.0;
  MatrixXd Y;
  EXPECT_FALSE(
      detail::SolveSteinBySchur(detail::ComputeRealSchur(A2), detail::ComputeRealSchur(B2), MatrixXd::Ones(3, 2), &Y));
}

// The shared products of the Smith iteration and the DARE (issue 24, h24l): the lower triangle of a symmetric
// product by recursive blocks against the full product, at seeded random sizes across the base size 64 and
// odd splits, with a transposed left factor as the doubling uses it; and the congruences on the lower
// triangle against Eigen's products.
TEST(SymmetricProducts, LowerTriangleAgreesWithTheFullProduct) {
  TestRng rng(2425);
  std::mt19937 pick(25);
  for (int trial = 0; trial < 6; ++trial) {
    const int n = trial == 0 ? 1 : std::uniform_int_distribution<int>(2, 300)(pick);
    const MatrixXd A = rng.Gaussian(n, n);
    const MatrixXd S = rng.Spd(n);
    const MatrixXd T = S * A;  // A^T T = A^T S A is symmetric
    const MatrixXd full = A.transpose() * T;
    MatrixXd lower = MatrixXd::Constant(n, n, 7.0);
    detail::LowerOfSymmetricProduct(A.transpose(), T, 1.0, false, &lower);
    MatrixXd acc = MatrixXd::Identity(n, n);
    detail::LowerOfSymmetricProduct(A.transpose(), T, -2.0, true, &acc);
    const double scale = full.norm();
    for (int j = 0; j < n; ++j) {
      for (int i = j; i < n; ++i) {
        EXPECT_NEAR(lower(i, j), full(i, j), 1e-13 * scale) << "n = " << n;
        EXPECT_NEAR(acc(i, j), (i == j ? 1.0 : 0.0) - 2.0 * full(i, j), 3e-13 * scale) << "n = " << n;
      }
    }
    MatrixXd out = S;
    detail::CongruenceWork work;
    ASSERT_EQ(detail::AddCongruenceOfPdLower(A, S, 0.5, &work, &out), n >= 32);
    if (n >= 32) {
      const MatrixXd expected = S + 0.5 * A * S * A.transpose();
      MatrixXd got = out.triangularView<Eigen::Lower>();
      got.triangularView<Eigen::StrictlyUpper>() = got.transpose();
      EXPECT_LE(RelativeDifference(got, expected), 1e-14) << "n = " << n;
      EXPECT_NEAR(detail::LowerFrobeniusNorm(out), expected.norm(), 1e-13 * expected.norm());
    }
    MatrixXd out2 = S;
    detail::UpdateWithCongruenceLower(A, S, -1.0, 1.0, &work, &out2);
    MatrixXd got2 = out2.triangularView<Eigen::Lower>();
    got2.triangularView<Eigen::StrictlyUpper>() = got2.transpose();
    EXPECT_LE(RelativeDifference(got2, S - A * S * A.transpose()), 1e-13) << "n = " << n;
  }
}

TEST(SymmetricProducts, MatrixPoolHandsBackTheSameBuffer) {
  detail::MatrixPool pool;
  MatrixXd a = pool.Take(40, 40);
  const double* data = a.data();
  pool.Give(std::move(a));
  const MatrixXd b = pool.Take(20, 80);  // same number of entries: the same storage, reshaped
  EXPECT_EQ(b.data(), data);
  EXPECT_EQ(b.rows(), 20);
  EXPECT_EQ(b.cols(), 80);
  const MatrixXd c = pool.Take(40, 40);  // the pool is empty: a new buffer
  EXPECT_NE(c.data(), data);
}

}  // namespace
}  // namespace kfx
