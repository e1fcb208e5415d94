// The exact-performance engine on a true model with a cross-covariance S = E[w_k v_k^T] (issue 22): the
// Kalman filter designed with S has its own covariance as true error; a filter that ignores S against Monte
// Carlo within the interval; the stationary equations (joint and error coordinates) against long horizons;
// a known input (tests/core/performance_input_test.cpp) is asked for, naming g, when not given.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/performance.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// A step whose joint noise covariance [[Q, S], [S^T, R]] is a random positive definite matrix.
ModelStep CorrelatedStep(testing::TestRng& rng, Index n, Index m, double rho) {
  const MatrixXd F = rng.Gaussian(n + m, n + m) / std::sqrt(static_cast<double>(n + m));
  MatrixXd joint = F * F.transpose();
  joint.diagonal().array() += 0.1;
  MatrixXd C = rng.Gaussian(m, n);  // one draw per statement, in GCC's former order of the arguments (TestRng)
  MatrixXd A = rng.WithSpectralRadius(n, rho);
  ModelStep s = MakeStep(std::move(A), std::move(C), joint.topLeftCorner(n, n), joint.bottomRightCorner(m, m));
  s.S = joint.topRightCorner(n, m);
  return s;
}

TEST(ExactPerformanceWithCrossCovariance, KalmanFilterWithSOnItsOwnModelReturnsItsCovariance) {
  testing::TestRng rng(61);
  const Index n = 4, m = 2;
  const int T = 30;
  std::vector<ModelStep> steps;
  for (int k = 0; k < T; ++k) steps.push_back(CorrelatedStep(rng, n, m, 1.05));
  const MatrixXd P0 = rng.Spd(n);
  const VectorXd x0 = rng.Gaussian(n, 1);
  const Model model(steps, x0, P0);
  const KalmanSchedule sch = ComputeKalmanSchedule(model, KalmanScheduleOptions{T});
  const PerformanceResult perf = ExactPerformance(model, KalmanAsLinearFilter(model, sch));
  for (int k = 0; k <= T; ++k) {
    const MatrixXd& P = sch.P_filt[static_cast<size_t>(k)];
    EXPECT_LT(testing::RelativeDifference(perf.error_moment[static_cast<size_t>(k)], P), 1e-10) << "k = " << k;
  }
  EXPECT_LT(perf.bias.cwiseAbs().maxCoeff(), 1e-12);
}

TEST(ExactPerformanceWithCrossCovariance, FilterIgnoringSAgreesWithMonteCarlo) {
  testing::TestRng rng(62);
  const Index n = 3, m = 2;
  const ModelStep truth_step = CorrelatedStep(rng, n, m, 0.95);
  const VectorXd m0 = rng.Gaussian(n, 1);
  const MatrixXd P0 = rng.Spd(n);
  const Model truth(truth_step, m0, P0);
  const Model ignoring(MakeStep(truth_step.A, truth_step.C, truth_step.Q, truth_step.R), m0, P0);
  const int T = 25;
  const LinearFilter f = KalmanAsLinearFilter(ignoring, ComputeKalmanSchedule(ignoring, KalmanScheduleOptions{T}));
  const PerformanceResult exact = ExactPerformance(truth, f, PerformanceOptions{T});
  MonteCarloOptions mo;
  mo.runs = 4000;
  mo.seed = 77;
  const MonteCarloResult mc = MonteCarloPerformance(truth, f, mo);
  int outside = 0;
  for (int k = 0; k <= T; ++k) {
    const double z = std::abs(exact.mse(k) - mc.mse(k)) / mc.mse_std_error(k);
    EXPECT_LT(z, 4.5) << "k = " << k << " exact " << exact.mse(k) << " mc " << mc.mse(k) << " +- "
                      << mc.mse_std_error(k);
    outside += z > 1.96;
  }
  EXPECT_LE(outside, 8);  // about 5% of 26 correlated steps may fall outside the 95% interval
  // Ignoring S costs: worse than the filter that models it (optimal), and its own covariance is not its error.
  const KalmanSchedule optimal = ComputeKalmanSchedule(truth, KalmanScheduleOptions{T});
  EXPECT_GT(exact.mse(T), optimal.P_filt.back().trace() * 1.01);
  const double own = ComputeKalmanSchedule(ignoring, KalmanScheduleOptions{T}).P_filt.back().trace();
  EXPECT_GT(std::abs(exact.mse(T) - own), 0.01 * exact.mse(T));
}

