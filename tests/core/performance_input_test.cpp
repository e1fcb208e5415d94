// The exact-performance engine on a true model driven by a known input g (issue 22): a Kalman filter that
// models the input (Gamma = (I - K C) G - K D) has a zero-mean error and the MSE of the model without input;
// a filter that ignores the input or mis-models G has the closed-form bias of a driven scalar system; both
// against Monte Carlo within the interval, with S and the input together; every invalid input throws naming
// the argument.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/performance.hpp"
#include "kfx/simulation.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// The step without its known input (G, D) and, with keep_s = false, without S.
ModelStep WithoutInput(const ModelStep& s, bool keep_s = true) {
  ModelStep out = MakeStep(s.A, s.C, s.Q, s.R);
  if (keep_s) out.S = s.S;
  return out;
}

TimeSeries RandomInput(testing::TestRng& rng, int T, Index q) {
  const MatrixXd g = rng.Gaussian(T, q);
  return 3.0 * g;  // large enough that a filter ignoring it is far from optimal
}

// Engine against Monte Carlo: the MSE within 4.5 standard errors at every step (at most `outside` of the
// steps outside the 95% interval), and the mean error within 4.5 of its standard errors sqrt(var / runs).
void ExpectAgreesWithMonteCarlo(const PerformanceResult& exact, const MonteCarloResult& mc, int outside_max) {
  const Index T = exact.mse.size() - 1;
  int outside = 0;
  for (Index k = 0; k <= T; ++k) {
    const double z = std::abs(exact.mse(k) - mc.mse(k)) / mc.mse_std_error(k);
    EXPECT_LT(z, 4.5) << "k = " << k << " exact " << exact.mse(k) << " mc " << mc.mse(k) << " +- "
                      << mc.mse_std_error(k);
    outside += z > 1.96;
    for (Index i = 0; i < exact.bias.cols(); ++i) {
      const double b = exact.bias(k, i);
      const double var = exact.error_moment[static_cast<size_t>(k)](i, i) - b * b;
      const double se = std::sqrt(std::max(var, 0.0) / mc.runs);
      EXPECT_LE(std::abs(mc.bias(k, i) - b), 4.5 * se + 1e-12) << "k = " << k << " i = " << i;
    }
  }
  EXPECT_LE(outside, outside_max);
}

TEST(ExactPerformanceWithKnownInput, KalmanFilterModellingTheInputHasZeroMeanErrorAndTheMseWithoutInput) {
  testing::TestRng rng(71);
  const Index n = 3, m = 2, q = 2;
  const int T = 25;
  std::vector<ModelStep> steps, plain;
  for (int k = 0; k < T; ++k) {
    const MatrixXd A = rng.WithSpectralRadius(n, 1.02);
    const MatrixXd C = rng.Gaussian(m, n);
    const MatrixXd Q = rng.Spd(n);
    const MatrixXd R = rng.Spd(m);
    ModelStep s = MakeStep(A, C, Q, R);
    s.G = rng.Gaussian(n, q);
    s.D = rng.Gaussian(m, q);
    plain.push_back(WithoutInput(s));
    steps.push_back(std::move(s));
  }
  const VectorXd m0 = rng.Gaussian(n, 1);
  const MatrixXd P0 = rng.Spd(n);
  const Model model(steps, m0, P0), no_input(plain, m0, P0);
  const TimeSeries g = RandomInput(rng, T, q);
  const KalmanSchedule sch = ComputeKalmanSchedule(model, KalmanScheduleOptions{T});
  const LinearFilter kf = KalmanAsLinearFilter(model, sch);
  ASSERT_EQ(kf.input_dim(), q);
  // The LinearFilter form is the filter kfx runs: RunLinearFilter with g equals RunFilter with g.
  const Trajectory tr = Simulate(model, g, SimulationOptions{T, 5});
  const TimeSeries online = RunLinearFilter(kf, tr.y, g);
  EXPECT_LT(testing::RelativeDifference(online, RunFilter(model, tr.y, g).x_filt), 1e-10);

  const PerformanceResult exact = ExactPerformance(model, kf, g);
  const PerformanceResult without = ExactPerformance(no_input, KalmanAsLinearFilter(no_input, sch));
  EXPECT_LT(exact.bias.cwiseAbs().maxCoeff(), 1e-11);
  for (int k = 0; k <= T; ++k) {
    EXPECT_LE(std::abs(exact.mse(k) - without.mse(k)), 1e-12 * without.mse(k)) << "k = " << k;
    EXPECT_LT(
        testing::RelativeDifference(exact.error_moment[static_cast<size_t>(k)], sch.P_filt[static_cast<size_t>(k)]),
        1e-10)
        << "k = " << k;
  }
  MonteCarloOptions mo;
  mo.runs = 3000;
  mo.seed = 72;
  ExpectAgreesWithMonteCarlo(exact, MonteCarloPerformance(model, kf, g, mo), 8);
}

