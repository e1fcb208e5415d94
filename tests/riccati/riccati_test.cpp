// Tests of SolveFilterDare / FilterDareResidual (src/riccati/). Oracles, strongest first:
// closed forms (scalar quadratic, a double-integrator family derived by hand below), the
// independent second method (doubling vs SLICOT SB02OD), the Riccati recursion run to steady
// state, residuals and invariants (symmetry, PSD, stabilizing), diagnosis of ill-posed problems,
// and every invalid input.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/riccati.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using kfx::testing::RelativeDifference;
using kfx::testing::TestRng;

DareOptions WithMethod(DareMethod method, bool exact_eigenvalues = false) {
  DareOptions options;
  options.method = method;
  options.exact_eigenvalues = exact_eigenvalues;
  return options;
}

double MinEigenvalue(const MatrixXd& p) {
  return Eigen::SelfAdjointEigenSolver<MatrixXd>(p, Eigen::EigenvaluesOnly).eigenvalues().minCoeff();
}

double Rho(const MatrixXd& a) { return a.eigenvalues().cwiseAbs().maxCoeff(); }

/// The invariants every accepted solution must satisfy (tolerances relative to |P|).
void ExpectValidSolution(const MatrixXd& A, const MatrixXd& C, const MatrixXd& Q, const MatrixXd& R,
                         const DareSolution& s) {
  ASSERT_TRUE(s.summary.ok()) << s.summary.FullReport();
  const double scale = std::max(1.0, s.P_pred.norm());
  EXPECT_EQ(s.P_pred, s.P_pred.transpose()) << "P must be exactly symmetric";
  EXPECT_EQ(s.P_filt, s.P_filt.transpose()) << "P_filt must be exactly symmetric";
  EXPECT_GE(MinEigenvalue(s.P_pred), -1e-12 * scale);
  EXPECT_GE(MinEigenvalue(s.P_filt), -1e-12 * scale);
  const MatrixXd S = C * s.P_pred * C.transpose() + R;
  EXPECT_MATRICES_NEAR(s.innovation_cov, S, 1e-12 * std::max(1.0, S.norm()));
  // K_f S = P C^T, K_p = A K_f, P_filt = P - K_f C P.
  EXPECT_MATRICES_NEAR(s.filter_gain * S, s.P_pred * C.transpose(), 1e-11 * scale);
  EXPECT_MATRICES_NEAR(s.predictor_gain, A * s.filter_gain, 1e-12 * std::max(1.0, s.predictor_gain.norm()));
  EXPECT_MATRICES_NEAR(s.P_filt, s.P_pred - s.filter_gain * C * s.P_pred, 1e-12 * scale);
  const double rho = Rho(A - s.predictor_gain * C);
  EXPECT_LT(rho, 1.0);
  if (s.eigenvalues_exact) {
    EXPECT_NEAR(s.closed_loop_spectral_radius, rho, 1e-9);
    EXPECT_NEAR(s.min_eigenvalue, MinEigenvalue(s.P_pred), 1e-12 * scale);
  } else {  // the Lyapunov certificate's bounds
    EXPECT_TRUE(s.lyapunov_certified);
    EXPECT_GE(s.closed_loop_spectral_radius, rho - 1e-12);
    EXPECT_LT(s.closed_loop_spectral_radius, 1.0);
    EXPECT_GT(s.min_eigenvalue, 0.0);
    EXPECT_LE(s.min_eigenvalue, MinEigenvalue(s.P_pred) + 1e-12 * scale);
  }
  EXPECT_NEAR(s.summary.relative_residual, FilterDareResidual(A, C, Q, R, s.P_pred), 1e-15);
  EXPECT_GE(s.summary.seconds, 0.0);
}

// ------------------------------------------------------------------------------------------------
// Scalar: p = a^2 p + q - a^2 c^2 p^2 / (c^2 p + r); multiplying by (c^2 p + r) gives
//   c^2 p^2 + (r - a^2 r - q c^2) p - q r = 0.
// For q, r > 0 and c != 0 the product of the roots is -q r / c^2 < 0: exactly one positive root,
// the stabilizing one. With b = r - a^2 r - q c^2 it is 2 q r / (b + sqrt(b^2 + 4 c^2 q r))
// (cancellation-free form of (-b + sqrt(...)) / (2 c^2)).
double ScalarDare(double a, double c, double q, double r) {
  const double b = r - a * a * r - q * c * c;
  const double disc = std::sqrt(b * b + 4 * c * c * q * r);
  return b > 0 ? 2 * q * r / (b + disc) : (-b + disc) / (2 * c * c);
}

TEST(DareScalar, MatchesPositiveRootOfTheQuadratic) {
  const double cases[][4] = {{0.5, 1.0, 1.0, 1.0},   {1.5, 2.0, 0.3, 0.7},   {-3.0, 0.5, 2.0, 4.0},
                             {0.99, 1e-3, 1.0, 1.0}, {20.0, 1.0, 1e-4, 1e2}, {1.0, 1.0, 1.0, 1.0}};
  for (const auto& k : cases) {
    const double a = k[0], c = k[1], q = k[2], r = k[3];
    const double p = ScalarDare(a, c, q, r);
    const MatrixXd A = MatrixXd::Constant(1, 1, a), C = MatrixXd::Constant(1, 1, c);
    const MatrixXd Q = MatrixXd::Constant(1, 1, q), R = MatrixXd::Constant(1, 1, r);
    for (DareMethod method : {DareMethod::kAuto, DareMethod::kDoubling, DareMethod::kSchur}) {
      SCOPED_TRACE(std::string("a = ") + std::to_string(a) + ", method " + ToString(method));
      const DareSolution s = SolveFilterDare(A, C, Q, R, WithMethod(method, /*exact_eigenvalues=*/true));
      ExpectValidSolution(A, C, Q, R, s);
      EXPECT_TRUE(s.eigenvalues_exact);
      EXPECT_FALSE(s.lyapunov_certified);  // not attempted when the eigenvalues are asked for
      EXPECT_NEAR(s.P_pred(0, 0), p, 1e-12 * p);
      const double kf = p * c / (c * c * p + r);
      EXPECT_NEAR(s.filter_gain(0, 0), kf, 1e-12 * std::abs(kf));
      EXPECT_NEAR(s.predictor_gain(0, 0), a * kf, 1e-12 * std::abs(a * kf));
      EXPECT_NEAR(s.P_filt(0, 0), p * r / (c * c * p + r), 1e-12 * p);
      EXPECT_NEAR(s.closed_loop_spectral_radius, std::abs(a - a * kf * c), 1e-12);
    }
  }
}

