// Tests of the generalized equations of the riccati layer (issue 22): the filter DARE with a cross
// term S and a descriptor E, the generalized discrete Lyapunov equation and the Stein/Sylvester
// equation. Oracles: a scalar closed form; two independent methods (the transformation to a standard
// DARE solved by doubling vs SLICOT SG02AD on the original pencil) on seeded systems n = 2..200; the
// Riccati recursion run to steady state; python-control's own test case (its closed-loop eigenvalues);
// Kronecker solves for small n; residuals; every invalid input.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <string>

#include "kfx/error.hpp"
#include "kfx/riccati.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using kfx::testing::RelativeDifference;
using kfx::testing::TestRng;
using kfx::testing::ThrowsErrorNaming;

const MatrixXd kNone(0, 0);

DareOptions WithMethod(DareMethod method) {
  DareOptions o;
  o.method = method;
  return o;
}

struct System {
  MatrixXd A, C, Q, R, S, E;
};

/// A seeded system with a joint noise covariance [[Q, S], [S^T, R]] > 0 and a well-conditioned E.
System RandomSystem(int n, int m, std::uint64_t seed, bool with_e) {
  TestRng rng(seed);
  System s;
  s.A = rng.WithSpectralRadius(n, 1.05);
  s.C = rng.Gaussian(m, n);
  const MatrixXd J = rng.Spd(n + m, 0.2);
  s.Q = J.topLeftCorner(n, n);
  s.S = J.topRightCorner(n, m);
  s.R = J.bottomRightCorner(m, m);
  s.E = with_e ? MatrixXd(MatrixXd::Identity(n, n) + 0.3 * rng.Gaussian(n, n) / std::sqrt(double(n))) : kNone;
  return s;
}

MatrixXd Eor(const System& s) { return s.E.size() ? s.E : MatrixXd(MatrixXd::Identity(s.A.rows(), s.A.rows())); }

double ClosedLoopRho(const System& s, const DareSolution& d) {
  const MatrixXd F = Eor(s).partialPivLu().solve(s.A - d.predictor_gain * s.C);
  return SpectralRadius(F);
}

void ExpectValid(const System& s, const DareSolution& d, double tol) {
  ASSERT_TRUE(d.summary.ok()) << d.summary.FullReport();
  const MatrixXd& P = d.P_pred;
  const MatrixXd W = s.C * P * s.C.transpose() + s.R;
  const MatrixXd Sx = s.S.size() ? s.S : MatrixXd(MatrixXd::Zero(P.rows(), s.C.rows()));
  const MatrixXd E = Eor(s);
  const MatrixXd res = s.A * P * s.A.transpose() - E * P * E.transpose() + s.Q -
                       (s.A * P * s.C.transpose() + Sx) * W.inverse() * (s.A * P * s.C.transpose() + Sx).transpose();
  EXPECT_LE(res.norm() / (E * P * E.transpose()).norm(), tol);
  EXPECT_NEAR(d.summary.relative_residual, FilterDareResidual(s.A, s.C, s.Q, s.R, s.S, s.E, P), 1e-15);
  EXPECT_EQ(P, P.transpose());
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<MatrixXd>(P).eigenvalues().minCoeff(), -1e-12 * P.norm());
  EXPECT_LT(ClosedLoopRho(s, d), 1.0);
  EXPECT_MATRICES_NEAR(d.predictor_gain * W, s.A * P * s.C.transpose() + Sx,
                       1e-10 * std::max(1.0, W.norm() * P.norm()));
  EXPECT_MATRICES_NEAR(d.filter_gain * W, P * s.C.transpose(), 1e-10 * std::max(1.0, W.norm() * P.norm()));
  EXPECT_MATRICES_NEAR(d.P_filt, P - d.filter_gain * s.C * P, 1e-10 * std::max(1.0, P.norm()));
}

