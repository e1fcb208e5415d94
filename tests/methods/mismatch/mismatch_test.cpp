// Filters built on a wrong model (paper 002): the exact true error by (15)-(19) against the
// exact-performance engine and Monte Carlo, and the bounds of Theorems 1-6 against true values on
// seeded random systems inside their error boxes.
#include "kfx/mismatch.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/performance.hpp"
#include "kfx/riccati.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using testing::TestRng;

double Spectral(const MatrixXd& m) { return Eigen::JacobiSVD<MatrixXd>(m).singularValues()(0); }

// A random step: stable A, noise input B (n x p) with covariance U when p > 0, else a full Q.
ModelStep RandomStep(TestRng& rng, Eigen::Index n, Eigen::Index m, Eigen::Index p, double rho) {
  const MatrixXd A = rng.WithSpectralRadius(n, rho);
  const MatrixXd C = rng.Gaussian(m, n);
  // One draw per statement, in GCC's former order of the arguments (TestRng).
  const MatrixXd R = rng.Spd(m, 0.3);
  if (p > 0) {
    const MatrixXd U = rng.Spd(p, 0.2);
    const MatrixXd B = rng.Gaussian(n, p);
    return MakeStepWithNoiseInput(A, B, U, C, R);
  }
  const MatrixXd Q = rng.Spd(n, 0.2);
  return MakeStep(A, C, Q, R);
}

// A design near `truth` with errors in A, C, the noise covariance and R together.
ModelStep PerturbedDesign(TestRng& rng, const ModelStep& truth, double eps) {
  const Eigen::Index n = truth.A.rows(), m = truth.C.rows();
  const MatrixXd A = truth.A + eps * rng.Gaussian(n, n);
  const MatrixXd C = truth.C + eps * rng.Gaussian(m, n);
  const MatrixXd R = truth.R + eps * rng.Spd(m, 0.0);
  if (truth.B.size() > 0) return MakeStepWithNoiseInput(A, truth.B, truth.U + eps * rng.Spd(truth.U.rows(), 0.0), C, R);
  return MakeStep(A, C, truth.Q + eps * rng.Spd(n, 0.0), R);
}

MatrixXd Zeros(const MatrixXd& like) { return MatrixXd::Zero(like.rows(), like.cols()); }

// A uniformly drawn point of the box (symmetric entries tied), or false if the truth is invalid or
// not stable (002's standing assumption).
bool RandomPointInBox(std::mt19937_64& gen, const ModelStep& design, const ErrorRanges& r, ModelingErrors* e,
                      ModelStep* truth) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto draw = [&](const MatrixXd& range, bool sym) {
    MatrixXd d = MatrixXd::Zero(range.rows(), range.cols());
    for (Eigen::Index j = 0; j < d.cols(); ++j)
      for (Eigen::Index i = 0; i < d.rows(); ++i) {
        if (sym && i > j) continue;
        d(i, j) = range(i, j) * u(gen);
        if (sym) d(j, i) = d(i, j);
      }
    return d;
  };
  e->A = draw(r.A, false);
  e->C = draw(r.C, false);
  e->Q = draw(r.Q, true);
  e->R = draw(r.R, true);
  try {
    *truth = ApplyModelingErrors(design, *e);
  } catch (const Error&) {
    return false;
  }
  return SpectralRadius(truth->A) < 1.0;
}

// ---- exact true error --------------------------------------------------------------------------