// Scalar driven system x_k = a x_{k-1} + G g + w_k, y_k = c x_k + D g + v_k with a constant input g and a
// constant-gain filter z_k = f z_{k-1} + K y_k + Gamma g, f = (1 - K c) a, z_0 = m_0. The error e = x - z obeys
//   e_k = f e_{k-1} + h g + (1 - K c) w_k - K v_k,   h = (1 - K c) G - K D - Gamma,
// so E[e_k] = h g (1 - f^k) / (1 - f), and its variance is that of the same filter on the model without input.
TEST(ExactPerformanceWithKnownInput, FilterIgnoringOrMisModellingTheInputHasTheClosedFormBias) {
  const double a = 0.9, G = 1.5, D = 0.4, c = 1.0, K = 0.6, gamma = 1.3;
  const int T = 40;
  ModelStep truth_step = MakeStep(MatrixXd::Constant(1, 1, a), MatrixXd::Constant(1, 1, c),
                                  MatrixXd::Constant(1, 1, 0.3), MatrixXd::Constant(1, 1, 0.5));
  const Model no_input(truth_step, VectorXd::Constant(1, 2.0), MatrixXd::Constant(1, 1, 1.0));
  truth_step.G = MatrixXd::Constant(1, 1, G);
  truth_step.D = MatrixXd::Constant(1, 1, D);
  const Model truth(truth_step, VectorXd::Constant(1, 2.0), MatrixXd::Constant(1, 1, 1.0));
  const TimeSeries g = TimeSeries::Constant(T, 1, gamma);
  const double f = (1 - K * c) * a;

  ModelStep wrong_g = truth_step;  // the design's G is half the truth's
  wrong_g.G *= 0.5;
  const LinearFilter ignoring =
      ConstantGainAsLinearFilter(WithoutInput(truth_step), MatrixXd::Constant(1, 1, K), truth.m0());
  const LinearFilter mis = ConstantGainAsLinearFilter(wrong_g, MatrixXd::Constant(1, 1, K), truth.m0());
  const LinearFilter exact_model = ConstantGainAsLinearFilter(truth_step, MatrixXd::Constant(1, 1, K), truth.m0());
  ASSERT_EQ(ignoring.input_dim(), 0);
  const double h_ignoring = (1 - K * c) * G - K * D;  // 0.36
  const double h_mis = (1 - K * c) * (G - 0.5 * G);   // 0.3
  const PerformanceResult variance = ExactPerformance(no_input, ignoring, PerformanceOptions{T});
  const struct {
    const LinearFilter& filter;
    double h;
  } cases[] = {{ignoring, h_ignoring}, {mis, h_mis}, {exact_model, 0.0}};
  for (const auto& cs : cases) {
    const PerformanceResult r = ExactPerformance(truth, cs.filter, g, PerformanceOptions{T});
    for (int k = 0; k <= T; ++k) {
      const double b = cs.h * gamma * (1 - std::pow(f, k)) / (1 - f);
      EXPECT_NEAR(r.bias(k, 0), b, 1e-13 * (1 + std::abs(b))) << "h = " << cs.h << ", k = " << k;
      EXPECT_NEAR(r.mse(k), variance.mse(k) + b * b, 1e-13 * (variance.mse(k) + b * b)) << "k = " << k;
    }
  }
  // The bias dominates the ignoring filter's error at the end: far above the filter that models the input.
  const PerformanceResult r = ExactPerformance(truth, ignoring, g, PerformanceOptions{T});
  EXPECT_GT(r.mse(T), 2.0 * variance.mse(T));
  MonteCarloOptions mo;
  mo.runs = 4000;
  mo.seed = 73;
  mo.steps = T;
  ExpectAgreesWithMonteCarlo(r, MonteCarloPerformance(truth, ignoring, g, mo), 10);
}

// A step whose joint noise covariance [[Q, S], [S^T, R]] is a random positive definite matrix, with G and D.
ModelStep CorrelatedDrivenStep(testing::TestRng& rng, Index n, Index m, Index q) {
  const MatrixXd F = rng.Gaussian(n + m, n + m) / std::sqrt(static_cast<double>(n + m));
  MatrixXd joint = F * F.transpose();
  joint.diagonal().array() += 0.1;
  const MatrixXd A = rng.WithSpectralRadius(n, 0.95);
  const MatrixXd C = rng.Gaussian(m, n);
  ModelStep s = MakeStep(A, C, joint.topLeftCorner(n, n), joint.bottomRightCorner(m, m));
  s.S = joint.topRightCorner(n, m);
  s.G = rng.Gaussian(n, q);
  s.D = rng.Gaussian(m, q);
  return s;
}