// e^2 p = a^2 p + q - (a p c + s)^2 / (c^2 p + r)  <=>
// e^2 c^2 p^2 + ((e^2 - a^2) r - q c^2 + 2 a c s) p + (s^2 - q r) = 0; for q r > s^2 the product of the
// roots is negative: one positive root, the stabilizing one.
TEST(GeneralDare, ScalarClosedForm) {
  for (double e : {1.0, 0.5, 2.0}) {
    for (double s : {0.0, 0.4, -0.7}) {
      const double a = 1.2, c = 0.8, q = 1.0, r = 0.6;
      const double qa = e * e * c * c, qb = (e * e - a * a) * r - q * c * c + 2 * a * c * s, qc = s * s - q * r;
      const double p = (-qb + std::sqrt(qb * qb - 4 * qa * qc)) / (2 * qa);
      for (DareMethod method : {DareMethod::kAuto, DareMethod::kDoubling, DareMethod::kSchur}) {
        const DareSolution d = SolveFilterDare(
            MatrixXd::Constant(1, 1, a), MatrixXd::Constant(1, 1, c), MatrixXd::Constant(1, 1, q),
            MatrixXd::Constant(1, 1, r), MatrixXd::Constant(1, 1, s), MatrixXd::Constant(1, 1, e), WithMethod(method));
        ASSERT_TRUE(d.summary.ok()) << d.summary.FullReport();
        EXPECT_NEAR(d.P_pred(0, 0), p, 1e-13 * p) << "e " << e << " s " << s << " " << ToString(method);
        EXPECT_NEAR(d.predictor_gain(0, 0), (a * p * c + s) / (c * c * p + r), 1e-13);
      }
    }
  }
}

TEST(GeneralDare, NoCrossTermNoDescriptorIsTheStandardDare) {
  const System s = RandomSystem(6, 3, 11, false);
  const DareSolution std_sol = SolveFilterDare(s.A, s.C, s.Q, s.R);
  const DareSolution gen = SolveFilterDare(s.A, s.C, s.Q, s.R, kNone, kNone);
  ASSERT_TRUE(gen.summary.ok()) << gen.summary.FullReport();
  EXPECT_MATRICES_NEAR(gen.P_pred, std_sol.P_pred, 1e-14 * std_sol.P_pred.norm());
  EXPECT_MATRICES_NEAR(gen.predictor_gain, std_sol.predictor_gain, 1e-12 * std_sol.predictor_gain.norm());
}

// The two methods are independent: the transformation + doubling vs SG02AD on the original pencil.
TEST(GeneralDare, DoublingAgreesWithSg02adOnSeededSystems) {
  const int sizes[] = {2, 3, 5, 10, 20, 50, 200};
  for (int n : sizes) {
    for (bool with_e : {false, true}) {
      const System s = RandomSystem(n, std::max(1, n / 2), 1000 + n, with_e);
      const DareSolution a = SolveFilterDare(s.A, s.C, s.Q, s.R, s.S, s.E, WithMethod(DareMethod::kAuto));
      const DareSolution b = SolveFilterDare(s.A, s.C, s.Q, s.R, s.S, s.E, WithMethod(DareMethod::kSchur));
      SCOPED_TRACE("n = " + std::to_string(n) + (with_e ? " with E" : " E = I"));
      ExpectValid(s, a, 1e-12);
      ExpectValid(s, b, 1e-9);
      EXPECT_EQ(a.method_used, DareMethod::kDoubling);
      EXPECT_FALSE(a.fell_back);
      EXPECT_EQ(b.method_used, DareMethod::kSchur);
      EXPECT_LE(RelativeDifference(a.P_pred, b.P_pred), 1e-9);
    }
  }
}

// The time-varying Riccati recursion E P_{k+1} E^T = A P_k A^T + Q - (A P_k C^T + S) W_k^{-1} (.)^T
// from P_0 = Q converges to the stabilizing solution.
TEST(GeneralDare, RiccatiRecursionConvergesToTheSolution) {
  System s = RandomSystem(4, 2, 7, true);
  const MatrixXd E = Eor(s);
  const Eigen::PartialPivLU<MatrixXd> lu(E);
  MatrixXd P = s.Q;
  for (int k = 0; k < 3000; ++k) {
    const MatrixXd W = s.C * P * s.C.transpose() + s.R;
    const MatrixXd X = s.A * P * s.C.transpose() + s.S;
    const MatrixXd rhs = s.A * P * s.A.transpose() + s.Q - X * W.llt().solve(X.transpose());
    P = lu.solve(lu.solve(rhs).transpose());
    P = 0.5 * (P + P.transpose()).eval();
  }
  const DareSolution d = SolveFilterDare(s.A, s.C, s.Q, s.R, s.S, s.E);
  ExpectValid(s, d, 1e-12);
  EXPECT_LE(RelativeDifference(d.P_pred, P), 1e-11);
}