TEST(MismatchStationary, EqualsEngineJointCovarianceOnRandomMismatchedSystems) {
  int compared = 0;
  for (int seed = 1; seed <= 24; ++seed) {
    TestRng rng(static_cast<std::uint64_t>(seed));
    const Eigen::Index n = 1 + seed % 4, m = 1 + seed % 2, p = seed % 3 == 0 ? 0 : 1 + seed % 2;
    const ModelStep truth = RandomStep(rng, n, m, p, 0.5 + 0.02 * seed);
    const ModelStep design = PerturbedDesign(rng, truth, 0.15);
    const StationaryMismatch s = StationaryMismatchedCovariance(design, truth);
    if ((s.summary.termination == Termination::kUnstable && s.filter_spectral_radius >= 1.0)) continue;
    ASSERT_TRUE(s.summary.ok()) << "seed " << seed << ": " << s.summary.message;
    EXPECT_LT(s.summary.relative_residual, 1e-12) << "seed " << seed;
    const Model truth_model(truth, VectorXd::Zero(n), MatrixXd::Identity(n, n));
    const LinearFilter f = ConstantGainAsLinearFilter(design, s.filter_gain, VectorXd::Zero(n));
    const StationaryPerformance engine = ExactStationaryPerformance(truth_model, f);
    ASSERT_EQ(engine.method, StationaryMethod::kJoint);
    EXPECT_MATRICES_NEAR(s.P, engine.error_cov, 1e-12 * std::max(1.0, engine.error_cov.norm())) << "seed " << seed;
    ++compared;
  }
  EXPECT_GE(compared, 20);
}

TEST(MismatchStationary, ZeroErrorsGiveKalmanFilterCovariance) {
  for (int seed = 1; seed <= 6; ++seed) {
    TestRng rng(static_cast<std::uint64_t>(100 + seed));
    const Eigen::Index n = 1 + seed % 4;
    const ModelStep step = RandomStep(rng, n, 1 + seed % 2, seed % 2, 0.8);
    const StationaryMismatch s = StationaryMismatchedCovariance(step, step);
    ASSERT_TRUE(s.summary.ok()) << s.summary.message;
    const DareSolution dare = SolveFilterDare(step.A, step.C, step.Q, step.R);
    EXPECT_MATRICES_NEAR(s.P, dare.P_filt, 1e-12 * std::max(1.0, dare.P_filt.norm()));
    // Orthogonality of the optimal estimate: E[x x~^T] = E[(x^ - x~) x~^T] = -P.
    EXPECT_MATRICES_NEAR(s.V, -dare.P_filt, 1e-12 * std::max(1.0, dare.P_filt.norm()));
    // Errors between a step and itself are zero; the truth they give is the step.
    const ModelingErrors e = ModelingErrorsBetween(step, step);
    EXPECT_EQ(e.A.norm() + e.C.norm() + e.Q.norm() + e.R.norm(), 0.0);
  }
}

TEST(MismatchSequence, EqualsExactPerformanceAtEveryStep) {
  for (int seed = 1; seed <= 4; ++seed) {
    TestRng rng(static_cast<std::uint64_t>(200 + seed));
    const Eigen::Index n = 2 + seed % 2, m = 1 + seed % 2;
    // Time-varying truth and design (A, C, R change with k), nonzero and different priors.
    std::vector<ModelStep> ts, ds;
    for (int k = 0; k < 3; ++k) {
      ts.push_back(RandomStep(rng, n, m, seed % 2, 0.9));
      ds.push_back(PerturbedDesign(rng, ts.back(), 0.2));
    }
    const MatrixXd P0_truth = rng.Spd(n, 0.5);  // one draw per statement, in GCC's former order (TestRng)
    const VectorXd x0_truth = rng.Gaussian(n, 1);
    const Model truth(ts, x0_truth, P0_truth);
    const MatrixXd P0_design = rng.Spd(n, 0.5);
    const VectorXd x0_design = rng.Gaussian(n, 1);
    const Model design(ds, x0_design, P0_design);
    const MismatchSequence seq = MismatchedCovarianceSequence(design, truth, MismatchSequenceOptions{3});
    const PerformanceResult exact =
        ExactPerformance(truth, KalmanAsLinearFilter(design, ComputeKalmanSchedule(design, KalmanScheduleOptions{3})));
    for (int k = 0; k <= 3; ++k) {
      const MatrixXd& E = exact.error_moment[static_cast<size_t>(k)];
      EXPECT_MATRICES_NEAR(seq.P[static_cast<size_t>(k)], E, 1e-12 * std::max(1.0, E.norm()))
          << "seed " << seed << ", k " << k;
    }
  }
}

