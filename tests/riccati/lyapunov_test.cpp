// Tests of SolveDiscreteLyapunov and SpectralRadius (src/riccati/lyapunov.cpp, linear_algebra.cpp). Oracles: the scalar
// closed form, the Kronecker-product linear system (I - A (x) A) vec X = vec Q for small n,
// residuals and invariants for n up to 200, and every invalid / singular input.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <random>

#include "kfx/error.hpp"
#include "kfx/riccati.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using kfx::testing::RelativeDifference;
using kfx::testing::TestRng;

LyapunovOptions Schur() {
  LyapunovOptions o;
  o.method = LyapunovMethod::kSchur;
  return o;
}

TEST(LyapunovScalar, MatchesClosedForm) {
  // x = a^2 x + q  =>  x = q / (1 - a^2), also for |a| > 1 (then x < 0 for q > 0).
  for (const auto& [a, q] : {std::pair{0.5, 1.0}, std::pair{-0.9, 2.0}, std::pair{0.0, 3.0}, std::pair{0.999, 1e-3},
                             std::pair{2.0, 1.0}, std::pair{0.3, -1.0}}) {
    const LyapunovSolution sol =
        SolveDiscreteLyapunov(MatrixXd::Constant(1, 1, a), MatrixXd::Constant(1, 1, q), Schur());
    const MatrixXd& x = sol.X;
    const double expected = q / (1 - a * a);
    ASSERT_EQ(x.rows(), 1);
    EXPECT_NEAR(x(0, 0), expected, 1e-14 * std::abs(expected)) << "a = " << a;
    EXPECT_TRUE(sol.summary.ok());
    EXPECT_EQ(sol.summary.method, "schur");
    EXPECT_NEAR(sol.spectral_radius, std::abs(a), 1e-15);
    EXPECT_LE(sol.summary.relative_residual, 1e-15);
  }
}

/// (I - A (x) A) vec X = vec Q, since vec(A X A^T) = (A (x) A) vec X (column-major vec). Full pivoting, or
/// partial pivoting (blocked, BLAS 3) for the larger sizes of well-conditioned cases (rho(A) <= 0.99).
MatrixXd KroneckerSolve(const MatrixXd& A, const MatrixXd& Q, bool partial_pivoting = false) {
  const Eigen::Index n = A.rows();
  MatrixXd K(n * n, n * n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j) K.block(i * n, j * n, n, n) = A(i, j) * A;
  K = MatrixXd::Identity(n * n, n * n) - K;
  const Eigen::VectorXd vec_q = Eigen::Map<const Eigen::VectorXd>(Q.data(), n * n);
  const Eigen::VectorXd vec_x =
      partial_pivoting ? Eigen::VectorXd(K.partialPivLu().solve(vec_q)) : Eigen::VectorXd(K.fullPivLu().solve(vec_q));
  return Eigen::Map<const MatrixXd>(vec_x.data(), n, n);
}

TEST(LyapunovKronecker, AgreesForSmallSystems) {
  TestRng rng(21);
  for (int n = 1; n <= 10; ++n) {
    for (double rho : {0.5, 0.95, 1.5}) {  // 1.5: solvable (no reciprocal pair in general), X indefinite
      const MatrixXd A = rng.WithSpectralRadius(n, rho);
      const MatrixXd G = rng.Gaussian(n, n);
      const MatrixXd Q = G + G.transpose();  // symmetric, indefinite
      const MatrixXd X = SolveDiscreteLyapunov(A, Q).X;
      EXPECT_LE(RelativeDifference(X, KroneckerSolve(A, Q)), 1e-11) << "n = " << n << ", rho = " << rho;
      EXPECT_EQ(X, X.transpose());
    }
  }
}