TEST(ExactPerformanceWithKnownInput, CrossCovarianceAndInputTogether) {
  testing::TestRng rng(74);
  const Index n = 3, m = 2, q = 1;
  const int T = 25;
  const ModelStep s = CorrelatedDrivenStep(rng, n, m, q);
  const VectorXd m0 = rng.Gaussian(n, 1);
  const MatrixXd P0 = rng.Spd(n);
  const Model truth(s, m0, P0);
  const TimeSeries g = RandomInput(rng, T, q);
  // The Kalman filter with S and the input on its own model: its covariance is its true error, its mean 0.
  const KalmanSchedule sch = ComputeKalmanSchedule(truth, KalmanScheduleOptions{T});
  const PerformanceResult own = ExactPerformance(truth, KalmanAsLinearFilter(truth, sch), g);
  EXPECT_LT(own.bias.cwiseAbs().maxCoeff(), 1e-11);
  for (int k = 0; k <= T; ++k) {
    EXPECT_LT(testing::RelativeDifference(own.error_moment[static_cast<size_t>(k)], sch.P_filt[static_cast<size_t>(k)]),
              1e-10)
        << "k = " << k;
  }
  // A filter that ignores both S and the input: biased, and the engine agrees with Monte Carlo.
  const Model design(WithoutInput(s, false), m0, P0);
  const LinearFilter ignoring = KalmanAsLinearFilter(design, ComputeKalmanSchedule(design, KalmanScheduleOptions{T}));
  const PerformanceResult exact = ExactPerformance(truth, ignoring, g, PerformanceOptions{T});
  EXPECT_GT(exact.bias.cwiseAbs().maxCoeff(), 0.1);
  MonteCarloOptions mo;
  mo.runs = 4000;
  mo.seed = 75;
  mo.steps = T;
  ExpectAgreesWithMonteCarlo(exact, MonteCarloPerformance(truth, ignoring, g, mo), 8);
}

// --- every validation path throws naming the argument (one test per class) ---

struct Driven {
  Model truth;
  LinearFilter kf;
};
Driven DrivenScalar() {
  ModelStep s =
      MakeStep(MatrixXd::Constant(1, 1, 0.9), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1));
  s.G = MatrixXd::Ones(1, 2);
  const Model truth(s, VectorXd::Zero(1), MatrixXd::Ones(1, 1));
  return {truth, ConstantGainAsLinearFilter(s, MatrixXd::Constant(1, 1, 0.5), VectorXd::Zero(1))};
}

TEST(ExactPerformanceWithKnownInput, MissingInputIsAnErrorNamingG) {
  const Driven d = DrivenScalar();
  MonteCarloOptions mo;
  mo.runs = 2;
  mo.steps = 5;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactPerformance(d.truth, d.kf, PerformanceOptions{5}); }, "g"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { MonteCarloPerformance(d.truth, d.kf, mo); }, "g"));
}

TEST(ExactPerformanceWithKnownInput, InputOfTheWrongWidthIsAnErrorNamingG) {
  const Driven d = DrivenScalar();
  const TimeSeries g = TimeSeries::Ones(5, 3);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactPerformance(d.truth, d.kf, g, PerformanceOptions{5}); }, "g"));
}

TEST(ExactPerformanceWithKnownInput, InputShorterThanTheHorizonIsAnErrorNamingG) {
  const Driven d = DrivenScalar();
  const TimeSeries g = TimeSeries::Ones(4, 2);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactPerformance(d.truth, d.kf, g, PerformanceOptions{5}); }, "g"));
  MonteCarloOptions mo;
  mo.runs = 2;
  mo.steps = 5;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { MonteCarloPerformance(d.truth, d.kf, g, mo); }, "g"));
}

TEST(ExactPerformanceWithKnownInput, NonFiniteInputIsAnErrorNamingG) {
  const Driven d = DrivenScalar();
  TimeSeries g = TimeSeries::Ones(5, 2);
  g(3, 1) = std::nan("");
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactPerformance(d.truth, d.kf, g, PerformanceOptions{5}); }, "g"));
}

TEST(ExactPerformanceWithKnownInput, InputForATruthWithoutOneIsAnErrorNamingG) {
  const Model plain(
      MakeStep(MatrixXd::Constant(1, 1, 0.9), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1), MatrixXd::Ones(1, 1)),
      VectorXd::Zero(1), MatrixXd::Ones(1, 1));
  const LinearFilter f = ConstantGainAsLinearFilter(*plain.step(1), MatrixXd::Constant(1, 1, 0.5), VectorXd::Zero(1));
  const TimeSeries g = TimeSeries::Ones(5, 2);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactPerformance(plain, f, g, PerformanceOptions{5}); }, "g"));
}