TEST(MismatchSequence, ConvergesToTheStationarySolution) {
  TestRng rng(301);
  const ModelStep truth = RandomStep(rng, 3, 2, 2, 0.7);
  const ModelStep design = PerturbedDesign(rng, truth, 0.1);
  const StationaryMismatch s = StationaryMismatchedCovariance(design, truth);
  ASSERT_TRUE(s.summary.ok()) << s.summary.message;
  const Model tm(truth, VectorXd::Zero(3), MatrixXd::Identity(3, 3));
  const Model dm(design, VectorXd::Zero(3), MatrixXd::Identity(3, 3));
  const MismatchSequence seq = MismatchedCovarianceSequence(dm, tm, MismatchSequenceOptions{300});
  EXPECT_MATRICES_NEAR(seq.P.back(), s.P, 1e-9 * s.P.norm());
  EXPECT_MATRICES_NEAR(seq.V.back(), s.V, 1e-9 * std::max(1.0, s.V.norm()));
  EXPECT_MATRICES_NEAR(seq.U.back(), s.U, 1e-9 * s.U.norm());
}

TEST(MismatchSequence, MonteCarloAgreesWithinItsConfidenceInterval) {
  TestRng rng(401);
  const ModelStep truth = RandomStep(rng, 2, 1, 1, 0.8);
  const ModelStep design = PerturbedDesign(rng, truth, 0.3);
  const Model tm(truth, VectorXd::Ones(2), 0.5 * MatrixXd::Identity(2, 2));
  const Model dm(design, VectorXd::Zero(2), MatrixXd::Identity(2, 2));
  const int T = 8;
  const MismatchSequence seq = MismatchedCovarianceSequence(dm, tm, MismatchSequenceOptions{T});
  MonteCarloOptions mo;
  mo.runs = 3000;
  mo.steps = T;
  mo.seed = 11;
  const MonteCarloResult mc =
      MonteCarloPerformance(tm, KalmanAsLinearFilter(dm, ComputeKalmanSchedule(dm, KalmanScheduleOptions{T})), mo);
  for (int k : {1, 4, T}) {
    EXPECT_LT(std::abs(mc.mse(k) - seq.trace(k)), 4.0 * mc.mse_std_error(k))
        << "k " << k << ": exact " << seq.trace(k) << ", Monte Carlo " << mc.mse(k) << " +- " << mc.mse_std_error(k);
  }
}

// ---- bounds ------------------------------------------------------------------------------------

TEST(MismatchBounds, Theorem1IdentityIsExactAndBoundHolds) {
  int checked = 0;
  for (int seed = 1; seed <= 12; ++seed) {
    TestRng rng(static_cast<std::uint64_t>(500 + seed));
    const Eigen::Index n = 1 + seed % 3;
    const ModelStep truth = RandomStep(rng, n, 1 + seed % 2, seed % 2, 0.7);
    const ModelStep design = PerturbedDesign(rng, truth, 0.1);
    if (SpectralRadius((MatrixXd::Identity(n, n) -
                        SolveFilterDare(design.A, design.C, design.Q, design.R).filter_gain * design.C) *
                       design.A) >= 1.0)
      continue;
    const Theorem1Result r = Theorem1Bound(design, ModelingErrorsBetween(design, truth));
    // tr P = i^T M^{-1} (b + cs(D)) exactly: checks the corrected (26) term by term.
    EXPECT_NEAR(r.identity_trace, r.exact.trace, 1e-11 * r.exact.trace) << "seed " << seed;
    EXPECT_GE(r.pi1, r.exact.trace * (1 - 1e-12)) << "seed " << seed;
    ++checked;
  }
  EXPECT_GE(checked, 10);
}

TEST(MismatchBounds, Theorem2IsALowerBoundOnRandomSystems) {
  for (int seed = 1; seed <= 12; ++seed) {
    TestRng rng(static_cast<std::uint64_t>(600 + seed));
    const ModelStep s = RandomStep(rng, 1 + seed % 4, 1 + seed % 2, 0, 0.3 + 0.05 * seed);
    const double tr = SolveFilterDare(s.A, s.C, s.Q, s.R).P_filt.trace();
    const double pi2 = Theorem2Bound(s);
    EXPECT_GT(pi2, 0.0);
    EXPECT_LE(pi2, tr * (1 + 1e-12)) << "seed " << seed;
  }
}