// python-control's test_dare_g (control/tests/mateqn_test.py), in the dual: X = dare(A, B, Q, R, S, E)
// solves A^T X A - E^T X E - (A^T X B + S)(B^T X B + R)^{-1}(...)^T + Q = 0, i.e. ours with
// A -> A^T, C = B^T, E -> E^T; its gain G = (B^T X B + R)^{-1} (B^T X A + S^T) is K_p^T and its check
// is that the eigenvalues of the pencil (A - B G, E) are inside the unit circle.
TEST(GeneralDare, PythonControlCrossTermDescriptorCase) {
  MatrixXd A(2, 2), Q(2, 2), B(2, 1), R(1, 1), S(2, 1), E(2, 2);
  A << -0.6, 0, -0.1, -0.4;
  Q << 2, 1, 1, 3;
  B << 1, 2;
  R << 1;
  S << 1, 0;
  E << 2, 1, 1, 2;
  for (DareMethod method : {DareMethod::kDoubling, DareMethod::kSchur}) {
    const DareSolution d = SolveFilterDare(A.transpose(), B.transpose(), Q, R, S, E.transpose(), WithMethod(method));
    ASSERT_TRUE(d.summary.ok()) << d.summary.FullReport();
    const MatrixXd& X = d.P_pred;
    const MatrixXd G = (B.transpose() * X * B + R).inverse() * (B.transpose() * X * A + S.transpose());
    EXPECT_MATRICES_NEAR(G, d.predictor_gain.transpose(), 1e-12);
    const MatrixXd res = A.transpose() * X * A - E.transpose() * X * E - (A.transpose() * X * B + S) * G + Q;
    EXPECT_LE(res.norm(), 1e-12 * X.norm());
    EXPECT_LT(SpectralRadius(E.partialPivLu().solve(A - B * G)), 1.0);
  }
}

TEST(GeneralDare, IllConditionedDescriptorGoesToSg02ad) {
  System s = RandomSystem(4, 2, 21, false);
  s.E = MatrixXd::Identity(4, 4);
  s.E(3, 3) = 1e-9;  // rcond ~ 1e-9 < 1e-8: no E^{-1} transformation under kAuto
  const DareSolution d = SolveFilterDare(s.A, s.C, s.Q, s.R, s.S, s.E);
  EXPECT_EQ(d.method_used, DareMethod::kSchur);
  EXPECT_TRUE(d.fell_back);
  if (d.summary.ok()) ExpectValid(s, d, 1e-8);
}

TEST(GeneralDare, InvalidInputNamesTheArgument) {
  const System s = RandomSystem(3, 2, 5, true);
  MatrixXd bad_s = s.S;
  bad_s(0, 0) = std::nan("");
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveFilterDare(s.A, s.C, s.Q, s.R, MatrixXd(2, 2), s.E); }, "S"));
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveFilterDare(s.A, s.C, s.Q, s.R, bad_s, s.E); }, "S"));
  // Joint covariance not PSD: S too large for Q and R.
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveFilterDare(s.A, s.C, s.Q, s.R, 100.0 * s.S, s.E); }, "[[Q, S], [S^T, R]]"));
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveFilterDare(s.A, s.C, s.Q, s.R, s.S, MatrixXd(2, 3)); }, "E"));
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveFilterDare(s.A, s.C, s.Q, s.R, s.S, MatrixXd::Zero(3, 3)); }, "E"));
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveFilterDare(s.A, s.C, -s.Q, s.R, s.S, s.E); }, "Q"));
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveFilterDare(s.A, s.C, s.Q, -s.R, s.S, s.E); }, "R"));
  DareOptions o;
  o.max_iterations = 0;
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveFilterDare(s.A, s.C, s.Q, s.R, s.S, s.E, o); }, "options"));
  EXPECT_TRUE(ThrowsErrorNaming([&] { FilterDareResidual(s.A, s.C, s.Q, s.R, s.S, s.E, MatrixXd(2, 2)); }, "P"));
}

TEST(GeneralDare, EmptyState) {
  const DareSolution d =
      SolveFilterDare(MatrixXd(0, 0), MatrixXd(1, 0), MatrixXd(0, 0), MatrixXd::Identity(1, 1), kNone, kNone);
  EXPECT_TRUE(d.summary.ok()) << d.summary.FullReport();
  EXPECT_EQ(d.P_pred.size(), 0);
}