TEST(DareScalar, RandomWalkGivesTheGoldenRatio) {
  // a = c = q = r = 1: p^2 - p - 1 = 0.
  const MatrixXd one = MatrixXd::Ones(1, 1);
  const DareSolution s = SolveFilterDare(one, one, one, one);
  EXPECT_NEAR(s.P_pred(0, 0), (1 + std::sqrt(5.0)) / 2, 1e-15);
  EXPECT_EQ(s.method_used, DareMethod::kDoubling);
  EXPECT_FALSE(s.fell_back);
}

TEST(DareScalar, DoublingReportsEachStepToTheProgressHook) {
  const MatrixXd one = MatrixXd::Ones(1, 1);
  DareOptions o;
  o.method = DareMethod::kDoubling;
  std::vector<long> steps;
  o.progress = [&](long done, long total) {
    EXPECT_EQ(total, o.max_iterations);
    steps.push_back(done);
  };
  const DareSolution s = SolveFilterDare(one, one, one, one, o);
  EXPECT_NEAR(s.P_pred(0, 0), (1 + std::sqrt(5.0)) / 2, 1e-15);
  ASSERT_FALSE(steps.empty());
  for (size_t i = 0; i < steps.size(); ++i) EXPECT_EQ(steps[i], static_cast<long>(i) + 1);
  EXPECT_LT(steps.back(), o.max_iterations);  // converged before the limit
}

TEST(DareScalar, WithoutMeasurementInformationIsTheLyapunovSolution) {
  // c = 0: P = a^2 P + q, P = q / (1 - a^2); the gain is zero.
  const MatrixXd A = MatrixXd::Constant(1, 1, 0.8), C = MatrixXd::Zero(1, 1);
  const MatrixXd Q = MatrixXd::Constant(1, 1, 0.36), R = MatrixXd::Constant(1, 1, 2.0);
  for (DareMethod method : {DareMethod::kDoubling, DareMethod::kSchur}) {
    const DareSolution s = SolveFilterDare(A, C, Q, R, WithMethod(method));
    ExpectValidSolution(A, C, Q, R, s);
    EXPECT_NEAR(s.P_pred(0, 0), 1.0, 1e-14) << ToString(method);
    EXPECT_EQ(s.filter_gain(0, 0), 0.0);
  }
}

// ------------------------------------------------------------------------------------------------
// Double integrator A = [1 1; 0 1], C = [1 0], Q = diag(0, q), R = r, P = [a b; b c]. With
// s = a + r: P_filt = [a r/s, b r/s; b r/s, c - b^2/s], and P = A P_filt A^T + Q reads
//   (2,2): b^2 = q s,   (1,2): c = a b / s + q,   (1,1): a^2 = b (a + 2 r)  =>  b = a^2 / (a + 2r).
// So a^4 = q (a + r) (a + 2r)^2; choosing a > 0 and r > 0 fixes q = a^4 / ((a + r)(a + 2r)^2) and
// P in closed form. (A, C) is observable and (A, Q^{1/2}) reachable, so this positive definite
// solution is the unique stabilizing one. For a = 2, r = 1: q = 1/3, P = [2 1; 1 1],
// K_f = [2/3; 1/3], K_p = [1; 1/3], A - K_p C = [0 1; -1/3 1] with |lambda|^2 = 1/3.
TEST(DareDoubleIntegrator, MatchesHandDerivedFamily) {
  const MatrixXd A = (MatrixXd(2, 2) << 1, 1, 0, 1).finished();
  const MatrixXd C = (MatrixXd(1, 2) << 1, 0).finished();
  for (const auto& [a, r] : {std::pair{2.0, 1.0}, std::pair{4.0, 1.0}, std::pair{0.5, 3.0}, std::pair{10.0, 0.1}}) {
    const double q = std::pow(a, 4) / ((a + r) * (a + 2 * r) * (a + 2 * r));
    const double b = a * a / (a + 2 * r);
    const double c = a * b / (a + r) + q;
    const MatrixXd Q = (MatrixXd(2, 2) << 0, 0, 0, q).finished();
    const MatrixXd R = MatrixXd::Constant(1, 1, r);
    const MatrixXd P = (MatrixXd(2, 2) << a, b, b, c).finished();
    EXPECT_LT(FilterDareResidual(A, C, Q, R, P), 1e-15);  // the derivation itself
    for (DareMethod method : {DareMethod::kDoubling, DareMethod::kSchur}) {
      SCOPED_TRACE(std::string("a = ") + std::to_string(a) + ", method " + ToString(method));
      const DareSolution s = SolveFilterDare(A, C, Q, R, WithMethod(method));
      ExpectValidSolution(A, C, Q, R, s);
      EXPECT_MATRICES_NEAR(s.P_pred, P, 1e-12 * P.norm());
    }
  }
  const DareSolution s = SolveFilterDare(A, C, (MatrixXd(2, 2) << 0, 0, 0, 1.0 / 3).finished(), MatrixXd::Ones(1, 1),
                                         WithMethod(DareMethod::kAuto, /*exact_eigenvalues=*/true));
  EXPECT_MATRICES_NEAR(s.filter_gain, (MatrixXd(2, 1) << 2.0 / 3, 1.0 / 3).finished(), 1e-14);
  EXPECT_MATRICES_NEAR(s.predictor_gain, (MatrixXd(2, 1) << 1.0, 1.0 / 3).finished(), 1e-14);
  EXPECT_MATRICES_NEAR(s.P_filt, (MatrixXd(2, 2) << 2.0 / 3, 1.0 / 3, 1.0 / 3, 2.0 / 3).finished(), 1e-14);
  EXPECT_NEAR(s.closed_loop_spectral_radius, 1 / std::sqrt(3.0), 1e-14);
}

TEST(DareStabilityMargin, RequiresRhoBelowOneMinusMargin) {
  // The a = 2, r = 1 double integrator has rho(A - K_p C) = 1/sqrt(3) = 0.577.
  const MatrixXd A = (MatrixXd(2, 2) << 1, 1, 0, 1).finished();
  const MatrixXd C = (MatrixXd(1, 2) << 1, 0).finished();
  const MatrixXd Q = (MatrixXd(2, 2) << 0, 0, 0, 1.0 / 3).finished();
  const MatrixXd R = MatrixXd::Ones(1, 1);
  DareOptions options = WithMethod(DareMethod::kDoubling);
  options.stability_margin = 0.4;
  EXPECT_EQ(SolveFilterDare(A, C, Q, R, options).summary.termination, Termination::kConverged);
  options.stability_margin = 0.45;
  EXPECT_EQ(SolveFilterDare(A, C, Q, R, options).summary.termination, Termination::kNotStabilizing);
}

