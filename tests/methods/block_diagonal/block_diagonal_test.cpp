// Block-diagonal filter (004): the O(n r^2) form against the naive dense form, the limits U = 0 and
// n = 1, the full and banded filters against kfx's Kalman filter, the coupling-input posterior
// against dense Gaussian conditioning, true errors against Monte Carlo, the identical-subsystem
// reduction against dense computations, and the Prop. 2.2 bounds.
#include "kfx/block_diagonal.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <string>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/performance.hpp"
#include "kfx/riccati.hpp"
#include "kfx/simulation.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using testing::RelativeDifference;
using testing::TestRng;

MatrixXd PackedSpd(TestRng& rng, Index a, Index n, double shift) {
  MatrixXd m(a, n * a);
  for (Index i = 0; i < n; ++i) m.middleCols(i * a, a) = rng.Spd(a, shift);
  return m;
}

CoupledStep RandomStep(TestRng& rng, Index n, Index c, Index d, Index r) {
  CoupledStep s;
  s.F = rng.Gaussian(c, n * c) * 0.6;
  s.H = rng.Gaussian(d, n * c);
  s.V = PackedSpd(rng, c, n, 0.05);
  s.R = PackedSpd(rng, d, n, 0.2);
  s.G = rng.Gaussian(n * c, r) * 0.7;
  s.U = rng.Spd(r, 0.1);
  return s;
}

struct Dims {
  Index n, c, d, r;
};

class FastVsNaive : public ::testing::TestWithParam<Dims> {};

// 004 eqs. (8)-(17) (with C_2 = C_1, C_3 = -C_1) against eqs. (3)-(7) on time-varying systems.
TEST_P(FastVsNaive, CovarianceGainAndEstimateAgree) {
  const Dims dm = GetParam();
  TestRng rng(100 + dm.n * 7 + dm.c * 3 + dm.d + dm.r * 11);
  MatrixXd P_fast = PackedSpd(rng, dm.c, dm.n, 0.1), P_naive = P_fast;
  VectorXd x_fast = rng.Gaussian(dm.n * dm.c, 1), x_naive = x_fast;
  // The running filter folds K nu into the covariance passes without storing E and Y: a third path.
  CoupledFilter folded(CoupledFilterKind::kBlockDiagonal, x_fast, P_fast);
  for (int k = 1; k <= 6; ++k) {
    const CoupledStep s = RandomStep(rng, dm.n, dm.c, dm.d, dm.r);
    const VectorXd y = rng.Gaussian(dm.n * dm.d, 1);
    const BlockDiagonalCovarianceStep fast = BlockDiagonalCovarianceUpdate(s, P_fast);
    folded.Step(s, y);
    const DenseGainCovarianceStep naive = NaiveBlockDiagonalCovarianceUpdate(s, P_naive);
    EXPECT_LE(RelativeDifference(fast.P_filt, naive.P_filt), 1e-10) << "k = " << k;
    EXPECT_LE(RelativeDifference(fast.gain.ToDense(), naive.K), 1e-10) << "k = " << k;
    const VectorXd nu_f = y - CoupledPredictMeasurement(s, x_fast);
    const VectorXd nu_n = y - CoupledPredictMeasurement(s, x_naive);
    x_fast = CoupledPropagate(s, x_fast) + fast.gain.Apply(nu_f);
    x_naive = CoupledPropagate(s, x_naive) + naive.K * nu_n;
    EXPECT_LE(RelativeDifference(x_fast, x_naive), 1e-10) << "k = " << k;
    EXPECT_LE(RelativeDifference(folded.x(), x_fast), 1e-12) << "k = " << k;
    EXPECT_LE(RelativeDifference(folded.P(), fast.P_filt), 1e-12) << "k = " << k;
    if (dm.r > 0) {
      EXPECT_LE(RelativeDifference(folded.coupling_mean(), fast.gain.CouplingMean(nu_f)), 1e-12) << "k = " << k;
      EXPECT_LE(RelativeDifference(folded.coupling_cov(), fast.gain.C1), 1e-12) << "k = " << k;
    }
    P_fast = fast.P_filt;
    P_naive = naive.P_filt;
  }
}

INSTANTIATE_TEST_SUITE_P(Sizes, FastVsNaive,
                         ::testing::Values(Dims{1, 1, 1, 1}, Dims{1, 2, 3, 4}, Dims{5, 2, 1, 3}, Dims{4, 3, 2, 1},
                                           Dims{7, 4, 2, 2}, Dims{3, 1, 1, 5}, Dims{300, 1, 1, 2}, Dims{260, 2, 1, 20},
                                           Dims{6, 3, 1, 4}, Dims{5, 6, 1, 2}, Dims{2, 9, 9, 3}, Dims{270, 1, 2, 2}));

