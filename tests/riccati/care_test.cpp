// Tests of the filter CARE with a cross term S and a descriptor E (SolveFilterCare, issue 22).
// Oracles: the scalar closed form (the positive root of a quadratic); the S-free CARE of the
// decorrelated problem (A - S R^{-1} C, Q - S R^{-1} S^T) and the E-free CARE of the E^{-1}-transformed
// problem; the residual of the original equation computed here; the closed-loop eigenvalues (Eigen's
// solver, not the DGEEV of the library); PSD; the long-time limit of the Riccati ODE by explicit
// steps for a scalar system; every invalid input.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdint>
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

struct System {
  MatrixXd A, C, Q, R, S, E;
};

/// A seeded system: A with eigenvalues on both sides of the imaginary axis, a joint noise covariance
/// [[Q, S], [S^T, R]] > 0, and (with_e) a well-conditioned E.
System RandomSystem(int n, int m, std::uint64_t seed, bool with_e) {
  TestRng rng(seed);
  System s;
  s.A = rng.Gaussian(n, n) / std::sqrt(static_cast<double>(n)) - 0.3 * MatrixXd::Identity(n, n);
  s.C = rng.Gaussian(m, n);
  const MatrixXd J = rng.Spd(n + m, 0.2);
  s.Q = J.topLeftCorner(n, n);
  s.S = J.topRightCorner(n, m);
  s.R = J.bottomRightCorner(m, m);
  s.E = with_e ? MatrixXd(MatrixXd::Identity(n, n) + 0.3 * rng.Gaussian(n, n) / std::sqrt(double(n))) : kNone;
  return s;
}

MatrixXd Eor(const System& s) { return s.E.size() ? s.E : MatrixXd(MatrixXd::Identity(s.A.rows(), s.A.rows())); }
MatrixXd Sor(const System& s) { return s.S.size() ? s.S : MatrixXd(MatrixXd::Zero(s.A.rows(), s.C.rows())); }

/// Residual, gain, closed loop, symmetry and PSD of a solution, computed here from the equation.
void ExpectValid(const System& s, const CareSolution& c, double tol) {
  ASSERT_TRUE(c.summary.ok()) << c.summary.FullReport();
  const MatrixXd& P = c.P;
  const MatrixXd E = Eor(s), S = Sor(s);
  const MatrixXd cross = E * P * s.C.transpose() + S;
  const MatrixXd Rinv = s.R.inverse();
  const MatrixXd res = s.A * P * E.transpose() + E * P * s.A.transpose() + s.Q - cross * Rinv * cross.transpose();
  const double scale = 2 * (s.A * P * E.transpose()).norm() + s.Q.norm() + (cross * Rinv * cross.transpose()).norm();
  EXPECT_LE(res.norm() / scale, tol);
  EXPECT_NEAR(c.summary.relative_residual, res.norm() / scale, 1e-12);
  EXPECT_EQ(P, P.transpose());
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<MatrixXd>(P).eigenvalues().minCoeff(), -1e-12 * P.norm());
  EXPECT_MATRICES_NEAR(c.gain * s.R, cross, 1e-10 * std::max(1.0, cross.norm()));
  const MatrixXd F = E.partialPivLu().solve(s.A - c.gain * s.C);
  const double max_real = Eigen::EigenSolver<MatrixXd>(F).eigenvalues().real().maxCoeff();
  EXPECT_LT(max_real, 0.0);
  EXPECT_NEAR(c.closed_loop_max_real, max_real, 1e-8 * std::max(1.0, F.norm()));
}

// a p e + e p a + q - (e p c + s)^2 / r = 0  <=>  e^2 c^2 p^2 + 2 e (c s - a r) p + (s^2 - q r) = 0;
// for q r > s^2 the product of the roots is negative: the positive root is the stabilizing one.
double ScalarCare(double a, double c, double q, double r, double s, double e) {
  const double qa = e * e * c * c, qb = 2 * e * (c * s - a * r), qc = s * s - q * r;
  return (-qb + std::sqrt(qb * qb - 4 * qa * qc)) / (2 * qa);
}