// ------------------------------------------------------------------------------------------------
// Generalized Lyapunov A X A^T - E X E^T + Q = 0: (A (x) A - E (x) E) vec X = -vec Q.
TEST(GeneralizedLyapunov, MatchesKroneckerSolve) {
  for (int n = 1; n <= 6; ++n) {
    TestRng rng(300 + n);
    const MatrixXd A = rng.Gaussian(n, n);
    const MatrixXd E = rng.Gaussian(n, n) + 3.0 * MatrixXd::Identity(n, n);
    const MatrixXd Q = rng.Spd(n);
    MatrixXd K(n * n, n * n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) K.block(i * n, j * n, n, n) = A(i, j) * A - E(i, j) * E;
    const Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(Q.data(), n * n);
    const Eigen::VectorXd x = K.fullPivLu().solve(-q);
    const MatrixXd X = Eigen::Map<const MatrixXd>(x.data(), n, n);
    const LyapunovSolution s = SolveGeneralizedDiscreteLyapunov(A, E, Q);
    ASSERT_TRUE(s.summary.ok()) << s.summary.FullReport();
    EXPECT_LE(RelativeDifference(s.X, X), 1e-11) << "n = " << n;
    EXPECT_LE(s.summary.relative_residual, 1e-13);
  }
}

TEST(GeneralizedLyapunov, IdentityDescriptorIsTheStandardEquationAndResidualAtN100) {
  TestRng rng(41);
  const MatrixXd A = rng.WithSpectralRadius(100, 0.9);
  const MatrixXd Q = rng.Spd(100);
  const LyapunovSolution g = SolveGeneralizedDiscreteLyapunov(A, MatrixXd::Identity(100, 100), Q);
  const LyapunovSolution s = SolveDiscreteLyapunov(A, Q);
  ASSERT_TRUE(g.summary.ok()) << g.summary.FullReport();
  EXPECT_LE(g.summary.relative_residual, 1e-13);
  EXPECT_LE(RelativeDifference(g.X, s.X), 1e-11);
  EXPECT_NEAR(g.spectral_radius, 0.9, 1e-10);
}

TEST(GeneralizedLyapunov, SingularAndInvalid) {
  const MatrixXd A = MatrixXd::Identity(3, 3);
  EXPECT_EQ(SolveGeneralizedDiscreteLyapunov(A, A, A).summary.termination, Termination::kSingular);
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveGeneralizedDiscreteLyapunov(A, MatrixXd::Zero(3, 3), A); }, "E"));
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveGeneralizedDiscreteLyapunov(A, A, MatrixXd(2, 2)); }, "Q"));
  MatrixXd asym = A;
  asym(0, 1) = 1;
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveGeneralizedDiscreteLyapunov(A, A, asym); }, "Q"));
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveGeneralizedDiscreteLyapunov(MatrixXd(2, 3), A, A); }, "A"));
}

// Stein / Sylvester A X B - X + C = 0: (B^T (x) A - I) vec X = -vec C.
TEST(DiscreteSylvester, MatchesKroneckerSolve) {
  for (int n = 1; n <= 5; ++n) {
    const int m = n % 3 + 1;
    TestRng rng(500 + n);
    const MatrixXd A = rng.Gaussian(n, n);
    const MatrixXd B = rng.Gaussian(m, m);
    const MatrixXd C = rng.Gaussian(n, m);
    MatrixXd K(n * m, n * m);
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < m; ++j) K.block(i * n, j * n, n, n) = B(j, i) * A;
    K -= MatrixXd::Identity(n * m, n * m);
    const Eigen::VectorXd c = Eigen::Map<const Eigen::VectorXd>(C.data(), n * m);
    const Eigen::VectorXd x = K.fullPivLu().solve(-c);
    const SteinSolution s = SolveDiscreteSylvester(A, B, C);
    ASSERT_TRUE(s.summary.ok()) << s.summary.FullReport();
    EXPECT_LE(RelativeDifference(s.X, Eigen::Map<const MatrixXd>(x.data(), n, m)), 1e-11) << "n = " << n;
  }
}

TEST(DiscreteSylvester, ResidualAtModerateSizeSingularAndInvalid) {
  TestRng rng(61);
  const MatrixXd A = rng.WithSpectralRadius(80, 0.95);
  const MatrixXd B = rng.WithSpectralRadius(50, 0.9);
  const MatrixXd C = rng.Gaussian(80, 50);
  const SteinSolution s = SolveDiscreteSylvester(A, B, C);
  ASSERT_TRUE(s.summary.ok()) << s.summary.FullReport();
  EXPECT_LE(s.summary.relative_residual, 1e-13);
  const MatrixXd I = MatrixXd::Identity(2, 2);
  EXPECT_EQ(SolveDiscreteSylvester(I, I, I).summary.termination, Termination::kSingular);
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveDiscreteSylvester(A, B, MatrixXd(3, 3)); }, "C"));
  EXPECT_TRUE(ThrowsErrorNaming([&] { SolveDiscreteSylvester(A, MatrixXd(2, 3), C); }, "B"));
}

}  // namespace
}  // namespace kfx