// The fixed-shape kernels of the O(n r^2) step (c <= 4, d <= 2: Kalman steps, whitening, A = J H - I,
// Gram blocks, congruence) against the generic run-time-size ones, on time-varying systems whose
// shapes hit every dispatch branch and the fallbacks (c = 9: heap-sized blocks), across chunk
// boundaries (n = 300 > 256) and with r = 1, n = 1.
TEST(BlockDiagonalKernels, SpecializedEqualGeneric) {
  const Dims shapes[] = {{37, 1, 1, 3}, {300, 2, 1, 20}, {29, 3, 1, 4}, {23, 4, 1, 2}, {19, 2, 2, 5}, {17, 1, 2, 3},
                         {13, 3, 2, 4}, {11, 5, 1, 3},   {5, 9, 9, 2},  {1, 2, 1, 1},  {40, 2, 1, 1}, {9, 4, 3, 6}};
  for (const Dims& dm : shapes) {
    TestRng rng(500 + dm.n + 13 * dm.c + 7 * dm.d + dm.r);
    std::vector<CoupledStep> steps;
    for (int k = 0; k < 3; ++k) steps.push_back(RandomStep(rng, dm.n, dm.c, dm.d, dm.r));
    std::vector<VectorXd> ys;
    for (int k = 0; k < 3; ++k) ys.push_back(rng.Gaussian(dm.n * dm.d, 1));
    const MatrixXd P0 = PackedSpd(rng, dm.c, dm.n, 0.1);
    const VectorXd x0 = rng.Gaussian(dm.n * dm.c, 1);
    struct Result {
      std::vector<BlockDiagonalCovarianceStep> offline;
      std::vector<VectorXd> x, mu;
      std::vector<MatrixXd> P;
    };
    auto run = [&](bool specialized) {
      detail::SetBlockDiagonalSpecializedKernels(specialized);
      Result out;
      MatrixXd P = P0;
      CoupledFilter filter(CoupledFilterKind::kBlockDiagonal, x0, P0);
      for (int k = 0; k < 3; ++k) {
        out.offline.push_back(BlockDiagonalCovarianceUpdate(steps[k], P));
        P = out.offline.back().P_filt;
        filter.Step(steps[k], ys[k]);
        out.x.push_back(filter.x());
        out.mu.push_back(filter.coupling_mean());
        out.P.push_back(filter.P());
      }
      detail::SetBlockDiagonalSpecializedKernels(true);
      return out;
    };
    const Result fast = run(true), generic = run(false);
    for (int k = 0; k < 3; ++k) {
      SCOPED_TRACE("n c d r = " + std::to_string(dm.n) + " " + std::to_string(dm.c) + " " + std::to_string(dm.d) + " " +
                   std::to_string(dm.r) + ", k = " + std::to_string(k));
      const BlockDiagonalCovarianceStep &a = fast.offline[k], &b = generic.offline[k];
      EXPECT_LE(RelativeDifference(a.P_filt, b.P_filt), 1e-12);
      EXPECT_LE(RelativeDifference(a.gain.J, b.gain.J), 1e-12);
      EXPECT_LE(RelativeDifference(a.gain.Et, b.gain.Et), 1e-12);
      EXPECT_LE(RelativeDifference(a.gain.Yt, b.gain.Yt), 1e-12);
      EXPECT_LE(RelativeDifference(a.gain.C1, b.gain.C1), 1e-12);
      EXPECT_LE(RelativeDifference(fast.x[k], generic.x[k]), 1e-12);
      EXPECT_LE(RelativeDifference(fast.mu[k], generic.mu[k]), 1e-12);
      EXPECT_LE(RelativeDifference(fast.P[k], generic.P[k]), 1e-12);
      EXPECT_GT(a.P_filt.norm(), 0.0);
    }
  }
}

// A singular coupling covariance (rank 3 of 7, and 0): C_1's pivoted factor then has fewer columns
// than r (k < r). The specialized kernels (for c = 2 the AVX2 ones where the CPU has them), the
// generic ones and the naive form (3)-(7) must agree; odd n exercises the kernels' tails.
TEST(BlockDiagonalKernels, RankDeficientCouplingCovariance) {
  for (const Index rank : {Index{3}, Index{0}}) {
    for (const Index n : {Index{1}, Index{2}, Index{19}, Index{261}}) {
      SCOPED_TRACE("rank " + std::to_string(rank) + ", n = " + std::to_string(n));
      TestRng rng(900 + n + rank);
      const Index c = 2, d = 1, r = 7;
      CoupledStep s = RandomStep(rng, n, c, d, r);
      const MatrixXd B = rng.Gaussian(r, rank);
      s.U = B * B.transpose();
      const MatrixXd P0 = PackedSpd(rng, c, n, 0.1);
      detail::SetBlockDiagonalSpecializedKernels(false);
      const BlockDiagonalCovarianceStep generic = BlockDiagonalCovarianceUpdate(s, P0);
      detail::SetBlockDiagonalSpecializedKernels(true);
      const BlockDiagonalCovarianceStep fast = BlockDiagonalCovarianceUpdate(s, P0);
      const DenseGainCovarianceStep naive = NaiveBlockDiagonalCovarianceUpdate(s, P0);
      EXPECT_LE(RelativeDifference(fast.P_filt, generic.P_filt), 1e-12);
      EXPECT_LE(RelativeDifference(fast.P_filt, naive.P_filt), 1e-10);
      EXPECT_LE(RelativeDifference(fast.gain.ToDense(), naive.K), 1e-10);
      EXPECT_LE(RelativeDifference(fast.gain.C1, generic.gain.C1), 1e-12);
    }
  }
}