// (29) prints |A^T H^T R^{-1} H A|_s^5. That bound is not a lower bound: a scalar counterexample.
TEST(MismatchBounds, Theorem2PrintedExponentFiveIsNotALowerBound) {
  const double a = 0.9, q = 1.0, r = 1.0;
  const ModelStep s = MakeStep(MatrixXd::Constant(1, 1, a), MatrixXd::Ones(1, 1), MatrixXd::Constant(1, 1, q),
                               MatrixXd::Constant(1, 1, r));
  const double tr = SolveFilterDare(s.A, s.C, s.Q, s.R).P_filt.trace();
  const double a1 = a * a / r, a2 = 1.0 + q / r - a * a, a3 = q;
  const double a1_printed = std::pow(a1, 5);
  const double pi2_printed = (-a2 + std::sqrt(a2 * a2 + 4 * a1_printed * a3)) / (2 * a1_printed);
  EXPECT_LE(Theorem2Bound(s), tr * (1 + 1e-12));  // equality for a scalar system
  EXPECT_GT(pi2_printed, tr);
}

TEST(MismatchBounds, Theorems3And4HoldInsideNoiseErrorBoxes) {
  std::mt19937_64 gen(7);
  int checked = 0;
  for (int seed = 1; seed <= 8; ++seed) {
    TestRng rng(static_cast<std::uint64_t>(700 + seed));
    const Eigen::Index n = 1 + seed % 3, m = 1 + seed % 2, p = seed % 2 ? 1 : 0;
    const ModelStep design = RandomStep(rng, n, m, p, 0.8);
    ErrorRanges ranges;
    const MatrixXd qs = rng.Spd(design.B.size() > 0 ? design.U.rows() : n, 0.0);
    ranges.Q = 0.3 * qs.cwiseAbs();
    ranges.R = 0.2 * rng.Spd(m, 0.0).cwiseAbs();
    const PatelTodaBounds b = ComputePatelTodaBounds(design, ranges);
    ASSERT_TRUE(b.pi3 && b.pi4);
    EXPECT_FALSE(b.pi5 || b.pi6);
    const double pi4_trace = Theorem4Bound(design, b.norms, EigenvalueTerm::kTraceSquared);
    EXPECT_LE(pi4_trace, *b.pi4);
    MismatchOptions fixed;
    fixed.filter_gain = b.terms.filter_gain;
    for (int draw = 0; draw < 20; ++draw) {
      ModelingErrors e;
      ModelStep truth;
      if (!RandomPointInBox(gen, design, ranges, &e, &truth)) continue;
      const StationaryMismatch s = StationaryMismatchedCovariance(design, truth, fixed);
      ASSERT_TRUE(s.summary.ok()) << s.summary.message;
      EXPECT_GE(*b.pi3, s.trace) << "seed " << seed;
      const double pf = SolveFilterDare(truth.A, truth.C, truth.Q, truth.R).P_filt.trace();
      EXPECT_LE(*b.pi4, pf) << "seed " << seed;
      ++checked;
    }
  }
  EXPECT_GE(checked, 100);
}

TEST(MismatchBounds, Theorems5And6HoldInsidePlantErrorBoxes) {
  std::mt19937_64 gen(9);
  int checked = 0;
  for (int seed = 1; seed <= 8; ++seed) {
    TestRng rng(static_cast<std::uint64_t>(800 + seed));
    const Eigen::Index n = 1 + seed % 3, m = 1 + seed % 2;
    const ModelStep design = RandomStep(rng, n, m, seed % 2, 0.6);
    ErrorRanges ranges;
    ranges.A = 0.03 * rng.Gaussian(n, n).cwiseAbs();
    ranges.C = 0.03 * rng.Gaussian(m, n).cwiseAbs();
    const PatelTodaBounds b = ComputePatelTodaBounds(design, ranges);
    ASSERT_TRUE(b.pi5 && b.pi6 && b.lemma);
    EXPECT_FALSE(b.pi3 || b.pi4);
    ASSERT_TRUE(b.lemma->applies()) << b.lemma->summary.message;
    MismatchOptions fixed;
    fixed.filter_gain = b.terms.filter_gain;
    for (int draw = 0; draw < 20; ++draw) {
      ModelingErrors e;
      ModelStep truth;
      if (!RandomPointInBox(gen, design, ranges, &e, &truth)) continue;
      const StationaryMismatch s = StationaryMismatchedCovariance(design, truth, fixed);
      if ((s.summary.termination == Termination::kUnstable && s.filter_spectral_radius >= 1.0)) continue;
      ASSERT_TRUE(s.summary.ok()) << s.summary.message;
      EXPECT_GE(b.lemma->beta, Spectral(s.U)) << "seed " << seed;
      if (b.lemma->printed_is_valid) {
        EXPECT_GE(b.lemma->beta_printed, Spectral(s.U));
      }
      EXPECT_GE(*b.pi5, s.trace) << "seed " << seed;
      const double pf = SolveFilterDare(truth.A, truth.C, truth.Q, truth.R).P_filt.trace();
      EXPECT_LE(*b.pi6, pf) << "seed " << seed;
      ++checked;
    }
  }
  EXPECT_GE(checked, 100);
}

