// The exact-performance engine against independent truth: the Kalman filter's own covariance,
// Monte Carlo with a confidence interval (mismatched filter), the stationary Lyapunov solution
// vs a long horizon, and a closed form for a scalar constant-gain filter.
#include "kfx/performance.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/riccati.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
MatrixXd Scalar(double v) { return MatrixXd::Constant(1, 1, v); }

TEST(ExactPerformance, KalmanFilterOnItsOwnModelReturnsItsCovariance) {
  kfx::testing::TestRng rng(1);
  const Eigen::Index n = 5, m = 2;
  // Time-varying model: A_k, C_k change with k.
  std::vector<ModelStep> steps;
  for (int k = 0; k < 30; ++k) {
    steps.push_back(RandomModelStep(rng, n, m, 1.05));
  }
  const MatrixXd P0 = rng.Spd(n);  // one draw per statement, in GCC's former order of the arguments (TestRng)
  const VectorXd x0 = rng.Gaussian(n, 1);
  Model model(steps, x0, P0);
  const KalmanSchedule sch = ComputeKalmanSchedule(model, KalmanScheduleOptions{30});
  const PerformanceResult perf = ExactPerformance(model, KalmanAsLinearFilter(model, sch));
  ASSERT_EQ(perf.error_moment.size(), 31u);
  for (int k = 0; k <= 30; ++k) {
    const MatrixXd& P = sch.P_filt[static_cast<size_t>(k)];
    EXPECT_LT((perf.error_moment[static_cast<size_t>(k)] - P).norm() / P.norm(), 1e-11) << "k = " << k;
    EXPECT_NEAR(perf.mse(k), P.trace(), 1e-10 * P.trace());
  }
  EXPECT_LT(perf.bias.cwiseAbs().maxCoeff(), 1e-12);  // the Kalman filter is unbiased
}

TEST(ExactPerformance, ScalarConstantGainClosedForm) {
  // x_k = a x_{k-1} + w, y = x + v, filter z_k = (1 - g) a z_{k-1} + g y_k (consistent):
  // e_k = (1 - g) a e_{k-1} + (1 - g) w_k - g v_k  =>  E_inf = ((1-g)^2 q + g^2 r) / (1 - (1-g)^2 a^2).
  const double a = 0.8, q = 0.5, r = 2.0, g = 0.3;
  Model model(MakeStep(Scalar(a), Scalar(1), Scalar(q), Scalar(r)), VectorXd::Zero(1), Scalar(1.0));
  LinearFilter f(LinearFilterStep{Scalar((1 - g) * a), Scalar(g), MatrixXd()}, VectorXd::Zero(1));
  const double e_inf = ((1 - g) * (1 - g) * q + g * g * r) / (1 - (1 - g) * (1 - g) * a * a);
  const StationaryPerformance st = ExactStationaryPerformance(model, f);
  EXPECT_EQ(st.method, StationaryMethod::kJoint);
  EXPECT_NEAR(st.mse, e_inf, 1e-13);
  PerformanceOptions opt;
  opt.steps = 200;
  EXPECT_NEAR(ExactPerformance(model, f, opt).mse(200), e_inf, 1e-12);
  // Recursion by hand for the first steps.
  double e = 1.0;
  const PerformanceResult pr = ExactPerformance(model, f, opt);
  for (int k = 1; k <= 10; ++k) {
    e = (1 - g) * (1 - g) * (a * a * e + q) + g * g * r;
    EXPECT_NEAR(pr.mse(k), e, 1e-14);
  }
}