// The filter class over a time-varying system gives the same estimates as the naive kind.
TEST(CoupledFilter, FastAndNaiveKindsAgreeOverARun) {
  TestRng rng(7);
  const Index n = 6, c = 2, d = 1, r = 2;
  std::vector<CoupledStep> steps;
  for (int k = 0; k < 8; ++k) steps.push_back(RandomStep(rng, n, c, d, r));
  const MatrixXd P0 = PackedSpd(rng, c, n, 0.2);  // one draw per statement, in GCC's former order (TestRng)
  const VectorXd x0 = rng.Gaussian(n * c, 1);
  const CoupledSystem sys(steps, x0, P0);
  const CoupledTrajectory tr = SimulateCoupled(sys, {-1, 3});
  const CoupledRun fast = RunCoupledFilter(sys, CoupledFilterKind::kBlockDiagonal, tr.y);
  const CoupledRun naive = RunCoupledFilter(sys, CoupledFilterKind::kBlockDiagonalNaive, tr.y);
  EXPECT_LE(RelativeDifference(fast.x_filt, naive.x_filt), 1e-10);
  EXPECT_LE(RelativeDifference(fast.coupling, naive.coupling), 1e-10);
  EXPECT_LE(RelativeDifference(fast.trace, naive.trace), 1e-10);
}

// With U = 0 the subsystems are independent: all three filters are the per-block Kalman filters.
TEST(CoupledFilter, WithoutCouplingAllKindsArePerBlockKalmanFilters) {
  TestRng rng(11);
  const Index n = 4, c = 2, d = 2, r = 3;
  CoupledStep s = RandomStep(rng, n, c, d, r);
  s.U.setZero();
  const MatrixXd P0 = PackedSpd(rng, c, n, 0.3);
  const VectorXd x0 = rng.Gaussian(n * c, 1);
  CoupledFilter block(CoupledFilterKind::kBlockDiagonal, x0, P0), banded(CoupledFilterKind::kBanded, x0, P0),
      full(CoupledFilterKind::kFull, x0, P0);
  std::vector<Estimate> per_block;
  for (Index i = 0; i < n; ++i) per_block.push_back({x0.segment(i * c, c), P0.middleCols(i * c, c)});
  for (int k = 1; k <= 5; ++k) {
    const VectorXd y = rng.Gaussian(n * d, 1);
    block.Step(s, y);
    banded.Step(s, y);
    full.Step(s, y);
    for (Index i = 0; i < n; ++i) {
      const ModelStep bs = MakeStep(s.F.middleCols(i * c, c), s.H.middleCols(i * c, c), s.V.middleCols(i * c, c),
                                    s.R.middleCols(i * d, d));
      per_block[i] = Update(Predict(per_block[i], bs), bs, y.segment(i * d, d)).estimate;
      EXPECT_MATRICES_NEAR(block.x().segment(i * c, c), per_block[i].x, 1e-12);
      EXPECT_MATRICES_NEAR(banded.x().segment(i * c, c), per_block[i].x, 1e-12);
      EXPECT_MATRICES_NEAR(full.x().segment(i * c, c), per_block[i].x, 1e-12);
      EXPECT_MATRICES_NEAR(block.P().middleCols(i * c, c), per_block[i].P, 1e-12);
      EXPECT_MATRICES_NEAR(banded.P().middleCols(i * c, c), per_block[i].P, 1e-12);
      EXPECT_MATRICES_NEAR(full.P().block(i * c, i * c, c, c), per_block[i].P, 1e-12);
    }
    EXPECT_MATRICES_NEAR(block.coupling_cov(), MatrixXd::Zero(r, r), 0.0);
  }
}