// The doubling stops one step early when two consecutive relative changes show quadratic convergence
// and predict the next below a hundredth of the tolerance (dare_doubling.cpp): at rho(A) = 0.95 after 5
// steps instead of 6 (the benchmark systems' changes 8.6e-5, 1.4e-9). The result, refined as before, must
// agree with SB02OD, and the step skipped must indeed change nothing that matters: the doubling with
// tolerance 1e-30 runs one step further (where its own prediction, ~1e-45, stops it) and agrees.
TEST(DareDoubling, PredictedConvergenceSkipsTheConfirmingStep) {
  for (int n : {40, 120}) {
    const int m = n / 2;
    TestRng rng(2400 + n);
    const MatrixXd A = rng.WithSpectralRadius(n, 0.95);
    const MatrixXd C = rng.Gaussian(m, n);
    const MatrixXd Q = rng.Spd(n);
    const MatrixXd R = rng.Spd(m);
    const DareSolution d = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kDoubling));
    ExpectValidSolution(A, C, Q, R, d);
    EXPECT_NE(d.summary.message.find("predicted below the tolerance"), std::string::npos) << d.summary.message;
    DareOptions strict = WithMethod(DareMethod::kDoubling);
    strict.tolerance = 1e-30;
    strict.max_iterations = d.summary.iterations + 1;
    const DareSolution full = SolveFilterDare(A, C, Q, R, strict);
    EXPECT_EQ(full.summary.iterations, d.summary.iterations + 1) << full.summary.message;
    const DareSolution s = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kSchur));
    EXPECT_LE(RelativeDifference(d.P_pred, s.P_pred), 1e-12) << "n = " << n;
    ExpectValidSolution(A, C, Q, R, full);
    EXPECT_LE(RelativeDifference(d.P_pred, full.P_pred), 1e-13) << "n = " << n;
    EXPECT_LE(d.summary.relative_residual, 32 * std::numeric_limits<double>::epsilon()) << d.summary.message;
    // The refinement's first step is four terms of the Newton correction (rho(A_cl)^8 per step instead of
    // the fixed point's rho(A_cl)^2): one step from the doubling's ~1e-13 to the target.
    EXPECT_EQ(d.refinement_steps, 1) << d.summary.message;
    EXPECT_NE(d.summary.message.find("(1 four-term Newton;"), std::string::npos) << d.summary.message;
  }
}

// The refinement's fallbacks. A closed loop with a mode at 0.999 (a slow mode that C does not see, hidden by a
// similarity): the four-term step contracts its error by only 0.999^8 and the fixed point by 0.999^2, so neither
// halves the residual and neither is kept; the doubling's residual (7.1e-13, measured) is above 1e-13, so the
// Newton step through the Stein equation runs and is kept. Checked against SB02OD and against the unrefined
// doubling: the refined solution must have the smaller residual and stay as close to SB02OD's as the
// conditioning allows (a closed-loop mode at 0.999 amplifies residuals by about 1 / (1 - 0.999^2) = 500).
TEST(DareRefinement, SlowClosedLoopFallsBackToTheSteinNewtonStep) {
  const int n = 40, m = 20;
  TestRng rng(2417);
  MatrixXd A = MatrixXd::Zero(n, n);
  A.topLeftCorner(n - 1, n - 1) = rng.WithSpectralRadius(n - 1, 0.9);
  A(n - 1, n - 1) = 0.999;
  MatrixXd C = MatrixXd::Zero(m, n);
  C.leftCols(n - 1) = rng.Gaussian(m, n - 1);
  const MatrixXd Q0 = rng.Spd(n);
  const MatrixXd R = rng.Spd(m);
  const MatrixXd mix = rng.Gaussian(n, n);
  const MatrixXd T = MatrixXd::Identity(n, n) + (0.3 / std::sqrt(static_cast<double>(n))) * mix;
  const MatrixXd T_inv = T.inverse();
  const MatrixXd At = T * A * T_inv;
  const MatrixXd Ct = C * T_inv;
  const MatrixXd Qt = T * Q0 * T.transpose();
  DareOptions raw_options = WithMethod(DareMethod::kDoubling);
  raw_options.refine = false;
  const DareSolution raw = SolveFilterDare(At, Ct, Qt, R, raw_options);
  const DareSolution d = SolveFilterDare(At, Ct, Qt, R, WithMethod(DareMethod::kDoubling));
  const DareSolution s = SolveFilterDare(At, Ct, Qt, R, WithMethod(DareMethod::kSchur, /*exact_eigenvalues=*/true));
  ExpectValidSolution(At, Ct, Qt, R, d);
  ASSERT_TRUE(s.summary.ok()) << s.summary.message;
  EXPECT_NEAR(s.closed_loop_spectral_radius, 0.999, 1e-10);  // the unobservable mode stays in A - K_p C
  ASSERT_GT(raw.summary.relative_residual, 1e-13) << "the system no longer reaches the Stein step";
  EXPECT_NE(d.summary.message.find("(a four-term Newton step not kept, 1 Stein-Newton;"), std::string::npos)
      << d.summary.message;
  EXPECT_EQ(d.refinement_steps, 1);
  EXPECT_LE(d.summary.relative_residual, 32 * std::numeric_limits<double>::epsilon()) << d.summary.message;
  EXPECT_LT(d.summary.relative_residual, 0.01 * raw.summary.relative_residual);
  EXPECT_LE(RelativeDifference(d.P_pred, s.P_pred), 500 * 1e-13);
}

// ------------------------------------------------------------------------------------------------
// Doubling vs SB02OD on seeded random systems. Measured (this machine, refinement on): relative
// residuals 1e-16..1e-14 for both methods, relative differences <= 2e-14.
class DareRandomTest : public ::testing::TestWithParam<std::tuple<int, double>> {};