// The Lemma's (41) applies the Bellman-Gronwall lemma to a constant. Scalar counterexample:
// A_M = 0.5, dA = -0.45 (true A = 0.95) gives x = 0.87 > 0.797, where (41) is below the true U.
TEST(MismatchBounds, LemmaAsPrintedFailsBeyondItsLimitAndSoundBoundHolds) {
  const ModelStep design =
      MakeStep(MatrixXd::Constant(1, 1, 0.5), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1));
  const LemmaBound b = LemmaStateBound(design, 0.45);
  ASSERT_TRUE(b.applies());
  EXPECT_FALSE(b.printed_is_valid);
  const double true_u = 1.0 / (1.0 - 0.95 * 0.95);  // U = A U A + Q at A = 0.95
  EXPECT_LT(b.beta_printed, true_u);
  EXPECT_GE(b.beta, true_u * (1 - 1e-12));
  // At zero error both equal the stationary U of the model: |U_M|_s / 2.
  const LemmaBound b0 = LemmaStateBound(design, 0.0);
  EXPECT_NEAR(b0.beta, 1.0 / 0.75, 1e-12);
  EXPECT_NEAR(b0.beta_printed, 1.0 / 0.75, 1e-12);
  EXPECT_NEAR(b0.kappa, 1.0, 1e-12);
}

// ---- error box ---------------------------------------------------------------------------------

TEST(MismatchErrorBox, NoiseBoxExtremesAreCornersAndMatchBruteForce) {
  TestRng rng(901);
  const ModelStep design = RandomStep(rng, 2, 1, 1, 0.7);
  ErrorRanges ranges;
  ranges.Q = MatrixXd::Constant(1, 1, 0.3 * design.U(0, 0));
  ranges.R = MatrixXd::Constant(1, 1, 0.3 * design.R(0, 0));
  const ErrorBoxSearch s = SearchErrorBox(design, ranges);
  ASSERT_TRUE(s.least_upper.found && s.greatest_lower.found);
  EXPECT_EQ(s.free_entries, 2);
  // tr P is linear in (dQ, dR) for a fixed gain: the maximum sits at a corner.
  MismatchOptions fixed;
  fixed.filter_gain = ComputeDesignTerms(design).filter_gain;
  double best = -1, best_f = 1e300;
  for (double dq : {-1.0, 1.0})
    for (double dr : {-1.0, 1.0}) {
      const ModelStep truth =
          ApplyModelingErrors(design, {Zeros(design.A), Zeros(design.C), dq * ranges.Q, dr * ranges.R});
      best = std::max(best, StationaryMismatchedCovariance(design, truth, fixed).trace);
      best_f = std::min(best_f, SolveFilterDare(truth.A, truth.C, truth.Q, truth.R).P_filt.trace());
    }
  EXPECT_TRUE(s.least_upper.at_corner);
  EXPECT_NEAR(s.least_upper.value, best, 1e-12 * best);
  EXPECT_NEAR(s.greatest_lower.value, best_f, 1e-12 * best_f);
  // The true system reported is the design minus the reported errors.
  EXPECT_MATRICES_NEAR(s.least_upper.truth.R, design.R - s.least_upper.errors.R, 0.0);
}