// A filter designed on a wrong model (wrong A, Q, R), evaluated exactly and by Monte Carlo.
TEST(ExactPerformance, MismatchedFilterAgreesWithMonteCarlo) {
  kfx::testing::TestRng rng(4);
  const Eigen::Index n = 3, m = 2;
  const ModelStep truth_step = RandomModelStep(rng, n, m, 0.97);
  ModelStep design = truth_step;
  design.A *= 0.9;
  design.Q *= 0.2;
  design.R *= 3.0;
  const VectorXd m0 = rng.Gaussian(n, 1);
  Model truth(truth_step, m0, rng.Spd(n));
  Model designed(design, VectorXd::Zero(n), MatrixXd::Identity(n, n));  // wrong prior too (biased)
  const int T = 25;
  const LinearFilter f = KalmanAsLinearFilter(designed, ComputeKalmanSchedule(designed, KalmanScheduleOptions{T}));
  PerformanceOptions po;
  po.weight = rng.Spd(n);
  const PerformanceResult exact = ExactPerformance(truth, f, po);
  MonteCarloOptions mo;
  mo.runs = 4000;
  mo.seed = 2024;
  mo.weight = po.weight;
  const MonteCarloResult mc = MonteCarloPerformance(truth, f, mo);
  int outside = 0;
  for (int k = 0; k <= T; ++k) {
    const double z = std::abs(exact.mse(k) - mc.mse(k)) / mc.mse_std_error(k);
    const double zw = std::abs(exact.weighted_mse(k) - mc.weighted_mse(k)) / mc.weighted_mse_std_error(k);
    EXPECT_LT(z, 4.5) << "k = " << k << " exact " << exact.mse(k) << " mc " << mc.mse(k) << " +- "
                      << mc.mse_std_error(k);
    EXPECT_LT(zw, 4.5) << "k = " << k;
    outside += z > 1.96;
  }
  // About 5% of 26 steps may fall outside the 95% interval (they are correlated in k); many more would be a bug.
  EXPECT_LE(outside, 8);
  // The designed filter's own covariance is not its true error (the engine is needed at all).
  EXPECT_GT(std::abs(exact.mse(T) - ComputeKalmanSchedule(designed, KalmanScheduleOptions{T}).P_filt.back().trace()),
            0.05 * exact.mse(T));
  // The mismatched filter is worse than the Kalman filter on the true model.
  EXPECT_GT(exact.mse(T), ComputeKalmanSchedule(truth, KalmanScheduleOptions{T}).P_filt.back().trace());
}

TEST(ExactPerformance, StationaryJointMatchesLongHorizonAndReducedOutputMap) {
  kfx::testing::TestRng rng(8);
  const Eigen::Index n = 4, m = 2, nz = 2;
  Model truth(RandomModelStep(rng, n, m, 0.9), VectorXd::Zero(n), MatrixXd::Identity(n, n));
  // A reduced-order filter: z in R^2, estimate O z (a fixed arbitrary stable filter). Braces evaluate
  // in order: Phi, then K, then O.
  LinearFilterStep fs;
  fs.Phi = 0.5 * rng.WithSpectralRadius(nz, 1.0);
  fs.K = rng.Gaussian(nz, m);
  fs.O = rng.Gaussian(n, nz);
  LinearFilter f(fs, VectorXd::Zero(nz));
  const StationaryPerformance st = ExactStationaryPerformance(truth, f);
  ASSERT_EQ(st.method, StationaryMethod::kJoint);
  PerformanceOptions po;
  po.steps = 400;
  const PerformanceResult pr = ExactPerformance(truth, f, po);
  EXPECT_LT(kfx::testing::RelativeDifference(pr.error_moment.back(), st.error_cov), 1e-10);
  ASSERT_TRUE(st.summary.ok()) << st.summary.FullReport();
  EXPECT_LT(st.summary.relative_residual, 1e-12);
}