TEST_P(DareRandomTest, DoublingAgreesWithSchur) {
  const auto [n, rho] = GetParam();
  const int m = std::max(1, n / 2);
  TestRng rng(1000 * n + static_cast<int>(10 * rho));
  const MatrixXd A = rng.WithSpectralRadius(n, rho);
  const MatrixXd C = rng.Gaussian(m, n);
  const MatrixXd Q = rng.Spd(n);
  const MatrixXd R = rng.Spd(m);
  const DareSolution d = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kDoubling));
  const DareSolution s = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kSchur));
  ExpectValidSolution(A, C, Q, R, d);
  ExpectValidSolution(A, C, Q, R, s);
  EXPECT_EQ(d.method_used, DareMethod::kDoubling);
  EXPECT_EQ(s.method_used, DareMethod::kSchur);
  EXPECT_EQ(s.summary.iterations, 0);
  EXPECT_GT(d.summary.iterations, 0);
  EXPECT_LE(d.summary.iterations, 12);  // quadratic convergence: 6-7 steps measured
  EXPECT_LE(RelativeDifference(d.P_pred, s.P_pred), 1e-9);
  EXPECT_LE(RelativeDifference(d.filter_gain, s.filter_gain), 1e-9);
  EXPECT_LE(d.summary.relative_residual, n <= 100 ? 1e-12 : 1e-13);
  EXPECT_LE(s.summary.relative_residual, 1e-12);
  EXPECT_TRUE(std::isfinite(d.min_eigenvalue));
  EXPECT_GT(d.min_eigenvalue, 0.0);  // Q is PD, hence so is P
  // Q > 0: the certificate decides (P - F P F^T = Q + K_p R K_p^T > 0), and its bounds agree with
  // the eigenvalues of the same solution asked for exactly.
  EXPECT_TRUE(d.lyapunov_certified) << d.summary.FullReport();
  EXPECT_FALSE(d.eigenvalues_exact);
  const DareSolution e = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kDoubling, /*exact_eigenvalues=*/true));
  ASSERT_TRUE(e.eigenvalues_exact);
  EXPECT_EQ(e.P_pred, d.P_pred);
  EXPECT_NEAR(e.min_eigenvalue, MinEigenvalue(d.P_pred), 1e-12 * d.P_pred.norm());
  EXPECT_GE(d.closed_loop_spectral_radius, e.closed_loop_spectral_radius);
  EXPECT_LE(d.min_eigenvalue, e.min_eigenvalue);
}

INSTANTIATE_TEST_SUITE_P(Sizes, DareRandomTest,
                         ::testing::Combine(::testing::Values(2, 5, 10, 50, 100, 200), ::testing::Values(0.9, 1.3)));

TEST(DareRefinement, RemovesTheRoundingAccumulatedByDoubling) {
  TestRng rng(77);
  const int n = 200, m = 100;
  const MatrixXd A = rng.WithSpectralRadius(n, 1.3);
  const MatrixXd C = rng.Gaussian(m, n);
  const MatrixXd Q = rng.Spd(n);
  const MatrixXd R = rng.Spd(m);
  DareOptions raw_options = WithMethod(DareMethod::kDoubling);
  raw_options.refine = false;
  const DareSolution raw = SolveFilterDare(A, C, Q, R, raw_options);
  const DareSolution refined = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kDoubling));
  ASSERT_TRUE(raw.summary.ok());
  ASSERT_TRUE(refined.summary.ok());
  EXPECT_EQ(raw.refinement_steps, 0);
  // Measured: raw ~4e-13, refined ~4e-15 (one four-term Newton step since issue 24; 2-3 fixed-point steps before).
  EXPECT_GT(refined.refinement_steps, 0);
  EXPECT_LT(refined.summary.relative_residual, 0.1 * raw.summary.relative_residual);
  EXPECT_LE(refined.summary.relative_residual, 2e-14);
  // The refined solution is also closer to the Schur one, not only of smaller residual.
  const DareSolution schur = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kSchur));
  EXPECT_LE(RelativeDifference(refined.P_pred, schur.P_pred), RelativeDifference(raw.P_pred, schur.P_pred));
}

TEST(DareRiccatiRecursion, ConvergesToTheDareSolution) {
  // Independent oracle: the prediction-form Riccati recursion P <- A P_filt A^T + Q from P = Q.
  TestRng rng(5);
  const int n = 6, m = 2;
  const MatrixXd A = rng.WithSpectralRadius(n, 1.1);
  const MatrixXd C = rng.Gaussian(m, n);
  const MatrixXd Q = rng.Spd(n);
  const MatrixXd R = rng.Spd(m);
  MatrixXd P = Q;
  for (int k = 0; k < 3000; ++k) {
    const MatrixXd S = C * P * C.transpose() + R;
    const MatrixXd K = S.llt().solve(C * P).transpose();
    MatrixXd Pf = P - K * C * P;
    Pf = 0.5 * (Pf + Pf.transpose()).eval();
    P = A * Pf * A.transpose() + Q;
    P = 0.5 * (P + P.transpose()).eval();
  }
  const DareSolution s = SolveFilterDare(A, C, Q, R);
  ExpectValidSolution(A, C, Q, R, s);
  EXPECT_LE(RelativeDifference(s.P_pred, P), 1e-12);
}

// ------------------------------------------------------------------------------------------------
// Shapes: n = 1, m > n, n = 0, m = 0.

TEST(DareShapes, MoreMeasurementsThanStates) {
  TestRng rng(11);
  for (const auto& [n, m] : {std::pair{1, 3}, std::pair{3, 5}, std::pair{4, 12}}) {
    const MatrixXd A = rng.WithSpectralRadius(n, 1.2);
    const MatrixXd C = rng.Gaussian(m, n);
    const MatrixXd Q = rng.Spd(n);
    const MatrixXd R = rng.Spd(m);
    const DareSolution d = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kDoubling));
    const DareSolution s = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kSchur));
    ExpectValidSolution(A, C, Q, R, d);
    ExpectValidSolution(A, C, Q, R, s);
    EXPECT_EQ(d.filter_gain.rows(), n);
    EXPECT_EQ(d.filter_gain.cols(), m);
    EXPECT_EQ(d.innovation_cov.rows(), m);
    EXPECT_LE(RelativeDifference(d.P_pred, s.P_pred), 1e-12);
  }
}

TEST(DareShapes, EmptyStateGivesEmptyResults) {
  const MatrixXd A(0, 0), C(2, 0), Q(0, 0);
  const MatrixXd R = MatrixXd::Identity(2, 2);
  for (DareMethod method : {DareMethod::kAuto, DareMethod::kDoubling, DareMethod::kSchur}) {
    const DareSolution s = SolveFilterDare(A, C, Q, R, WithMethod(method));
    EXPECT_TRUE(s.summary.ok());
    EXPECT_EQ(s.P_pred.size(), 0);
    EXPECT_EQ(s.filter_gain.rows(), 0);
    EXPECT_EQ(s.filter_gain.cols(), 2);
    EXPECT_EQ(s.innovation_cov, R);
  }
}

TEST(DareShapes, NoMeasurementsIsTheLyapunovEquation) {
  TestRng rng(12);
  const int n = 5;
  const MatrixXd A = rng.WithSpectralRadius(n, 0.8);
  const MatrixXd Q = rng.Spd(n);
  const MatrixXd C(0, n), R(0, 0);
  const MatrixXd X = SolveDiscreteLyapunov(A, Q).X;
  for (DareMethod method : {DareMethod::kDoubling, DareMethod::kSchur}) {
    const DareSolution s = SolveFilterDare(A, C, Q, R, WithMethod(method));
    ASSERT_TRUE(s.summary.ok()) << s.summary.FullReport();
    EXPECT_LE(RelativeDifference(s.P_pred, X), 1e-13) << ToString(method);
    EXPECT_EQ(s.filter_gain.cols(), 0);
  }
}