// n = 1: D{.} is the identity, so the block-diagonal filter is the Kalman filter; so is the
// structured full filter for any n. Reference: kfx::Predict/Update on the dense stacked model.
TEST(CoupledFilter, SingleSubsystemBlockDiagonalAndFullEqualKalmanFilter) {
  for (const Index n : {Index{1}, Index{5}}) {
    TestRng rng(20 + n);
    const Index c = 3, d = 2, r = 2;
    const MatrixXd P0 = PackedSpd(rng, c, n, 0.3);
    const VectorXd x0 = rng.Gaussian(n * c, 1);
    CoupledFilter block(CoupledFilterKind::kBlockDiagonal, x0, P0), full(CoupledFilterKind::kFull, x0, P0);
    Estimate kf{x0, BlockDiagonalToDense(P0, c)};
    for (int k = 1; k <= 5; ++k) {
      const CoupledStep s = RandomStep(rng, n, c, d, r);
      const VectorXd y = rng.Gaussian(n * d, 1);
      const ModelStep dense = ToDenseStep(s);
      kf = Update(Predict(kf, dense), dense, y).estimate;
      full.Step(s, y);
      EXPECT_LE(RelativeDifference(full.x(), kf.x), 1e-11);
      EXPECT_LE(RelativeDifference(full.P(), kf.P), 1e-11);
      if (n == 1) {
        block.Step(s, y);
        EXPECT_LE(RelativeDifference(block.x(), kf.x), 1e-11);
        EXPECT_LE(RelativeDifference(block.P(), kf.P), 1e-11);
      }
    }
  }
}

// Issue 20, class 14: NaN measurements are missing (before: rejected). Reference: kfx's Kalman filter on the
// dense stacked model, which leaves NaN rows out of its update; the full filter for any n and the
// block-diagonal filter at n = 1 are that filter, the banded one is it on the projected noise, and the fast
// block-diagonal form equals the naive one with the same entries missing. The missing entries cover one
// component of a subsystem (R correlated with the other), a whole subsystem, and a whole step.
TEST(CoupledFilter, MissingMeasurementsAreSkippedAsTheKalmanFilterSkipsThem) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const Index n : {Index{1}, Index{5}}) {
    TestRng rng(40 + n);
    const Index c = 3, d = 2, r = 2;
    const MatrixXd P0 = PackedSpd(rng, c, n, 0.3);
    const VectorXd x0 = rng.Gaussian(n * c, 1);
    CoupledFilter block(CoupledFilterKind::kBlockDiagonal, x0, P0), full(CoupledFilterKind::kFull, x0, P0),
        naive(CoupledFilterKind::kBlockDiagonalNaive, x0, P0), banded(CoupledFilterKind::kBanded, x0, P0);
    Estimate kf{x0, BlockDiagonalToDense(P0, c)}, kf_banded = kf;
    for (int k = 1; k <= 6; ++k) {
      const CoupledStep s = RandomStep(rng, n, c, d, r);
      VectorXd y = rng.Gaussian(n * d, 1);
      if (k == 2) y(0) = nan;                                  // one of subsystem 0's two components
      if (k == 3) y.segment((n - 1) * d, d).setConstant(nan);  // all of the last subsystem
      if (k == 4) y.setConstant(nan);                          // the whole step: a pure prediction
      if (k == 5 && n > 1) y(3) = nan;                         // subsystem 1's second component
      const ModelStep dense = ToDenseStep(s);
      kf = Update(Predict(kf, dense), dense, y).estimate;
      ModelStep projected = dense;
      projected.Q = BlockDiagonalToDense(DiagonalBlocks(dense.Q, c), c);
      kf_banded = Update(Predict(kf_banded, projected), projected, y).estimate;
      full.Step(s, y);
      naive.Step(s, y);
      block.Step(s, y);
      banded.Step(s, y);
      EXPECT_LE(RelativeDifference(full.x(), kf.x), 1e-11) << "n " << n << " step " << k;
      EXPECT_LE(RelativeDifference(full.P(), kf.P), 1e-11) << "n " << n << " step " << k;
      EXPECT_LE(RelativeDifference(banded.x(), kf_banded.x), 1e-11) << "n " << n << " step " << k;
      EXPECT_LE(RelativeDifference(BlockDiagonalToDense(banded.P(), c), kf_banded.P), 1e-11);
      EXPECT_LE(RelativeDifference(block.x(), naive.x()), 1e-10) << "n " << n << " step " << k;
      EXPECT_LE(RelativeDifference(block.P(), naive.P()), 1e-10) << "n " << n << " step " << k;
      EXPECT_TRUE(block.x().allFinite() && block.P().allFinite());
      if (n == 1) {
        EXPECT_LE(RelativeDifference(block.x(), kf.x), 1e-11) << "step " << k;
        EXPECT_LE(RelativeDifference(block.P(), kf.P), 1e-11) << "step " << k;
      }
    }
  }
  // An infinite measurement is not a missing one.
  TestRng rng(3);
  const CoupledStep s = RandomStep(rng, 2, 2, 1, 1);
  CoupledFilter f(CoupledFilterKind::kBlockDiagonal, VectorXd::Zero(4), PackedSpd(rng, 2, 2, 0.3));
  EXPECT_TRUE(testing::ThrowsErrorNaming(
      [&] { f.Step(s, (VectorXd(2) << 1.0, std::numeric_limits<double>::infinity()).finished()); }, "y", {"inf"}));
}

