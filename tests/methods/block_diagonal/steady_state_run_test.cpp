// The steady-state block-diagonal filter (RunCoupledFilter with CoupledFilterOptions::steady_state_tolerance):
// against the running filter after convergence, and against the frozen gain applied as a dense matrix
// (x_k = F x + K (y - H F x)) from the step where it froze, on seeded random sizes.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "kfx/block_diagonal.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using testing::TestRng;

MatrixXd PackedSpd(TestRng& rng, Index a, Index n, double shift) {
  MatrixXd m(a, n * a);
  for (Index i = 0; i < n; ++i) m.middleCols(i * a, a) = rng.Spd(a, shift);
  return m;
}

CoupledSystem RandomSystem(TestRng& rng, Index n, Index c, Index d, Index r, double rho = 0.9) {
  CoupledStep s;
  s.F.resize(c, n * c);
  for (Index i = 0; i < n; ++i) s.F.middleCols(i * c, c) = rng.WithSpectralRadius(c, rho);
  s.H = rng.Gaussian(d, n * c);
  s.V = PackedSpd(rng, c, n, 0.05);
  s.R = PackedSpd(rng, d, n, 0.2);
  s.G = rng.Gaussian(n * c, r) * 0.5;
  s.U = rng.Spd(r, 0.1);
  const MatrixXd P0 = PackedSpd(rng, c, n, 0.5);  // one draw per statement, in GCC's former order (TestRng)
  const Eigen::VectorXd x0 = rng.Gaussian(n * c, 1);
  return CoupledSystem(s, x0, P0);
}

CoupledRun RunWithTolerance(const CoupledSystem& sys, const TimeSeries& y, double tol) {
  CoupledFilterOptions o;
  o.steady_state_tolerance = tol;
  return RunCoupledFilter(sys, CoupledFilterKind::kBlockDiagonal, y, o);
}

double MaxRelative(const MatrixXd& a, const MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(b.cwiseAbs().maxCoeff(), 1e-300);
}

TEST(SteadyStateBlockDiagonal, EqualsTheRunningFilterAfterConvergence) {
  std::mt19937_64 gen(2024);
  for (int trial = 0; trial < 8; ++trial) {
    const Index c = 1 + static_cast<Index>(gen() % 3);
    const Index d = 1 + static_cast<Index>(gen() % 2);
    const Index r = 1 + static_cast<Index>(gen() % 6);
    const Index n = 5 + static_cast<Index>(gen() % 200);
    const int T = 250 + static_cast<int>(gen() % 37);  // groups of 8 and a remainder
    SCOPED_TRACE("n = " + std::to_string(n) + ", c = " + std::to_string(c) + ", d = " + std::to_string(d) +
                 ", r = " + std::to_string(r) + ", T = " + std::to_string(T));
    TestRng rng(300 + trial);
    const CoupledSystem sys = RandomSystem(rng, n, c, d, r, 0.6);
    const TimeSeries y = SimulateCoupled(sys, {T, static_cast<std::uint64_t>(trial + 1)}).y;
    const CoupledRun running = RunWithTolerance(sys, y, 0.0), steady = RunWithTolerance(sys, y, 1e-13);
    EXPECT_EQ(running.steady_state_steps, 0);
    ASSERT_GT(steady.steady_state_steps, 0);
    ASSERT_LT(steady.steady_state_steps, T);
    const int frozen_at = T - steady.steady_state_steps;                                     // the last full step
    EXPECT_EQ(steady.x_filt.topRows(frozen_at + 1), running.x_filt.topRows(frozen_at + 1));  // same code until then
    const Index after = T - frozen_at;
    EXPECT_LE(MaxRelative(steady.x_filt.bottomRows(after), running.x_filt.bottomRows(after)), 1e-10);
    EXPECT_LE(MaxRelative(steady.coupling.bottomRows(after), running.coupling.bottomRows(after)), 1e-10);
    EXPECT_LE(std::abs(steady.trace(T) - running.trace(T)), 1e-10 * running.trace(T));
  }
}