TEST(LyapunovRandom, StableSystemsHaveSmallResidualAndPsdSolution) {
  // Measured relative residuals: 1e-16 .. 3e-15 up to n = 200.
  TestRng rng(22);
  for (int n : {1, 2, 3, 5, 10, 20, 50, 100, 200}) {
    const MatrixXd A = rng.WithSpectralRadius(n, 0.95);
    const MatrixXd Q = rng.Spd(n);
    const LyapunovSolution sol = SolveDiscreteLyapunov(A, Q, Schur());
    const MatrixXd& X = sol.X;
    ASSERT_TRUE(sol.summary.ok()) << sol.summary.message;
    const MatrixXd res = X - A * X * A.transpose() - Q;
    const double residual = res.norm() / X.norm();
    EXPECT_LE(residual, 1e-13) << "n = " << n;
    EXPECT_NEAR(sol.summary.relative_residual, residual, 1e-14);
    EXPECT_NEAR(sol.spectral_radius, 0.95, 1e-10);
    EXPECT_NEAR(SpectralRadius(A), 0.95, 1e-10);
    EXPECT_EQ(X, X.transpose());
    const double min_eig = Eigen::SelfAdjointEigenSolver<MatrixXd>(X, Eigen::EigenvaluesOnly).eigenvalues()(0);
    EXPECT_GT(min_eig, 0.0) << "n = " << n;  // X >= Q > 0
  }
}

// kAuto sends a stable A to the squared Smith iteration (SB03MD beyond rho ~ 0.998 or on a residual
// above 1e-13); kSchur always to SB03MD: the two must agree, and each reports its own residual.
TEST(LyapunovRandom, SmithPathAgreesWithSb03md) {
  TestRng rng(24);
  for (int n : {3, 40, 120}) {
    for (double rho : {0.3, 0.95, 0.99, 0.999, 1.2}) {
      const MatrixXd A = rng.WithSpectralRadius(n, rho);
      const MatrixXd Q = rng.Spd(n);
      const MatrixXd X_schur = SolveDiscreteLyapunov(A, Q, Schur()).X;
      const LyapunovSolution sol = SolveDiscreteLyapunov(A, Q);
      const MatrixXd& X = sol.X;
      EXPECT_LE(RelativeDifference(X, X_schur), 1e-11) << "n = " << n << ", rho = " << rho;
      EXPECT_EQ(X, X.transpose());
      const double residual = (X - A * X * A.transpose() - Q).norm() / X.norm();
      EXPECT_LE(residual, 1e-13) << "n = " << n << ", rho = " << rho;
      EXPECT_NEAR(sol.summary.relative_residual, residual, 1e-14) << sol.summary.method;
      if (rho <= 0.95) {  // well inside the Smith iteration's reach
        EXPECT_EQ(sol.summary.method, "smith");
      }
      if (rho > 1.0) {
        EXPECT_EQ(sol.summary.method, "schur");
      }
    }
  }
}

// The Smith iteration's BLAS path (n >= 32: DTRMM + DSYR2K congruences, the early stop on |A_j|_F^2)
// against the Kronecker solve, at seeded random sizes just above the switch and a rho that needs
// every step (issue 24).
TEST(LyapunovKronecker, SmithBlasPathAgreesAtRandomSizes) {
  TestRng rng(2424);
  std::mt19937 pick(24);
  for (int trial = 0; trial < 2; ++trial) {
    const int n = std::uniform_int_distribution<int>(32, 36)(pick);
    for (double rho : {0.2, 0.9, 0.99}) {
      const MatrixXd A = rng.WithSpectralRadius(n, rho);
      const MatrixXd Q = rng.Spd(n);
      LyapunovOptions smith;
      smith.method = LyapunovMethod::kSmith;
      const LyapunovSolution sol = SolveDiscreteLyapunov(A, Q, smith);
      ASSERT_TRUE(sol.summary.ok()) << sol.summary.message << " n = " << n << ", rho = " << rho;
      EXPECT_LE(RelativeDifference(sol.X, KroneckerSolve(A, Q, true)), 1e-11) << "n = " << n << ", rho = " << rho;
      const double residual = (sol.X - A * sol.X * A.transpose() - Q).norm() / sol.X.norm();
      EXPECT_LE(residual, 1e-14) << "n = " << n << ", rho = " << rho;
      EXPECT_EQ(sol.X, sol.X.transpose());
    }
  }
}