// The banded filter is the Kalman filter of the model whose process noise is D{V + G U G^T}.
TEST(CoupledFilter, BandedIsKalmanFilterOfProjectedNoise) {
  TestRng rng(31);
  const Index n = 3, c = 2, d = 1, r = 2;
  const MatrixXd P0 = PackedSpd(rng, c, n, 0.3);
  const VectorXd x0 = rng.Gaussian(n * c, 1);
  CoupledFilter banded(CoupledFilterKind::kBanded, x0, P0);
  Estimate kf{x0, BlockDiagonalToDense(P0, c)};
  for (int k = 1; k <= 4; ++k) {
    const CoupledStep s = RandomStep(rng, n, c, d, r);
    const VectorXd y = rng.Gaussian(n * d, 1);
    ModelStep dense = ToDenseStep(s);
    dense.Q = BlockDiagonalToDense(DiagonalBlocks(dense.Q, c), c);
    kf = Update(Predict(kf, dense), dense, y).estimate;
    banded.Step(s, y);
    EXPECT_LE(RelativeDifference(banded.x(), kf.x), 1e-12);
    EXPECT_LE(RelativeDifference(BlockDiagonalToDense(banded.P(), c), kf.P), 1e-12);
  }
}

// mu_u, Sigma_u against Gaussian conditioning of (u_k, y_k) given x_{k-1} ~ N(x~, blockdiag P~):
// Sigma_u = U - U G^T H^T S^{-1} H G U, mu_u = U G^T H^T S^{-1} nu, S = H (L + G U G^T) H^T + R.
TEST(CoupledFilter, CouplingPosteriorIsGaussianConditioning) {
  TestRng rng(41);
  const Index n = 5, c = 2, d = 2, r = 3;
  const CoupledStep s = RandomStep(rng, n, c, d, r);
  const MatrixXd P = PackedSpd(rng, c, n, 0.2);
  const VectorXd x = rng.Gaussian(n * c, 1);
  const VectorXd y = rng.Gaussian(n * d, 1);
  const ModelStep dense = ToDenseStep(s);
  const MatrixXd Pp = dense.A * BlockDiagonalToDense(P, c) * dense.A.transpose() + dense.Q;
  const MatrixXd S = dense.C * Pp * dense.C.transpose() + dense.R;
  const MatrixXd UGtHt = s.U * s.G.transpose() * dense.C.transpose();
  const Eigen::LLT<MatrixXd> llt(S);
  const VectorXd nu = y - dense.C * dense.A * x;
  const MatrixXd sigma = s.U - UGtHt * llt.solve(UGtHt.transpose());
  const VectorXd mu = UGtHt * llt.solve(nu);
  const BlockDiagonalCovarianceStep st = BlockDiagonalCovarianceUpdate(s, P);
  EXPECT_LE(RelativeDifference(st.gain.C1, sigma), 1e-12);
  EXPECT_LE(RelativeDifference(st.gain.CouplingMean(nu), mu), 1e-12);
  CoupledFilter f(CoupledFilterKind::kBlockDiagonal, x, P);
  f.Step(s, y);
  EXPECT_LE(RelativeDifference(f.coupling_mean(), mu), 1e-12);
}

// The true error of the block-diagonal and banded filters (which their own covariances are not):
// the exact-performance engine against Monte Carlo of SimulateCoupled + CoupledFilter.
TEST(CoupledFilter, TrueErrorFromEngineMatchesMonteCarlo) {
  TestRng rng(51);
  const Index n = 4, c = 2, d = 1, r = 1;
  std::vector<CoupledStep> steps;
  for (int k = 0; k < 6; ++k) steps.push_back(RandomStep(rng, n, c, d, r));
  for (auto& s : steps) s.U *= 20.0;  // strong coupling: the filters differ clearly
  const CoupledSystem sys(steps, VectorXd::Zero(n * c), PackedSpd(rng, c, n, 0.5));
  const Model truth = ToDenseModel(sys);
  for (const auto kind : {CoupledFilterKind::kBlockDiagonal, CoupledFilterKind::kBanded, CoupledFilterKind::kFull}) {
    const PerformanceResult exact = ExactPerformance(truth, CoupledFilterAsLinearFilter(sys, kind, {-1}));
    const int runs = 3000;
    VectorXd sum = VectorXd::Zero(7), sum2 = VectorXd::Zero(7);
    for (int i = 0; i < runs; ++i) {
      const CoupledTrajectory tr = SimulateCoupled(sys, SimulationOptions{-1, Rng::StreamSeed(9, i)});
      const CoupledRun run = RunCoupledFilter(sys, kind, tr.y);
      for (int k = 0; k <= 6; ++k) {
        const double e = (tr.x.row(k) - run.x_filt.row(k)).squaredNorm();
        sum(k) += e;
        sum2(k) += e * e;
      }
    }
    for (int k = 1; k <= 6; ++k) {
      const double mean = sum(k) / runs, var = sum2(k) / runs - mean * mean;
      const double se = std::sqrt(var / runs);
      EXPECT_NEAR(mean, exact.mse(k), 4.5 * se) << ToString(kind) << " k = " << k;
    }
    // Only the Kalman filter's own covariance is its true error.
    if (kind == CoupledFilterKind::kFull) {
      const CoupledRun run = RunCoupledFilter(sys, kind, SimulateCoupled(sys, {-1, 1}).y);
      EXPECT_NEAR(run.trace(6), exact.mse(6), 1e-10 * exact.mse(6));
    }
  }
}