TEST(ExactPerformanceWithCrossCovariance, StationaryEquationsMatchLongHorizons) {
  testing::TestRng rng(63);
  const Index n = 3, m = 2;
  // Joint Lyapunov equation: stable truth, a filter ignoring S with the steady-state gain of its design.
  const ModelStep stable = CorrelatedStep(rng, n, m, 0.9);
  const Model truth(stable, VectorXd::Zero(n), MatrixXd::Identity(n, n));
  const Model ignoring(MakeStep(stable.A, stable.C, stable.Q, stable.R), VectorXd::Zero(n), MatrixXd::Identity(n, n));
  const MatrixXd K = ComputeKalmanSchedule(ignoring, KalmanScheduleOptions{300}).filter_gain.back();
  const LinearFilter f = ConstantGainAsLinearFilter(stable, K, VectorXd::Zero(n));
  const StationaryPerformance st = ExactStationaryPerformance(truth, f);
  ASSERT_TRUE(st.summary.ok()) << st.summary.FullReport();
  EXPECT_EQ(st.method, StationaryMethod::kJoint);
  const PerformanceResult pr = ExactPerformance(truth, f, PerformanceOptions{400});
  EXPECT_LT(testing::RelativeDifference(pr.error_moment.back(), st.error_cov), 1e-10);
  // The same truth factored once (StationaryTruth: the blocks on the Schur forms) for two filters: the one
  // ignoring S, and the steady-state Kalman filter designed with S, whose error is its own converged P_{k|k}.
  const StationaryTruth factored(truth);
  const StationaryPerformance st2 = ExactStationaryPerformance(factored, f);
  EXPECT_LT(testing::RelativeDifference(st2.error_cov, st.error_cov), 1e-12);
  const KalmanSchedule with_s = ComputeKalmanSchedule(truth, KalmanScheduleOptions{400});
  const StationaryPerformance opt = ExactStationaryPerformance(
      factored, ConstantGainAsLinearFilter(stable, with_s.filter_gain.back(), VectorXd::Zero(n)));
  ASSERT_TRUE(opt.summary.ok()) << opt.summary.FullReport();
  EXPECT_EQ(opt.method, StationaryMethod::kJoint);
  EXPECT_LT(testing::RelativeDifference(opt.error_cov, with_s.P_filt.back()), 1e-9);
  EXPECT_LT(opt.mse, st.mse);  // ignoring S costs
  // Error coordinates: unstable truth, the steady-state Kalman filter designed with S (consistent); its error
  // equals the converged P_{k|k} of the schedule with S.
  const ModelStep unstable = CorrelatedStep(rng, n, m, 1.05);
  const Model u_truth(unstable, VectorXd::Zero(n), MatrixXd::Identity(n, n));
  const KalmanSchedule sch = ComputeKalmanSchedule(u_truth, KalmanScheduleOptions{400});
  const LinearFilter kf = ConstantGainAsLinearFilter(unstable, sch.filter_gain.back(), VectorXd::Zero(n));
  const StationaryPerformance su = ExactStationaryPerformance(u_truth, kf);
  ASSERT_TRUE(su.summary.ok()) << su.summary.FullReport();
  EXPECT_EQ(su.method, StationaryMethod::kErrorCoordinates);
  EXPECT_LT(testing::RelativeDifference(su.error_cov, sch.P_filt.back()), 1e-9);
}

TEST(ExactPerformanceWithCrossCovariance, KnownInputWithoutGIsAnErrorNamingG) {
  testing::TestRng rng(64);
  ModelStep s = CorrelatedStep(rng, 2, 1, 0.9);
  s.G = MatrixXd::Ones(2, 1);
  const Model truth(s, VectorXd::Zero(2), MatrixXd::Identity(2, 2));
  const LinearFilter f = ConstantGainAsLinearFilter(s, MatrixXd::Zero(2, 1), VectorXd::Zero(2));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactPerformance(truth, f, PerformanceOptions{5}); }, "g"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ExactStationaryPerformance(truth, f); }, "truth"));
  MonteCarloOptions mo;
  mo.runs = 2;
  mo.steps = 5;
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { MonteCarloPerformance(truth, f, mo); }, "g"));
}

}  // namespace
}  // namespace kfx