// ------------------------------------------------------------------------------------------------
// Ill-posed problems: reported in the status, never thrown.

TEST(DareDiagnosis, UnobservedUnstableModeDrivenByNoiseIsNotDetectable) {
  // Mode 1 (lambda = 1.2) is unobserved and driven by noise: P_11 grows without bound.
  const MatrixXd A = (MatrixXd(2, 2) << 1.2, 0, 0, 0.5).finished();
  const MatrixXd C = (MatrixXd(1, 2) << 0, 1).finished();
  const MatrixXd Q = MatrixXd::Identity(2, 2), R = MatrixXd::Ones(1, 1);
  for (DareMethod method : {DareMethod::kAuto, DareMethod::kDoubling, DareMethod::kSchur}) {
    DareSolution s;
    ASSERT_NO_THROW(s = SolveFilterDare(A, C, Q, R, WithMethod(method)));
    EXPECT_EQ(s.summary.termination, Termination::kNotDetectable) << ToString(method) << ": " << s.summary.FullReport();
    EXPECT_FALSE(s.summary.ok());
    EXPECT_NE(s.summary.message.find("detectable"), std::string::npos) << s.summary.message;
  }
}

// Class 9 of docs/robustness.md: an observable pair whose A has entries of 1e100 was called
// not_detectable (the unscaled PBH test compares 1 in C with 1e100 in A). The equilibrated test
// finds no defect, so no false reason is given: the DARE either succeeds or the outcome is
// "undecided (badly scaled)". A true defect in a badly scaled model is still found when it is exact.
TEST(DareDiagnosis, BadlyScaledObservablePairGetsNoFalseReason) {
  const MatrixXd C = (MatrixXd(1, 2) << 1, 1).finished();
  const MatrixXd Q = MatrixXd::Identity(2, 2), R = MatrixXd::Ones(1, 1);
  for (const double big : {1e100, 1e30}) {
    const MatrixXd A = (MatrixXd(2, 2) << big, 1, 0, 0.5).finished();
    for (DareMethod method : {DareMethod::kAuto, DareMethod::kDoubling, DareMethod::kSchur}) {
      const DareSolution s = SolveFilterDare(A, C, Q, R, WithMethod(method));
      SCOPED_TRACE(ToString(method));
      EXPECT_NE(s.summary.termination, Termination::kNotDetectable) << s.summary.FullReport();
      EXPECT_NE(s.summary.termination, Termination::kNotStabilizable) << s.summary.FullReport();
      if (!s.summary.ok()) {
        EXPECT_EQ(s.summary.termination, Termination::kUndecided) << s.summary.FullReport();
        EXPECT_NE(s.summary.message.find("undecided (badly scaled)"), std::string::npos) << s.summary.message;
      }
    }
  }
  // Mode 0.5 -> 2 unobserved (C = [1, 0]) and driven by noise, beside a 1e100 mode: an exact defect.
  const MatrixXd A = (MatrixXd(2, 2) << 1e100, 0, 0, 2).finished();
  const DareSolution s = SolveFilterDare(A, (MatrixXd(1, 2) << 1, 0).finished(), Q, R);
  EXPECT_EQ(s.summary.termination, Termination::kNotDetectable) << s.summary.FullReport();
}

TEST(DareDiagnosis, UnobservedUnstableModeWithoutNoiseIsNotDetectable) {
  // P = diag(0, p22) solves the DARE, but the closed loop keeps lambda = 1.2 (a rotated basis, so
  // that the unobservable direction is not a coordinate axis).
  const Eigen::Matrix2d rot = Eigen::Rotation2Dd(0.3).toRotationMatrix();
  const MatrixXd A = rot * (MatrixXd(2, 2) << 1.2, 0, 0, 0.5).finished() * rot.transpose();
  const MatrixXd C = (MatrixXd(1, 2) << 0, 1).finished() * rot.transpose();
  const MatrixXd Q = rot * (MatrixXd(2, 2) << 0, 0, 0, 1).finished() * rot.transpose();
  const MatrixXd R = MatrixXd::Ones(1, 1);
  for (DareMethod method : {DareMethod::kAuto, DareMethod::kDoubling, DareMethod::kSchur}) {
    const DareSolution s = SolveFilterDare(A, C, Q, R, WithMethod(method));
    EXPECT_EQ(s.summary.termination, Termination::kNotDetectable) << ToString(method) << ": " << s.summary.FullReport();
  }
}

TEST(DareDiagnosis, UnobservedModeOnTheUnitCircleIsNotDetectable) {
  // Double integrator measuring only the velocity: the position (a defective eigenvalue 1) is
  // unobservable and integrates noise, so P grows without bound. |lambda| = 1 counts as undetectable.
  const MatrixXd A = (MatrixXd(2, 2) << 1, 1, 0, 1).finished();
  const MatrixXd C = (MatrixXd(1, 2) << 0, 1).finished();
  for (DareMethod method : {DareMethod::kAuto, DareMethod::kDoubling, DareMethod::kSchur}) {
    const DareSolution s = SolveFilterDare(A, C, MatrixXd::Identity(2, 2), MatrixXd::Ones(1, 1), WithMethod(method));
    EXPECT_EQ(s.summary.termination, Termination::kNotDetectable) << ToString(method) << ": " << s.summary.FullReport();
  }
}

TEST(DareDiagnosis, NoiselessModeOnTheUnitCircleIsNotStabilizable) {
  // Observable, but the unit-circle modes get no process noise (Q = 0). P = 0 solves the DARE
  // (it is the limit of the Riccati recursion from P_0 = 0) but A - K_p C = A has rho = 1, so no
  // stabilizing solution exists. The cause is (A, Q^{1/2}) losing reachability on the unit circle:
  // kNotStabilizable (more specific than kNotStabilizing), with P = 0 returned.
  const MatrixXd scalar_one = MatrixXd::Ones(1, 1);
  const MatrixXd rot = Eigen::Rotation2Dd(0.7).toRotationMatrix();
  const struct {
    MatrixXd A, C, Q, R;
  } cases[] = {{scalar_one, scalar_one, MatrixXd::Zero(1, 1), scalar_one},
               {rot, (MatrixXd(1, 2) << 1, 0).finished(), MatrixXd::Zero(2, 2), scalar_one}};
  for (const auto& c : cases) {
    for (DareMethod method : {DareMethod::kAuto, DareMethod::kDoubling, DareMethod::kSchur}) {
      DareSolution s;
      ASSERT_NO_THROW(s = SolveFilterDare(c.A, c.C, c.Q, c.R, WithMethod(method)));
      EXPECT_EQ(s.summary.termination, Termination::kNotStabilizable)
          << ToString(method) << ": " << s.summary.FullReport();
      if (method != DareMethod::kSchur) {  // doubling's result: the (non-stabilizing) solution P = 0
        EXPECT_MATRICES_NEAR(s.P_pred, MatrixXd::Zero(c.A.rows(), c.A.rows()), 1e-14);
        // The certificate cannot decide (P = 0 is not positive definite): the eigenvalues do.
        EXPECT_FALSE(s.lyapunov_certified);
        EXPECT_TRUE(s.eigenvalues_exact);
        EXPECT_NEAR(s.closed_loop_spectral_radius, 1.0, 1e-12);
      }
    }
  }
}