// The single-precision tail of the Smith iteration (the last two terms of the rest in SGEMM/SSYRK when
// their rounding and what they leave out are below eps/4 |X|): at seeded sizes and the benchmark's
// rho = 0.95, the path is taken, the residual stays at double precision (<= 1e-14) and X agrees with the
// Schur route (an independent method) and, at the smallest size, with the Kronecker solve. At rho = 0.99
// (n = 120) the test (a) fails at the step where the tail would start: the full iteration runs.
TEST(LyapunovRandom, SinglePrecisionTailKeepsDoublePrecisionResidual) {
  TestRng rng(2425);
  std::mt19937 pick(2425);
  for (int trial = 0; trial < 3; ++trial) {
    std::uniform_int_distribution<int> size =
        trial == 0 ? std::uniform_int_distribution<int>(40, 48) : std::uniform_int_distribution<int>(100, 220);
    const int n = size(pick);
    for (double rho : {0.9, 0.95, 0.99}) {
      const MatrixXd A = rng.WithSpectralRadius(n, rho);
      const MatrixXd Q = rng.Spd(n);
      const LyapunovSolution sol = SolveDiscreteLyapunov(A, Q);
      ASSERT_TRUE(sol.summary.ok()) << sol.summary.message;
      ASSERT_EQ(sol.summary.method, "smith") << "n = " << n << ", rho = " << rho;
      const bool tail = sol.summary.message.find("single precision") != std::string::npos;
      if (rho <= 0.95) {
        EXPECT_TRUE(tail) << sol.summary.message << " n = " << n << ", rho = " << rho;
      }
      const double residual = (sol.X - A * sol.X * A.transpose() - Q).norm() / sol.X.norm();
      EXPECT_LE(residual, 1e-14) << "n = " << n << ", rho = " << rho << ", " << sol.summary.message;
      EXPECT_NEAR(sol.summary.relative_residual, residual, 1e-15);
      EXPECT_EQ(sol.X, sol.X.transpose());
      EXPECT_LE(RelativeDifference(sol.X, SolveDiscreteLyapunov(A, Q, Schur()).X), 1e-12)
          << "n = " << n << ", rho = " << rho;
      if (trial == 0) {
        EXPECT_LE(RelativeDifference(sol.X, KroneckerSolve(A, Q, true)), 1e-12) << "n = " << n << ", rho = " << rho;
      }
    }
  }
}

TEST(LyapunovRandom, PsdRankDeficientNoiseGivesPsdSolution) {
  TestRng rng(23);
  const int n = 30;
  const MatrixXd A = rng.WithSpectralRadius(n, 0.9);
  const MatrixXd B = rng.Gaussian(n, 2);
  const MatrixXd Q = B * B.transpose();
  const MatrixXd X = SolveDiscreteLyapunov(A, Q).X;
  const double min_eig = Eigen::SelfAdjointEigenSolver<MatrixXd>(X, Eigen::EigenvaluesOnly).eigenvalues()(0);
  EXPECT_GE(min_eig, -1e-12 * X.norm());
}

TEST(LyapunovShapes, EmptyMatrixGivesEmptySolution) {
  const LyapunovSolution sol = SolveDiscreteLyapunov(MatrixXd(0, 0), MatrixXd(0, 0));
  EXPECT_EQ(sol.X.rows(), 0);
  EXPECT_EQ(sol.X.cols(), 0);
  EXPECT_TRUE(sol.summary.ok());
  EXPECT_EQ(sol.spectral_radius, 0.0);
  EXPECT_EQ(SpectralRadius(MatrixXd(0, 0)), 0.0);
}