TEST(FilterCare, ScalarClosedForm) {
  const double cases[][6] = {{-1, 1, 1, 1, 0.5, 1},   {0.7, 2, 0.3, 0.5, -0.2, 1}, {2, 1, 1, 1, 0.9, 0.5},
                             {-3, 0.1, 4, 2, 2.5, 3}, {0.5, 1, 1, 1, 0.0, -2.0},   {1.5, -1, 2, 0.25, 0.6, 1.2}};
  for (const auto& k : cases) {
    const MatrixXd a = MatrixXd::Constant(1, 1, k[0]), c = MatrixXd::Constant(1, 1, k[1]);
    const MatrixXd q = MatrixXd::Constant(1, 1, k[2]), r = MatrixXd::Constant(1, 1, k[3]);
    const MatrixXd s = MatrixXd::Constant(1, 1, k[4]), e = MatrixXd::Constant(1, 1, k[5]);
    const CareSolution sol = SolveFilterCare(a, c, q, r, s, e);
    const double p = ScalarCare(k[0], k[1], k[2], k[3], k[4], k[5]);
    ASSERT_TRUE(sol.summary.ok()) << sol.summary.FullReport();
    EXPECT_NEAR(sol.P(0, 0), p, 1e-13 * std::max(1.0, p)) << "a = " << k[0] << ", s = " << k[4] << ", e = " << k[5];
    EXPECT_NEAR(sol.gain(0, 0), (k[5] * p * k[1] + k[4]) / k[3], 1e-12 * std::max(1.0, std::abs(sol.gain(0, 0))));
    ExpectValid({a, c, q, r, s, e}, sol, 1e-14);
  }
}

// The explicit Riccati ODE p' = 2 a p + q - (p c + s)^2 / r from p = 0 settles on the CARE's root.
TEST(FilterCare, ScalarRiccatiFlowLimit) {
  const double a = 0.4, c = 1.3, q = 0.8, r = 0.6, s = 0.5;
  double p = 0.0;
  for (int i = 0; i < 200000; ++i) p += 1e-4 * (2 * a * p + q - (p * c + s) * (p * c + s) / r);
  const CareSolution sol =
      SolveFilterCare(MatrixXd::Constant(1, 1, a), MatrixXd::Constant(1, 1, c), MatrixXd::Constant(1, 1, q),
                      MatrixXd::Constant(1, 1, r), MatrixXd::Constant(1, 1, s), kNone);
  EXPECT_NEAR(sol.P(0, 0), p, 1e-9);
}

TEST(FilterCare, NoCrossTermIsTheStandardCare) {
  const System s = RandomSystem(6, 2, 3, false);
  const CareSolution with_zero = SolveFilterCare(s.A, s.C, s.Q, s.R, MatrixXd::Zero(6, 2), MatrixXd::Identity(6, 6));
  const CareSolution plain = SolveFilterCare(s.A, s.C, s.Q, s.R, kNone, kNone);
  ASSERT_TRUE(plain.summary.ok());
  EXPECT_EQ(plain.summary.computation, "filter CARE");
  EXPECT_LT(RelativeDifference(with_zero.P, plain.P), 1e-13);
}

// The decorrelated problem (A - S R^{-1} C, Q - S R^{-1} S^T) has the same P: one solve with L = S in
// SB02OD, one without any cross term. Likewise E^{-1} A, E^{-1} Q E^{-T}, E^{-1} S without E.
TEST(FilterCare, DecorrelatedAndTransformedProblemsHaveTheSameSolution) {
  for (int n : {2, 5, 12, 30}) {
    const System s = RandomSystem(n, 1 + n / 5, 100 + static_cast<std::uint64_t>(n), true);
    const CareSolution full = SolveFilterCare(s.A, s.C, s.Q, s.R, s.S, s.E);
    ExpectValid(s, full, 1e-12);
    const Eigen::PartialPivLU<MatrixXd> lu(s.E);
    const MatrixXd A1 = lu.solve(s.A), S1 = lu.solve(s.S);
    MatrixXd Q1 = lu.solve(MatrixXd(lu.solve(s.Q).transpose()));
    Q1 = 0.5 * (Q1 + Q1.transpose()).eval();
    const CareSolution no_e = SolveFilterCare(A1, s.C, Q1, s.R, S1, kNone);
    ASSERT_TRUE(no_e.summary.ok()) << no_e.summary.FullReport();
    EXPECT_LT(RelativeDifference(no_e.P, full.P), 1e-10) << "n = " << n;
    const MatrixXd RinvSt = s.R.llt().solve(S1.transpose());
    MatrixXd Q2 = Q1 - S1 * RinvSt;
    Q2 = 0.5 * (Q2 + Q2.transpose()).eval();
    const CareSolution plain = SolveFilterCare(A1 - RinvSt.transpose() * s.C, s.C, Q2, s.R, kNone, kNone);
    ASSERT_TRUE(plain.summary.ok()) << plain.summary.FullReport();
    EXPECT_LT(RelativeDifference(plain.P, full.P), 1e-10) << "n = " << n;
  }
}