// ---- Steady state ----------------------------------------------------------------------------------

// The fixed point of eq. (19) (update form): P~ = D{post(F P~ F^T + V + G U G^T)}, the limit of the
// time-varying recursion from any start (Prop. 2.1).
TEST(BlockDiagonalSteadyState, IsTheFixedPointAndTheLimitFromAnyStart) {
  TestRng rng(61);
  const Index n = 5, c = 2, d = 1, r = 2;
  CoupledStep s = RandomStep(rng, n, c, d, r);
  const BlockDiagonalSteadyState ss = SolveBlockDiagonalSteadyState(s);
  ASSERT_TRUE(ss.summary.ok()) << ss.summary.BriefReport();
  const DenseGainCovarianceStep again = NaiveBlockDiagonalCovarianceUpdate(s, ss.P_filt);
  EXPECT_LE(RelativeDifference(again.P_filt, ss.P_filt), 1e-12);
  MatrixXd P = PackedSpd(rng, c, n, 5.0);
  for (int k = 0; k < 400; ++k) P = BlockDiagonalCovarianceUpdate(s, P).P_filt;
  EXPECT_LE(RelativeDifference(P, ss.P_filt), 1e-10);
}

// Class 15 of docs/robustness.md: a tolerance below the iteration's rounding floor ends at the floor
// (converged, the floor in the Summary) instead of running max_iterations; same fixed point.
TEST(BlockDiagonalSteadyState, ToleranceBelowTheRoundingFloorStopsAtTheFloor) {
  TestRng rng(61);
  const CoupledStep s = RandomStep(rng, 5, 2, 1, 2);
  const BlockDiagonalSteadyState reached = SolveBlockDiagonalSteadyState(s);
  ASSERT_TRUE(reached.summary.ok()) << reached.summary.BriefReport();
  EXPECT_EQ(reached.summary.Detail("rounding_floor"), "");
  SteadyStateOptions o;
  o.tolerance = 1e-18;
  const BlockDiagonalSteadyState floor = SolveBlockDiagonalSteadyState(s, o);
  ASSERT_TRUE(floor.summary.ok()) << floor.summary.FullReport();
  EXPECT_LT(floor.summary.iterations, o.max_iterations);
  ASSERT_NE(floor.summary.Detail("rounding_floor"), "") << floor.summary.FullReport();
  EXPECT_GT(std::stod(floor.summary.Detail("rounding_floor")), 1e-18);
  EXPECT_LE(RelativeDifference(floor.P_filt, reached.P_filt), 1e-12);
}

TEST(BlockDiagonalSteadyState, BandedSteadyStateIsPerBlockDare) {
  TestRng rng(62);
  const CoupledStep s = RandomStep(rng, 3, 2, 1, 2);
  const BandedSteadyState b = SolveBandedSteadyState(s);
  const BandedCovarianceStep again = BandedCovarianceUpdate(s, b.P_filt);
  EXPECT_LE(RelativeDifference(again.P_filt, b.P_filt), 1e-12);
  EXPECT_LE(RelativeDifference(again.K, b.K), 1e-12);
}

// ---- Identical subsystems ----------------------------------------------------------------------------

IdenticalSubsystems Section31(double beta) {
  IdenticalSubsystems s;
  s.F.resize(2, 2);
  s.F << 0.9, beta, 0, 0.9;
  s.H.resize(1, 2);
  s.H << 1, 1;
  s.V = MatrixXd::Identity(2, 2);
  s.R = MatrixXd::Identity(1, 1);
  s.g = MatrixXd::Ones(2, 1);
  s.U = MatrixXd::Identity(1, 1);
  return s;
}

class IdenticalReduction : public ::testing::TestWithParam<std::tuple<double, int>> {};