// The steady sweeps run over chunks of 512 subsystems (GEMMs per chunk) and the vectorized kernels of
// the running filter over groups of 4: sizes on both sides of a chunk boundary, with every remainder
// modulo 4, for the fixed shapes (c, d) = (2, 1), (1, 1), (2, 2) and a generic one (3, 2).
TEST(SteadyStateBlockDiagonal, EqualsTheRunningFilterAcrossChunkBoundaries) {
  const Index shapes[][3] = {{2, 1, 20}, {1, 1, 3}, {2, 2, 5}, {3, 2, 4}};
  const Index sizes[] = {509, 514, 1027, 1536};
  int trial = 0;
  for (const auto& shape : shapes) {
    for (const Index n : sizes) {
      if (shape[0] != 2 && n > 1100) continue;  // the large size for the paper's shape only
      const Index c = shape[0], d = shape[1], r = shape[2];
      const int T = 90 + trial % 8;
      SCOPED_TRACE("n = " + std::to_string(n) + ", c = " + std::to_string(c) + ", d = " + std::to_string(d) +
                   ", r = " + std::to_string(r) + ", T = " + std::to_string(T));
      TestRng rng(700 + trial);
      const CoupledSystem sys = RandomSystem(rng, n, c, d, r, 0.5);
      const TimeSeries y = SimulateCoupled(sys, {T, static_cast<std::uint64_t>(40 + trial)}).y;
      ++trial;
      const CoupledRun running = RunWithTolerance(sys, y, 0.0), steady = RunWithTolerance(sys, y, 1e-12);
      ASSERT_GT(steady.steady_state_steps, 8);
      const Index after = steady.steady_state_steps;
      EXPECT_LE(MaxRelative(steady.x_filt.bottomRows(after), running.x_filt.bottomRows(after)), 1e-10);
      EXPECT_LE(MaxRelative(steady.coupling.bottomRows(after), running.coupling.bottomRows(after)), 1e-10);
    }
  }
}

TEST(SteadyStateBlockDiagonal, IsTheFrozenGainAppliedAsADenseMatrix) {
  TestRng rng(5);
  const Index n = 12, c = 2, d = 1, r = 3;
  const CoupledSystem sys = RandomSystem(rng, n, c, d, r, 0.6);
  const int T = 200;
  const TimeSeries y = SimulateCoupled(sys, {T, 9}).y;
  const CoupledRun steady =
      RunWithTolerance(sys, y, 1e-9);  // freezes early: the gain then differs from the running one
  const int frozen_at = T - steady.steady_state_steps;
  ASSERT_GT(steady.steady_state_steps, 20);
  // P_{k|k} at the freeze from the running filter, and the dense gain of the next step.
  CoupledFilter filter(CoupledFilterKind::kBlockDiagonal, sys.m0(), sys.P0_blocks());
  for (int k = 1; k <= frozen_at; ++k) filter.Step(*sys.step(k), y.row(k - 1).transpose());
  const CoupledStep& s = *sys.step(1);
  const BlockDiagonalCovarianceStep st = BlockDiagonalCovarianceUpdate(s, filter.P());
  const MatrixXd K = st.gain.ToDense(), F = BlockDiagonalToDense(s.F, c), H = BlockDiagonalToDense(s.H, c);
  VectorXd x = filter.x();
  for (int k = frozen_at + 1; k <= T; ++k) {
    const VectorXd nu = y.row(k - 1).transpose() - H * F * x;
    x = F * x + K * nu;
    EXPECT_LE(MaxRelative(steady.x_filt.row(k).transpose(), x), 1e-12) << "step " << k;
    EXPECT_LE(MaxRelative(steady.coupling.row(k - 1).transpose(), st.gain.CouplingMean(nu)), 1e-11) << "step " << k;
  }
}

TEST(SteadyStateBlockDiagonal, AMissingValueEndsTheFreezeAndTheFilterConvergesAgain) {
  TestRng rng(11);
  const CoupledSystem sys = RandomSystem(rng, 40, 2, 1, 4);
  const int T = 260;
  TimeSeries y = SimulateCoupled(sys, {T, 4}).y;
  y(149, 7) = std::numeric_limits<double>::quiet_NaN();  // y_150
  const CoupledRun running = RunWithTolerance(sys, y, 0.0), steady = RunWithTolerance(sys, y, 1e-13);
  ASSERT_GT(steady.steady_state_steps, 0);
  const CoupledRun once = RunWithTolerance(sys, y.topRows(149), 1e-13);  // the same run up to the missing value
  EXPECT_GT(steady.steady_state_steps, once.steady_state_steps) << "froze again after step 150";
  EXPECT_LT(steady.steady_state_steps, T - (149 - once.steady_state_steps));
  EXPECT_LE(MaxRelative(steady.x_filt.bottomRows(10), running.x_filt.bottomRows(10)), 1e-10);
}

TEST(SteadyStateBlockDiagonal, RejectsAToleranceOutOfRange) {
  TestRng rng(1);
  const CoupledSystem sys = RandomSystem(rng, 3, 2, 1, 1);
  const TimeSeries y = SimulateCoupled(sys, {5, 1}).y;
  for (double bad : {-1e-10, 0.5, std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_TRUE(testing::ThrowsErrorNaming([&] { RunWithTolerance(sys, y, bad); }, "options.steady_state_tolerance"));
  }
}

}  // namespace
}  // namespace kfx