TEST(DareFallback, ZeroNoiseUnstableModeNeedsTheSchurMethod) {
  // a = 1.5, c = 1, q = 0, r = 1: p^2 - 1.25 p = 0, so p = 0 (closed loop 1.5) or p = 1.25
  // (closed loop 1.5 - 1.5 * 1.25 / 2.25 = 2/3). Doubling from H_0 = Q = 0 stays at 0.
  const MatrixXd A = MatrixXd::Constant(1, 1, 1.5), C = MatrixXd::Ones(1, 1);
  const MatrixXd Q = MatrixXd::Zero(1, 1), R = MatrixXd::Ones(1, 1);
  const DareSolution d = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kDoubling));
  EXPECT_EQ(d.summary.termination, Termination::kNotStabilizing) << d.summary.FullReport();
  EXPECT_EQ(d.P_pred(0, 0), 0.0);
  const DareSolution s = SolveFilterDare(A, C, Q, R);
  ASSERT_TRUE(s.summary.ok()) << s.summary.FullReport();
  EXPECT_TRUE(s.fell_back);
  EXPECT_EQ(s.method_used, DareMethod::kSchur);
  EXPECT_NEAR(s.P_pred(0, 0), 1.25, 1e-14);
  // P - F P F^T = K_p R K_p^T = (1.5 * 1.25 / 2.25)^2 > 0: certified, with a bound above 2/3.
  EXPECT_TRUE(s.lyapunov_certified);
  EXPECT_GE(s.closed_loop_spectral_radius, 2.0 / 3.0);
  EXPECT_LT(s.closed_loop_spectral_radius, 1.0);
  const DareSolution e = SolveFilterDare(A, C, Q, R, WithMethod(DareMethod::kAuto, /*exact_eigenvalues=*/true));
  EXPECT_NEAR(e.closed_loop_spectral_radius, 2.0 / 3.0, 1e-14);
}

TEST(DareIterationLimit, ReportsNotConverged) {
  TestRng rng(3);
  const MatrixXd A = rng.WithSpectralRadius(8, 1.3);
  const MatrixXd C = rng.Gaussian(2, 8);
  DareOptions options = WithMethod(DareMethod::kDoubling);
  options.max_iterations = 1;
  const MatrixXd R = rng.Spd(2);  // one draw per statement, in GCC's former order of the arguments (TestRng)
  const MatrixXd Q = rng.Spd(8);
  const DareSolution s = SolveFilterDare(A, C, Q, R, options);
  EXPECT_EQ(s.summary.termination, Termination::kNotConverged) << s.summary.FullReport();
  EXPECT_EQ(s.summary.iterations, 1);
  EXPECT_EQ(s.P_pred.rows(), 8);  // the last iterate
}

// ------------------------------------------------------------------------------------------------
// The Lyapunov stability certificate (CertifyStability; docs/riccati.md). Oracle: DGEEV / Eigen's
// eigenvalues of the same F, and DARE solutions whose stability is known in closed form.

/// Scalar DARE roots: the stabilizing (+) and anti-stabilizing (-) solution of
/// c^2 p^2 + (r - a^2 r - q c^2) p - q r = 0 (see ScalarDare); the product of the roots is
/// -q r / c^2, which gives the second without cancellation.
std::pair<double, double> ScalarDareRoots(double a, double c, double q, double r) {
  const double plus = ScalarDare(a, c, q, r);
  return {plus, -q * r / (c * c * plus)};
}

TEST(StabilityCertificate, AgreesWithTheEigenvaluesOnRandomStableAndUnstableMatrices) {
  // X solves the Stein equation X = F X F^T + Q (Q SPD). For rho(F) < 1 it is SPD and
  // X - F X F^T = Q > 0: certified, with rho(F) <= bound < 1 and lambda_min(X) >= s. For rho(F) > 1
  // (no eigenvalue pair with product 1) X is indefinite: never certified.
  int certified = 0, refused = 0;
  for (int n : {1, 3, 10, 40}) {
    for (double rho : {0.1, 0.6, 0.95, 0.999, 1.05, 1.6}) {
      for (int seed = 0; seed < 3; ++seed) {
        TestRng rng(100 * n + static_cast<int>(1000 * rho) + 7 * seed);
        const MatrixXd F = rng.WithSpectralRadius(n, rho);
        const MatrixXd Q = rng.Spd(n);
        const LyapunovSolution lyapunov = SolveDiscreteLyapunov(F, Q);
        if (!lyapunov.summary.ok()) continue;  // (nearly) reciprocal eigenvalue pair: no X to test with
        const MatrixXd& X = lyapunov.X;
        const StabilityCertificate cert = CertifyStability(F, X);
        const double exact = Rho(F);
        SCOPED_TRACE("n = " + std::to_string(n) + ", rho = " + std::to_string(exact) + ": " + cert.summary.message);
        if (exact < 1.0) {
          ASSERT_TRUE(cert.certified());
          ++certified;
          EXPECT_GE(cert.spectral_radius_bound, exact);
          EXPECT_LE(cert.spectral_radius_bound, 1.0);
          EXPECT_GE(cert.min_eigenvalue_bound, 0.0);
          EXPECT_LE(cert.min_eigenvalue_bound, MinEigenvalue(X));
          // s < lambda_min(X - F X F^T) = lambda_min(Q + Stein residual)
          EXPECT_LE(cert.min_eigenvalue_bound, MinEigenvalue(Q) + 1e-9 * X.norm());
          if (exact < 0.99) {
            EXPECT_LT(cert.spectral_radius_bound, 1.0);
          }
        } else {
          EXPECT_FALSE(cert.certified());
          ++refused;
          EXPECT_EQ(cert.spectral_radius_bound, std::numeric_limits<double>::infinity());
        }
      }
    }
  }
  EXPECT_GE(certified, 40);
  EXPECT_GE(refused, 20);
}