TEST(MismatchErrorBox, PlantBoxSearchIsAtLeastTheGridExtreme) {
  TestRng rng(902);
  const ModelStep design = RandomStep(rng, 2, 1, 1, 0.6);
  ErrorRanges ranges;
  ranges.A = MatrixXd::Zero(2, 2);
  ranges.A(1, 0) = 0.2;
  const ErrorBoxSearch s = SearchErrorBox(design, ranges);
  MismatchOptions fixed;
  fixed.filter_gain = ComputeDesignTerms(design).filter_gain;
  double grid_max = -1, grid_min = 1e300;
  for (int i = 0; i <= 100; ++i) {
    ModelingErrors e{Zeros(design.A), Zeros(design.C), MatrixXd(), MatrixXd()};
    e.A(1, 0) = -0.2 + 0.004 * i;
    const ModelStep truth = ApplyModelingErrors(design, e);
    const StationaryMismatch m = StationaryMismatchedCovariance(design, truth, fixed);
    if (m.summary.ok()) grid_max = std::max(grid_max, m.trace);
    grid_min = std::min(grid_min, SolveFilterDare(truth.A, truth.C, truth.Q, truth.R).P_filt.trace());
  }
  EXPECT_GE(s.least_upper.value, grid_max * (1 - 1e-12));
  EXPECT_LE(s.greatest_lower.value, grid_min * (1 + 1e-12));
}

// ---- invalid input -----------------------------------------------------------------------------

TEST(MismatchInput, BadInputThrowsNamingTheArgument) {
  TestRng rng(1001);
  const ModelStep design = RandomStep(rng, 2, 1, 0, 0.5);
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] {
        ApplyModelingErrors(design, {MatrixXd::Zero(3, 3), {}, {}, {}});
      },
      "errors.A"));
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] {
        ApplyModelingErrors(design, {{}, {}, {}, MatrixXd::Constant(1, 1, 100.0)});
      },
      "R"));
  MismatchOptions bad_gain;
  bad_gain.filter_gain = MatrixXd::Zero(1, 2);
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { StationaryMismatchedCovariance(design, design, bad_gain); }, "filter_gain"));
  const ModelStep other = RandomStep(rng, 3, 1, 0, 0.5);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { StationaryMismatchedCovariance(design, other); }, "truth"));
  ErrorRanges neg;
  neg.A = -MatrixXd::Ones(2, 2);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ValidateErrorRanges(design, neg); }, "ranges.A"));
  ErrorRanges asym;
  asym.Q = MatrixXd::Zero(2, 2);
  asym.Q(0, 1) = 0.1;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ValidateErrorRanges(design, asym); }, "ranges.Q"));
  ErrorNorms plant;
  plant.A = 0.1;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Theorem3Bound(ComputeDesignTerms(design), plant); }, "norms"));
  ErrorNorms noise;
  noise.Q = 0.1;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Theorem6Bound(design, noise); }, "norms"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { LemmaStateBound(design, -1.0); }, "dA_norm"));
  const Model dm(design, VectorXd::Zero(2), MatrixXd::Identity(2, 2));
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { MismatchedCovarianceSequence(dm, dm, MismatchSequenceOptions{-2}); }, "steps"));
  ErrorBoxSearchOptions so;
  so.step_tolerance = 2.0;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { SearchErrorBox(design, ErrorRanges(), MismatchOptions(), so); },
                                         "step_tolerance"));
}