// The call SolveDiscreteLyapunov(A, Q), for testing::ThrowsErrorStartingWith.
auto Solving(const MatrixXd& A, const MatrixXd& Q) {
  return [A, Q] { SolveDiscreteLyapunov(A, Q); };
}

// A singular equation is a numerical outcome, reported in the Summary with the spectral radius (never
// thrown): each case below has an eigenvalue pair with lambda_i lambda_j = 1.
void ExpectSingular(const MatrixXd& A, const std::string& radius) {
  for (const LyapunovMethod method : {LyapunovMethod::kAuto, LyapunovMethod::kSchur}) {
    LyapunovOptions o;
    o.method = method;
    const LyapunovSolution sol = SolveDiscreteLyapunov(A, MatrixXd::Identity(A.rows(), A.rows()), o);
    EXPECT_EQ(sol.summary.termination, Termination::kSingular) << sol.summary.FullReport();
    EXPECT_NE(sol.summary.message.find("spectral radius " + radius), std::string::npos) << sol.summary.message;
    EXPECT_EQ(sol.X.size(), 0);
  }
}

TEST(LyapunovSingular, ReciprocalEigenvaluesAreReportedWithTheSpectralRadius) {
  const MatrixXd rot = Eigen::Rotation2Dd(0.4).toRotationMatrix();  // lambda lambda-bar = 1
  ExpectSingular(MatrixXd::Identity(3, 3), "1");
  ExpectSingular((MatrixXd(2, 2) << 2, 1, 0, 0.5).finished(), "2");
  ExpectSingular(rot, "");
  ExpectSingular(-MatrixXd::Identity(1, 1), "1");
}

TEST(LyapunovSingular, TheSmithIterationAloneReportsNoConvergenceBeyondItsReach) {
  LyapunovOptions o;
  o.method = LyapunovMethod::kSmith;
  const LyapunovSolution unstable = SolveDiscreteLyapunov(1.5 * MatrixXd::Identity(2, 2), MatrixXd::Identity(2, 2), o);
  EXPECT_EQ(unstable.summary.termination, Termination::kNotConverged) << unstable.summary.FullReport();
  const LyapunovSolution stable = SolveDiscreteLyapunov(0.5 * MatrixXd::Identity(2, 2), MatrixXd::Identity(2, 2), o);
  ASSERT_TRUE(stable.summary.ok());
  EXPECT_LT((stable.X - MatrixXd::Identity(2, 2) / 0.75).norm(), 1e-14);
}

TEST(LyapunovValidation, InvalidInputThrowsNamingTheArgument) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  MatrixXd A = 0.5 * MatrixXd::Identity(2, 2);
  const MatrixXd Q = MatrixXd::Identity(2, 2);
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(Solving(MatrixXd::Ones(2, 3), Q), "A:"));
  MatrixXd bad = A;
  bad(0, 1) = nan;
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(Solving(bad, Q), "A:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(Solving(A, MatrixXd::Identity(3, 3)), "Q:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(Solving(A, (MatrixXd(2, 2) << 1, 1, 0, 1).finished()), "Q:"));
  bad = Q;
  bad(1, 1) = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(Solving(A, bad), "Q:"));
  EXPECT_THROW(SpectralRadius(MatrixXd::Ones(2, 3)), Error);
}

TEST(LyapunovSpectralRadius, MatchesKnownEigenvalues) {
  EXPECT_NEAR(SpectralRadius(0.8 * Eigen::Rotation2Dd(1.0).toRotationMatrix()), 0.8, 1e-15);
  EXPECT_NEAR(SpectralRadius((MatrixXd(3, 3) << -3, 1, 0, 0, 2, 1, 0, 0, 1).finished()), 3.0, 1e-15);
  EXPECT_EQ(SpectralRadius(MatrixXd::Zero(4, 4)), 0.0);
}

}  // namespace
}  // namespace kfx