TEST(StabilityCertificate, RefusesTheAntiStabilizingSolutionOfAScalarDare) {
  // a = 2, c = q = r = 1: p^2 - 4 p - 1 = 0, p = 2 +- sqrt(5). Both solve the DARE; with
  // F = a - K_p c = a r / (c^2 p + r): the + root gives F = 2 / (3 + sqrt 5) = 0.382 (stabilizing),
  // the - root F = 2 / (3 - sqrt 5) = 2.618. For both P - F P F^T = q + K_p^2 r > 0: the positive
  // definiteness of P is what the proof needs, and the anti-stabilizing P = -0.236 lacks it.
  const auto [p_plus, p_minus] = ScalarDareRoots(2.0, 1.0, 1.0, 1.0);
  EXPECT_NEAR(p_plus, 2 + std::sqrt(5.0), 1e-14);
  const MatrixXd A = MatrixXd::Constant(1, 1, 2.0), one = MatrixXd::Ones(1, 1);
  for (const double p : {p_plus, p_minus}) {
    const MatrixXd P = MatrixXd::Constant(1, 1, p);
    EXPECT_LT(FilterDareResidual(A, one, one, one, P), 1e-15);  // both are solutions
    const double f = 2.0 / (p + 1.0);
    const StabilityCertificate cert = CertifyStability(MatrixXd::Constant(1, 1, f), P);
    const double m = p - f * f * p;  // = 1 + K_p^2 > 0 for both roots
    EXPECT_NEAR(m, 1 + std::pow(2 * p / (p + 1), 2), 1e-12);
    if (p > 0) {
      EXPECT_TRUE(cert.certified()) << cert.summary.message;
      EXPECT_NEAR(f, 2 / (3 + std::sqrt(5.0)), 1e-15);
      // 1 x 1: the bound is sqrt(1 - s / p) with s <= m = p (1 - f^2): at least f.
      EXPECT_GE(cert.spectral_radius_bound, f);
      EXPECT_LT(cert.spectral_radius_bound, 1.0);
    } else {
      EXPECT_FALSE(cert.certified()) << cert.summary.message;
      EXPECT_NEAR(f, 2 / (3 - std::sqrt(5.0)), 1e-14);
    }
  }
}

TEST(StabilityCertificate, RefusesAMixedSolutionOfACoupledDare) {
  // A rotated diag(2, 3), C = I, Q = R = I: two decoupled scalar DAREs (Q, R invariant under the
  // rotation). Taking the stabilizing root for one mode and the anti-stabilizing one for the other
  // gives an indefinite solution whose closed loop has one eigenvalue outside the unit circle.
  const Eigen::Matrix2d U = Eigen::Rotation2Dd(0.4).toRotationMatrix();
  const double a[2] = {2.0, 3.0};
  const MatrixXd A = U * Eigen::Vector2d(a[0], a[1]).asDiagonal() * U.transpose();
  const MatrixXd I = MatrixXd::Identity(2, 2);
  for (int anti = 0; anti < 3; ++anti) {  // 0, 1: mode `anti` anti-stabilizing; 2: both stabilizing
    Eigen::Vector2d p;
    for (int i = 0; i < 2; ++i) {
      const auto [plus, minus] = ScalarDareRoots(a[i], 1.0, 1.0, 1.0);
      p(i) = i == anti ? minus : plus;
    }
    const MatrixXd P = U * p.asDiagonal() * U.transpose();
    EXPECT_LT(FilterDareResidual(A, I, I, I, P), 1e-14);
    const MatrixXd K_p = A * P * (P + I).inverse();
    const MatrixXd F = A - K_p;
    const StabilityCertificate cert = CertifyStability(F, P);
    EXPECT_EQ(cert.certified(), anti == 2) << cert.summary.message;
    EXPECT_EQ(Rho(F) < 1.0, anti == 2);
  }
}

TEST(StabilityCertificate, CannotDecideMarginalOrSingularCasesButNeverClaimsStability) {
  // (a) A rotation (rho = 1 exactly) with its invariant Gramian: X = I, X - F X F^T = 0.
  const MatrixXd rot = Eigen::Rotation2Dd(0.7).toRotationMatrix();
  EXPECT_FALSE(CertifyStability(rot, MatrixXd::Identity(2, 2)).certified());
  // (b) Stable, but X only PSD (X = 0, as for Q = 0): the eigenvalues must decide.
  EXPECT_FALSE(CertifyStability(0.5 * rot, MatrixXd::Zero(2, 2)).certified());
  // (c) X = I > 0, but F = diag(0.5, 1) has an eigenvalue on the unit circle: M = diag(0.75, 0).
  const MatrixXd F = (MatrixXd(2, 2) << 0.5, 0, 0, 1).finished();
  EXPECT_FALSE(CertifyStability(F, MatrixXd::Identity(2, 2)).certified());
  // (d) Just stable: rho = 1 - 1e-9 with the exact Gramian of Q = I: still a proof (M = I > 0),
  //     with a bound in [rho, 1].
  const double r = 1 - 1e-9;
  const MatrixXd Fd = (MatrixXd(2, 2) << r, 0, 0, 0.5).finished();
  const MatrixXd Xd = (MatrixXd(2, 2) << 1 / (1 - r * r), 0, 0, 1 / 0.75).finished();
  const StabilityCertificate cd = CertifyStability(Fd, Xd);
  EXPECT_TRUE(cd.certified()) << cd.summary.message;
  EXPECT_GE(cd.spectral_radius_bound, r);
  EXPECT_LE(cd.spectral_radius_bound, 1.0);
  // (e) A perturbation budget larger than the stability margin of (d) must make it refuse.
  EXPECT_FALSE(CertifyStability(Fd, Xd, 1e-6).certified());
  EXPECT_TRUE(CertifyStability(0.5 * rot, MatrixXd::Identity(2, 2) * (1 / 0.75), 1e-3).certified());
  // Empty and invalid input.
  EXPECT_TRUE(CertifyStability(MatrixXd(0, 0), MatrixXd(0, 0)).certified());
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(
      [&] { CertifyStability(MatrixXd::Ones(2, 3), MatrixXd::Identity(2, 2)); }, "F:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { CertifyStability(rot, MatrixXd::Identity(3, 3)); }, "X:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { CertifyStability(rot, MatrixXd::Identity(2, 2), -1.0); },
                                               "perturbation:"));
}