// One rule for one event: when the design's DARE fails, every computation that needs the design's gain
// reports the DARE's own termination in its Summary ("design filter DARE: ..."), none throws.
TEST(MismatchOutcomes, AFailedDesignDareIsTheSameOutcomeEverywhere) {
  // (A, C) not detectable: the unstable mode 1.2 is not measured.
  MatrixXd A(2, 2), C(1, 2);
  A << 1.2, 0, 0, 0.5;
  C << 0, 1;
  const ModelStep design = MakeStep(A, C, MatrixXd::Identity(2, 2), MatrixXd::Ones(1, 1));
  ModelStep truth = design;
  truth.A(1, 1) = 0.4;
  ErrorRanges ranges;
  ranges.R = 0.1 * MatrixXd::Ones(1, 1);
  const auto expect_design_dare = [](const Summary& s, const char* what) {
    EXPECT_EQ(s.termination, Termination::kNotDetectable) << what << ": " << s.FullReport();
    EXPECT_NE(s.message.find("design filter DARE: (A, C) is not detectable"), std::string::npos)
        << what << ": " << s.message;
  };
  expect_design_dare(StationaryMismatchedCovariance(design, truth).summary, "StationaryMismatchedCovariance");
  expect_design_dare(ComputeDesignTerms(design).summary, "ComputeDesignTerms");
  expect_design_dare(Theorem1Bound(design, ModelingErrorsBetween(design, truth)).summary, "Theorem1Bound");
  const PatelTodaBounds b = ComputePatelTodaBounds(design, ranges);
  expect_design_dare(b.summary, "ComputePatelTodaBounds");
  EXPECT_FALSE(b.pi3 || b.pi4 || b.pi5 || b.pi6);
  expect_design_dare(SearchErrorBox(design, ranges).summary, "SearchErrorBox");
  // Terms that did not compute are not an input to the theorems.
  ErrorNorms noise;
  noise.R = 0.1;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Theorem3Bound(ComputeDesignTerms(design), noise); }, "terms"));
}

// A gain that makes the filter unstable: no stationary error, and no bound, in both shapes.
TEST(MismatchOutcomes, AnUnstableFilterIsReportedNotThrown) {
  const ModelStep design =
      MakeStep(MatrixXd::Constant(1, 1, 0.5), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1));
  MismatchOptions o;
  o.filter_gain = MatrixXd::Constant(1, 1, 5.0);  // (1 - 5) 0.5 = -2
  const StationaryMismatch s = StationaryMismatchedCovariance(design, design, o);
  EXPECT_EQ(s.summary.termination, Termination::kUnstable);
  EXPECT_NE(s.summary.message.find("filter is unstable"), std::string::npos) << s.summary.message;
  EXPECT_NEAR(s.filter_spectral_radius, 2.0, 1e-14);
  const DesignTerms t = ComputeDesignTerms(design, o);
  EXPECT_EQ(t.summary.termination, Termination::kUnstable);
  ModelStep unstable_truth = design;
  unstable_truth.A(0, 0) = 1.1;
  const StationaryMismatch u = StationaryMismatchedCovariance(design, unstable_truth);
  EXPECT_EQ(u.summary.termination, Termination::kUnstable);
  EXPECT_NE(u.summary.message.find("true system is unstable"), std::string::npos) << u.summary.message;
}

// Class 12 of docs/robustness.md: a range of 1e308 is valid. Its Frobenius norm is representable
// (closed form: sqrt(2) * 1e308 for two such entries), so the bounds are computed, never an
// error about an internal name; only a norm above the double range is an error, and it says so.
TEST(MismatchBounds, HugeButRepresentableRangesGiveBounds) {
  const ModelStep design =
      MakeStep(MatrixXd::Constant(1, 1, 0.5), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1));
  ErrorRanges noise;
  noise.Q = MatrixXd::Constant(1, 1, 1e308);
  noise.R = MatrixXd::Constant(1, 1, 1e308);
  const ErrorNorms e = ErrorNormsFromRanges(noise);
  EXPECT_DOUBLE_EQ(e.Q, 1e308);
  EXPECT_DOUBLE_EQ(e.R, 1e308);
  EXPECT_DOUBLE_EQ(ErrorNormsFromRanges({MatrixXd::Constant(1, 2, 1e308), {}, {}, {}}).A, std::sqrt(2.0) * 1e308);
  const PatelTodaBounds b = ComputePatelTodaBounds(design, noise);
  EXPECT_TRUE(b.summary.ok()) << b.summary.message;
  ASSERT_TRUE(b.pi3.has_value());
  EXPECT_FALSE(b.pi5.has_value());
  // A norm beyond the double range (three entries of 1.7e308) is named with what overflowed.
  ErrorNorms over;
  over.Q = ErrorNormsFromRanges({{}, {}, MatrixXd::Constant(1, 3, 1.7e308), {}}).Q;
  EXPECT_TRUE(std::isinf(over.Q));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { Theorem3Bound(b.terms, over); }, "|dQ|_F"));
}

}  // namespace
}  // namespace kfx