TEST(ExactPerformanceWithKnownInput, FilterWhoseGammaTakesAnotherInputIsAnErrorNamingFilter) {
  const Driven d = DrivenScalar();
  LinearFilterStep step = *d.kf.step(1);
  step.Gamma = MatrixXd::Ones(1, 3);  // the truth's q is 2
  const LinearFilter f(step, VectorXd::Zero(1));
  const TimeSeries g = TimeSeries::Ones(5, 2);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactPerformance(d.truth, f, g, PerformanceOptions{5}); }, "filter"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactStationaryPerformance(d.truth, f); }, "filter"));
}

TEST(ExactPerformanceWithKnownInput, StationaryEngineRefusesAKnownInputNamingTruth) {
  const Driven d = DrivenScalar();
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactStationaryPerformance(d.truth, d.kf); }, "truth", {"input"}));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactStationaryPerformance(StationaryTruth(d.truth), d.kf); }, "truth"));
}

TEST(LinearFilterGamma, GammaOfTheWrongShapeIsAnErrorNamingGamma) {
  LinearFilterStep step{MatrixXd::Identity(2, 2), MatrixXd::Ones(2, 1), MatrixXd(), MatrixXd::Ones(3, 1)};
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { LinearFilter(step, VectorXd::Zero(2)); }, "Gamma"));
}

TEST(LinearFilterGamma, NonFiniteGammaIsAnErrorNamingGamma) {
  LinearFilterStep step{MatrixXd::Identity(2, 2), MatrixXd::Ones(2, 1), MatrixXd(), MatrixXd::Ones(2, 1)};
  step.Gamma(1, 0) = std::nan("");
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { LinearFilter(step, VectorXd::Zero(2)); }, "Gamma"));
}

TEST(LinearFilterGamma, GammaOfAnotherWidthAtALaterStepIsAnErrorNamingTheStepsGamma) {
  LinearFilterStep first{MatrixXd::Identity(2, 2), MatrixXd::Ones(2, 1), MatrixXd(), MatrixXd::Ones(2, 1)};
  LinearFilterStep second = first;
  second.Gamma = MatrixXd::Ones(2, 2);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { LinearFilter({first, second}, VectorXd::Zero(2)); }, "step 2: Gamma"));
  LinearFilterStep none = first;
  none.Gamma = MatrixXd();
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { LinearFilter({none, first}, VectorXd::Zero(2)); }, "step 2: Gamma"));
}

TEST(LinearFilterGamma, NegativeInputLengthOfACallbackFilterIsAnErrorNamingQ) {
  const auto step = [](int) { return LinearFilterStep{MatrixXd::Identity(1, 1), MatrixXd::Ones(1, 1)}; };
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { LinearFilter(1, 1, 1, step, VectorXd::Zero(1), MatrixXd(), 3, -1); }, "q"));
}

TEST(LinearFilterGamma, RunWithoutOrWithAMisfitInputIsAnErrorNamingG) {
  const Driven d = DrivenScalar();
  const TimeSeries y = TimeSeries::Ones(5, 1);
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { RunLinearFilter(d.kf, y); }, "g"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { RunLinearFilter(d.kf, y, TimeSeries::Ones(5, 1)); }, "g"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { RunLinearFilter(d.kf, y, TimeSeries::Ones(4, 2)); }, "g"));
  TimeSeries bad = TimeSeries::Ones(5, 2);
  bad(2, 0) = std::nan("");
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { RunLinearFilter(d.kf, y, bad); }, "g"));
}

TEST(LinearFilterGamma, CallbackFilterAddsGammaG) {
  // z_k = 0.5 z_{k-1} + y_k + 2 g_k by a callback with q = 1, against the recursion by hand.
  const auto step = [](int) {
    return LinearFilterStep{MatrixXd::Constant(1, 1, 0.5), MatrixXd::Ones(1, 1), MatrixXd(),
                            MatrixXd::Constant(1, 1, 2)};
  };
  const LinearFilter f(1, 1, 1, step, VectorXd::Constant(1, 1.0), MatrixXd(), 3, 1);
  TimeSeries y(3, 1), g(3, 1);
  y << 1, 2, 3;
  g << -1, 0.5, 4;
  const TimeSeries z = RunLinearFilter(f, y, g);
  double expect = 1.0;
  for (int k = 1; k <= 3; ++k) {
    expect = 0.5 * expect + y(k - 1, 0) + 2 * g(k - 1, 0);
    EXPECT_DOUBLE_EQ(z(k, 0), expect);
  }
}

}  // namespace
}  // namespace kfx