TEST(DareCertificate, SingularNoiseFallsBackToTheEigenvalues) {
  // Q = e1 e1^T, A stable and diagonal, C measures mode 1 only: P = diag(p, 0, 0) is singular, so
  // the certificate cannot decide; the eigenvalues accept the (stabilizing) solution.
  const MatrixXd A = Eigen::Vector3d(0.9, 0.5, -0.3).asDiagonal();
  const MatrixXd C = (MatrixXd(1, 3) << 1, 0, 0).finished();
  MatrixXd Q = MatrixXd::Zero(3, 3);
  Q(0, 0) = 1.0;
  const DareSolution s = SolveFilterDare(A, C, Q, MatrixXd::Ones(1, 1));
  ASSERT_TRUE(s.summary.ok()) << s.summary.FullReport();
  EXPECT_FALSE(s.lyapunov_certified);
  EXPECT_TRUE(s.eigenvalues_exact);
  EXPECT_NEAR(s.P_pred(0, 0), ScalarDare(0.9, 1.0, 1.0, 1.0), 1e-14);
  const double kp = 0.9 * s.P_pred(0, 0) / (s.P_pred(0, 0) + 1);
  EXPECT_NEAR(s.closed_loop_spectral_radius, std::max(0.9 - kp, 0.5), 1e-14);
  EXPECT_NE(s.summary.FullReport().find("eigenvalues (DGEEV)"), std::string::npos);
}

TEST(DareValidation, EveryInvalidInputThrowsNamingTheArgument) {
  const MatrixXd A = MatrixXd::Identity(2, 2) * 0.5, C = MatrixXd::Ones(1, 2);
  const MatrixXd Q = MatrixXd::Identity(2, 2), R = MatrixXd::Ones(1, 1);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  MatrixXd bad;
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SolveFilterDare(MatrixXd::Ones(2, 3), C, Q, R); }, "A:"));
  bad = A;
  bad(1, 0) = nan;
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SolveFilterDare(bad, C, Q, R); }, "A:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SolveFilterDare(A, MatrixXd::Ones(1, 3), Q, R); }, "C:"));
  bad = C;
  bad(0, 1) = inf;
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SolveFilterDare(A, bad, Q, R); }, "C:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SolveFilterDare(A, C, MatrixXd::Identity(3, 3), R); }, "Q:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(
      [&] { SolveFilterDare(A, C, (MatrixXd(2, 2) << 1, 0.5, 0, 1).finished(), R); }, "Q:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(
      [&] { SolveFilterDare(A, C, (MatrixXd(2, 2) << 1, 0, 0, -1).finished(), R); }, "Q:"));
  bad = Q;
  bad(0, 0) = nan;
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SolveFilterDare(A, C, bad, R); }, "Q:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SolveFilterDare(A, C, Q, MatrixXd::Identity(2, 2)); }, "R:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SolveFilterDare(A, C, Q, MatrixXd::Zero(1, 1)); }, "R:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SolveFilterDare(A, C, Q, MatrixXd::Constant(1, 1, -1)); }, "R:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(
      [&] {
        SolveFilterDare(A, MatrixXd::Ones(2, 2), MatrixXd::Identity(2, 2), (MatrixXd(2, 2) << 1, 1, 1, 1).finished());
      },
      "R:"));  // singular
  const auto with_options = [&](const std::function<void(DareOptions&)>& edit) {
    DareOptions options;
    edit(options);
    std::string why;
    EXPECT_FALSE(options.IsValid(&why));
    EXPECT_FALSE(why.empty());
    EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SolveFilterDare(A, C, Q, R, options); }, "options:"));
  };
  with_options([](DareOptions& o) { o.max_iterations = 0; });
  with_options([](DareOptions& o) { o.max_iterations = 201; });
  with_options([](DareOptions& o) { o.tolerance = 0; });
  with_options([](DareOptions& o) { o.tolerance = 0.1; });
  with_options([&](DareOptions& o) { o.tolerance = nan; });
  with_options([](DareOptions& o) { o.stability_margin = -0.1; });
  with_options([](DareOptions& o) { o.stability_margin = 1.0; });
  with_options([](DareOptions& o) { o.method = static_cast<DareMethod>(17); });
  std::string why;
  EXPECT_TRUE(DareOptions().IsValid(&why));
  EXPECT_TRUE(DareOptions().IsValid(nullptr));
}

TEST(DareResidual, IsZeroAtTheSolutionAndValidatesItsInput) {
  const MatrixXd A = MatrixXd::Constant(1, 1, 1.5), C = MatrixXd::Constant(1, 1, 2.0);
  const MatrixXd Q = MatrixXd::Constant(1, 1, 0.3), R = MatrixXd::Constant(1, 1, 0.7);
  const double p = ScalarDare(1.5, 2.0, 0.3, 0.7);
  EXPECT_LT(FilterDareResidual(A, C, Q, R, MatrixXd::Constant(1, 1, p)), 1e-15);
  // A wrong candidate: |p' - F(p')| / |p'| with F(p') = a^2 p' r / (c^2 p' + r) + q.
  const double wrong = 2 * p;
  const double expected = std::abs(wrong - (2.25 * wrong * 0.7 / (4 * wrong + 0.7) + 0.3)) / wrong;
  EXPECT_NEAR(FilterDareResidual(A, C, Q, R, MatrixXd::Constant(1, 1, wrong)), expected, 1e-15);
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { FilterDareResidual(A, C, Q, R, MatrixXd::Ones(2, 2)); }, "P:"));
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(
      [&] { FilterDareResidual(A, MatrixXd::Ones(1, 2), Q, R, MatrixXd::Ones(1, 1)); }, "C:"));
}

TEST(DareReport, NamesStatusAndMethod) {
  // The terminations a DARE reports, with the text the CLI's JSON carries.
  const std::pair<Termination, const char*> statuses[] = {{Termination::kConverged, "converged"},
                                                          {Termination::kNotConverged, "not_converged"},
                                                          {Termination::kNotStabilizing, "not_stabilizing"},
                                                          {Termination::kNotDetectable, "not_detectable"},
                                                          {Termination::kNotStabilizable, "not_stabilizable"},
                                                          {Termination::kFailed, "failed"}};
  for (const auto& [status, text] : statuses) {
    EXPECT_STREQ(ToString(status), text);
    EXPECT_EQ(ParseEnum<Termination>("status", text), status);
  }
  EXPECT_STREQ(ToString(DareMethod::kAuto), "auto");
  EXPECT_STREQ(ToString(DareMethod::kDoubling), "doubling");
  EXPECT_STREQ(ToString(DareMethod::kSchur), "schur");
  const MatrixXd one = MatrixXd::Ones(1, 1);
  const DareSolution s = SolveFilterDare(one, one, one, one);
  EXPECT_NE(s.summary.BriefReport().find("converged"), std::string::npos) << s.summary.BriefReport();
  EXPECT_NE(s.summary.BriefReport().find("doubling"), std::string::npos);
  EXPECT_EQ(s.summary.BriefReport().find('\n'), std::string::npos);
  const std::string full = s.summary.FullReport();
  for (const char* key : {"termination", "method", "relative residual", "rho(A - K_p C)", "time [s]", "message"}) {
    EXPECT_NE(full.find(key), std::string::npos) << key << " missing in\n" << full;
  }
}

}  // namespace
}  // namespace kfx