// The exact two-mode reduction against dense computations on the stacked system.
TEST_P(IdenticalReduction, MatchesDenseComputation) {
  const auto [beta, n] = GetParam();
  const IdenticalSubsystems sys = Section31(beta);
  const IdenticalAnalysis a = AnalyzeIdenticalSubsystems(sys, n);
  ASSERT_TRUE(a.block_summary.ok()) << a.block_summary.BriefReport();
  const CoupledStep s = MakeIdenticalCoupledStep(n, sys.F, sys.H, sys.V, sys.R, sys.g, sys.U);
  const ModelStep dense = ToDenseStep(s);
  // Full KF: the dense DARE.
  const DareSolution full = SolveFilterDare(dense.A, dense.C, dense.Q, dense.R);
  ASSERT_TRUE(full.summary.ok()) << full.summary.BriefReport();
  EXPECT_LE(RelativeDifference(a.full_P.Dense(), full.P_filt), 1e-9);
  EXPECT_LE(RelativeDifference(a.full_gain.Dense(), full.filter_gain), 1e-9);
  // Block-diagonal: the general O(n r^2) iteration.
  const BlockDiagonalSteadyState block = SolveBlockDiagonalSteadyState(s);
  ASSERT_TRUE(block.summary.ok());
  EXPECT_LE(RelativeDifference(a.block_P.Dense(), BlockDiagonalToDense(block.P_filt, 2)), 1e-10);
  EXPECT_LE(RelativeDifference(a.block_gain.Dense(), block.gain.ToDense()), 1e-9);
  // Banded: per-block DAREs.
  const BandedSteadyState banded = SolveBandedSteadyState(s);
  EXPECT_LE(RelativeDifference(a.banded_P.Dense(), BlockDiagonalToDense(banded.P_filt, 2)), 1e-10);
  // Distances of Fig. 1 against dense norms.
  EXPECT_NEAR(FrobeniusDistance(a.block_P, a.full_P), (a.block_P.Dense() - full.P_filt).norm(),
              1e-9 * full.P_filt.norm());
  // True error of the block-diagonal filter: the engine on the dense system (moderate n).
  if (n <= 64) {
    const Model truth(dense, VectorXd::Zero(2 * n), MatrixXd::Identity(2 * n, 2 * n));
    const StationaryPerformance perf = ExactStationaryPerformance(
        truth, ConstantGainAsLinearFilter(dense, block.gain.ToDense(), VectorXd::Zero(2 * n)));
    if (a.block_true.X.size() == 0) {
      EXPECT_FALSE(perf.summary.ok());
    } else {
      ASSERT_TRUE(perf.summary.ok()) << perf.summary.message;
      EXPECT_LE(RelativeDifference(a.block_true.Dense(), perf.error_cov), 1e-8);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Section31, IdenticalReduction,
                         ::testing::Combine(::testing::Values(1.0, 4.0), ::testing::Values(1, 2, 16, 64, 256)));

// For 004 Sec. 3.1, (I - g (H g)^{-1} H) F has eigenvalues 0 and 0.9 - beta / 2.
// A subsystem whose DARE has no stabilizing solution (an unmeasured unstable state) makes the analyses
// that need that DARE report the DARE's own termination in their Summary, naming where; none throws.
TEST(BlockDiagonalOutcomes, AFailedSubsystemDareIsReportedInTheSummary) {
  IdenticalSubsystems sys = Section31(0.0);
  sys.F << 1.2, 0, 0, 0.9;  // state 1 unstable and unmeasured by H = [0, 1]
  sys.H << 0, 1;
  const IdenticalAnalysis a = AnalyzeIdenticalSubsystems(sys, 4);
  EXPECT_EQ(a.summary.termination, Termination::kNotDetectable) << a.summary.FullReport();
  EXPECT_NE(a.summary.message.find("DARE of P_+(V)"), std::string::npos) << a.summary.message;
  const CoupledStep s = MakeIdenticalCoupledStep(3, sys.F, sys.H, sys.V, sys.R, sys.g, sys.U);
  const BandedSteadyState banded = SolveBandedSteadyState(s);
  EXPECT_EQ(banded.summary.termination, Termination::kNotDetectable) << banded.summary.FullReport();
  EXPECT_NE(banded.summary.message.find("block 0"), std::string::npos) << banded.summary.message;
  const Proposition22 p = ComputeProposition22(s);
  EXPECT_EQ(p.summary.termination, Termination::kNotDetectable) << p.summary.FullReport();
  // The block-diagonal iteration itself grows without bound (P_11 ~ 1.44^k). Its Frobenius norm overflows
  // near k = 969 while the entries are still finite: that must not read as a relative change of 0
  // (it did: "converged" with P_11 ~ 1e153). The same for the two-mode iteration of identical subsystems.
  SteadyStateOptions o;
  o.max_iterations = 5000;
  const BlockDiagonalSteadyState bd = SolveBlockDiagonalSteadyState(s, o);
  EXPECT_EQ(bd.summary.termination, Termination::kUnstable) << bd.summary.FullReport();
  IdenticalSubsystems unmeasured = sys;
  unmeasured.F(1, 1) = 0.5;
  const IdenticalAnalysis b = AnalyzeIdenticalSubsystems(unmeasured, 4, o);
  EXPECT_FALSE(b.summary.ok());
}

TEST(IdenticalReduction, UnknownInputSpectralRadiusClosedForm) {
  for (const double beta : {0.5, 1.0, 3.7, 3.9, 6.0}) {
    EXPECT_NEAR(UnknownInputSpectralRadius(Section31(beta)), std::abs(0.9 - beta / 2), 1e-12) << beta;
  }
}

// ---- Prop. 2.2 -------------------------------------------------------------------------------------

// The corrected bounds (docs/papers/004.md) must hold; the printed ones are counted, not asserted:
// they fail on such systems, which is what the corrections are for.
TEST(Proposition22, CorrectedBoundsHoldOnRandomWeaklyCoupledSystems) {
  int part1_checked = 0, part2_checked = 0, printed_part1_violations = 0, printed_part2_violations = 0;
  for (int trial = 0; trial < 16; ++trial) {
    TestRng rng(70 + trial);
    const Index n = 3, c = 2, d = 1, r = 1;
    CoupledStep s = RandomStep(rng, n, c, d, r);
    s.U *= 1e-3 * (1 + trial);
    const Proposition22 p = ComputeProposition22(s);
    for (Index i = 0; i < n; ++i) EXPECT_GE(p.lyapunov_norm(i), p.alpha1(i) * (1 - 1e-12));
    // Uncoupled P_+(V), P_-(V); coupled P~_+, P~_- and the full filter's P_-.
    CoupledStep s0 = s;
    s0.U.setZero();
    const BlockDiagonalSteadyState unc = SolveBlockDiagonalSteadyState(s0);
    const BlockDiagonalSteadyState cpl = SolveBlockDiagonalSteadyState(s);
    ASSERT_TRUE(unc.summary.ok() && cpl.summary.ok());
    for (Index i = 0; i < n; ++i) {
      const double actual = (cpl.P_filt.middleCols(i * c, c) - unc.P_filt.middleCols(i * c, c)).norm();
      if (p.part1_applies[i] && actual > p.part1_bound(i)) ++printed_part1_violations;
      if (!p.part1_corrected_applies[i]) continue;
      ++part1_checked;
      EXPECT_LE(actual, p.part1_corrected_bound(i) * (1 + 1e-10)) << "trial " << trial << " block " << i;
    }
    const ModelStep dense = ToDenseStep(s), dense0 = ToDenseStep(s0);
    const DareSolution full = SolveFilterDare(dense.A, dense.C, dense.Q, dense.R);
    const DareSolution full0 = SolveFilterDare(dense0.A, dense0.C, dense0.Q, dense0.R);
    const double d_full = (full.P_pred - full0.P_pred).norm();
    const MatrixXd Pm_block = dense.A * BlockDiagonalToDense(cpl.P_filt, c) * dense.A.transpose() + dense.Q;
    const double d_block = (Pm_block - full0.P_pred).norm();
    if (p.part2_applies && std::max(d_full, d_block) > p.part2_bound) ++printed_part2_violations;
    if (!p.part2_corrected_applies) continue;
    ++part2_checked;
    EXPECT_LE(d_full, p.part2_corrected_bound * (1 + 1e-10)) << "trial " << trial;
    EXPECT_LE(d_block, p.part2_corrected_bound * (1 + 1e-10)) << "trial " << trial;
    const MatrixXd I = MatrixXd::Identity(n * c, n * c);
    const MatrixXd Fc0 = (I - full0.filter_gain * dense.C) * dense.A;
    const MatrixXd Fc_full = (I - full.filter_gain * dense.C) * dense.A;
    EXPECT_LE((Fc_full - Fc0).norm(), p.closed_loop_corrected_bound * (1 + 1e-10)) << "trial " << trial;
  }
  EXPECT_GT(part1_checked, 20);
  EXPECT_GT(part2_checked, 5);
  std::cout << "printed Prop. 2.2 bounds violated: part (1) " << printed_part1_violations << ", part (2) "
            << printed_part2_violations << "\n";
}

// ---- Bad input ---------------------------------------------------------------------------------------

TEST(CoupledSystemValidation, BadInputNamesTheArgument) {
  TestRng rng(90);
  const CoupledStep good = RandomStep(rng, 3, 2, 1, 2);
  const MatrixXd P0 = PackedSpd(rng, 2, 3, 0.1);
  auto expect_error = [&](const CoupledStep& s, const std::string& needle) {
    EXPECT_TRUE(testing::ThrowsErrorNaming([&] { CoupledSystem(s, VectorXd::Zero(6), P0); }, needle));
  };
  CoupledStep s = good;
  s.H = MatrixXd::Zero(1, 5);
  expect_error(s, "H");
  s = good;
  s.R(0, 1) = -1.0;
  expect_error(s, "R (block 1)");
  s = good;
  s.U(0, 1) += 0.5;
  expect_error(s, "U");
  s = good;
  s.G(2, 1) = std::nan("");
  expect_error(s, "G");
  EXPECT_THROW(CoupledSystem(good, VectorXd::Zero(5), P0), Error);
  CoupledFilter f(CoupledFilterKind::kBlockDiagonal, VectorXd::Zero(6), P0);
  VectorXd y = VectorXd::Zero(3);
  y(1) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(f.Step(good, y), Error);
  EXPECT_THROW(f.Step(good, VectorXd::Zero(4)), Error);
  EXPECT_THROW(BlockDiagonalCovarianceUpdate(good, P0.leftCols(4)), Error);
}

}  // namespace
}  // namespace kfx