TEST(ExactPerformance, StationaryErrorCoordinatesForUnstableTruthAndConsistentFilter) {
  // Random walk + constant velocity (unstable truth): the steady-state Kalman filter is consistent,
  // so its error is stationary although the state is not; it equals the DARE's P_filt.
  MatrixXd A(2, 2), C(1, 2);
  A << 1, 1, 0, 1;
  C << 1, 0;
  MatrixXd Q(2, 2);
  Q << 1.0 / 3, 0.5, 0.5, 1.0;
  const ModelStep s = MakeStep(A, C, 0.1 * Q, Scalar(1.0));
  Model truth(s, VectorXd::Zero(2), MatrixXd::Identity(2, 2));
  const DareSolution dare = SolveFilterDare(s.A, s.C, s.Q, s.R);
  ASSERT_TRUE(dare.summary.ok());
  const LinearFilter kf = ConstantGainAsLinearFilter(s, dare.filter_gain, VectorXd::Zero(2));
  const StationaryPerformance st = ExactStationaryPerformance(truth, kf);
  EXPECT_EQ(st.method, StationaryMethod::kErrorCoordinates);
  EXPECT_LT(kfx::testing::RelativeDifference(st.error_cov, dare.P_filt), 1e-10);
  // A filter with a wrong A is not consistent with the unstable truth: no stationary value.
  ModelStep wrong = s;
  wrong.A(0, 1) = 0.9;
  const StationaryPerformance none =
      ExactStationaryPerformance(truth, ConstantGainAsLinearFilter(wrong, dare.filter_gain, VectorXd::Zero(2)));
  EXPECT_EQ(none.summary.termination, Termination::kUnstable);
  EXPECT_FALSE(none.summary.ok());
  EXPECT_NE(none.summary.message.find("not consistent"), std::string::npos) << none.summary.message;
  EXPECT_TRUE(std::isinf(none.mse));
}

TEST(ExactPerformance, InvalidInputsThrow) {
  Model truth(MakeStep(MatrixXd::Identity(2, 2), MatrixXd::Ones(1, 2), MatrixXd::Identity(2, 2), Scalar(1)),
              VectorXd::Zero(2), MatrixXd::Identity(2, 2));
  LinearFilter wrong_m(LinearFilterStep{MatrixXd::Identity(2, 2), MatrixXd::Ones(2, 2), MatrixXd()}, VectorXd::Zero(2));
  PerformanceOptions po;
  po.steps = 3;
  EXPECT_THROW(ExactPerformance(truth, wrong_m, po), Error);
  LinearFilter wrong_out(LinearFilterStep{MatrixXd::Identity(3, 3), MatrixXd::Ones(3, 1), MatrixXd()},
                         VectorXd::Zero(3));
  EXPECT_THROW(ExactPerformance(truth, wrong_out, po), Error);
  LinearFilter ok(LinearFilterStep{MatrixXd::Identity(2, 2), MatrixXd::Ones(2, 1), MatrixXd()}, VectorXd::Zero(2));
  EXPECT_THROW(ExactPerformance(truth, ok), Error);  // no horizon anywhere
  po.weight = -MatrixXd::Identity(2, 2);
  EXPECT_THROW(ExactPerformance(truth, ok, po), Error);
  MonteCarloOptions mo;
  mo.runs = 1;
  mo.steps = 3;
  EXPECT_THROW(MonteCarloPerformance(truth, ok, mo), Error);
  EXPECT_THROW(
      LinearFilter(LinearFilterStep{MatrixXd::Identity(2, 2), MatrixXd::Ones(3, 1), MatrixXd()}, VectorXd::Zero(2)),
      Error);
  EXPECT_THROW(
      LinearFilter(LinearFilterStep{MatrixXd::Identity(2, 2), MatrixXd::Ones(2, 1), MatrixXd()}, VectorXd::Zero(3)),
      Error);
}

TEST(RunLinearFilter, KalmanAsLinearFilterReproducesTheOnlineFilter) {
  kfx::testing::TestRng rng(31);
  const Eigen::Index n = 3, m = 2;
  const MatrixXd P0 = rng.Spd(n);  // one draw per statement, in GCC's former order of the arguments (TestRng)
  const VectorXd x0 = rng.Gaussian(n, 1);
  Model model(RandomModelStep(rng, n, m, 1.0), x0, P0);
  TimeSeries y(12, m);
  for (int k = 0; k < 12; ++k) y.row(k) = rng.Gaussian(1, m);
  const TimeSeries est =
      RunLinearFilter(KalmanAsLinearFilter(model, ComputeKalmanSchedule(model, KalmanScheduleOptions{12})), y);
  const FilterRun run = RunFilter(model, y);
  EXPECT_MATRICES_NEAR(MatrixXd(est), MatrixXd(run.x_filt), 1e-12);
}

}  // namespace
}  // namespace kfx