TEST(FilterCare, SeededSystemsUpToN50) {
  for (int n = 2; n <= 50; n += (n < 10 ? 1 : 8)) {
    for (bool with_e : {false, true}) {
      const System s = RandomSystem(n, 1 + n % 4, 7000 + static_cast<std::uint64_t>(n), with_e);
      const CareSolution c = SolveFilterCare(s.A, s.C, s.Q, s.R, s.S, s.E);
      SCOPED_TRACE("n = " + std::to_string(n) + (with_e ? " with E" : ""));
      ExpectValid(s, c, 1e-11);
      EXPECT_EQ(c.summary.computation, "filter CARE (cross term S, descriptor E)");
      EXPECT_EQ(c.summary.method, "schur");
    }
  }
}

// An unstable mode that neither the measurement sees nor the noise drives: no stabilizing solution.
TEST(FilterCare, NotDetectableIsNotStabilizing) {
  MatrixXd A(2, 2), C(1, 2), Q = MatrixXd::Zero(2, 2), S = MatrixXd::Zero(2, 1);
  A << 1.0, 0.0, 0.0, -1.0;
  C << 0.0, 1.0;
  Q(1, 1) = 1.0;
  const CareSolution c = SolveFilterCare(A, C, Q, MatrixXd::Identity(1, 1), S, kNone);
  EXPECT_EQ(c.summary.termination, Termination::kNotStabilizing) << c.summary.FullReport();
  EXPECT_FALSE(c.summary.ok());
}

TEST(FilterCare, EmptyState) {
  const CareSolution c =
      SolveFilterCare(MatrixXd(0, 0), MatrixXd(1, 0), MatrixXd(0, 0), MatrixXd::Identity(1, 1), MatrixXd(0, 1), kNone);
  EXPECT_TRUE(c.summary.ok());
  EXPECT_EQ(c.P.size(), 0);
  EXPECT_EQ(c.gain.rows(), 0);
}

TEST(FilterCare, InvalidInputNamesTheArgument) {
  const System s = RandomSystem(3, 2, 5, true);
  auto care = [&](const MatrixXd& A, const MatrixXd& C, const MatrixXd& Q, const MatrixXd& R, const MatrixXd& S,
                  const MatrixXd& E) { return [=] { SolveFilterCare(A, C, Q, R, S, E); }; };
  MatrixXd nan3 = s.A;
  nan3(1, 1) = std::nan("");
  MatrixXd inf_c = s.C;
  inf_c(0, 0) = INFINITY;
  MatrixXd nan_s = s.S;
  nan_s(0, 1) = std::nan("");
  MatrixXd nan_r = s.R;
  nan_r(0, 0) = std::nan("");
  // shapes
  EXPECT_TRUE(ThrowsErrorNaming(care(MatrixXd(3, 2), s.C, s.Q, s.R, s.S, s.E), "A"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, MatrixXd(2, 4), s.Q, s.R, s.S, s.E), "C"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, MatrixXd(2, 2), s.R, s.S, s.E), "Q"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, s.Q, MatrixXd::Identity(3, 3), s.S, s.E), "R"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, s.Q, s.R, MatrixXd(2, 3), s.E), "S"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, s.Q, s.R, s.S, MatrixXd(3, 2)), "E"));
  // non-finite
  EXPECT_TRUE(ThrowsErrorNaming(care(nan3, s.C, s.Q, s.R, s.S, s.E), "A"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, inf_c, s.Q, s.R, s.S, s.E), "C"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, nan3, s.R, s.S, s.E), "Q"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, s.Q, nan_r, s.S, s.E), "R"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, s.Q, s.R, nan_s, s.E), "S"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, s.Q, s.R, s.S, nan3), "E"));
  // definiteness, singular E
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, s.Q, s.R, 100.0 * s.S, s.E), "[[Q, S], [S^T, R]]"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, -s.Q, s.R, s.S, s.E), "Q"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, s.Q, -s.R, s.S, s.E), "R"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, s.Q, MatrixXd::Zero(2, 2), kNone, kNone), "R"));
  EXPECT_TRUE(ThrowsErrorNaming(care(s.A, s.C, s.Q, s.R, s.S, MatrixXd::Zero(3, 3)), "E"));
}

}  // namespace
}  // namespace kfx
