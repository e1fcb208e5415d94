// Tests of the stationary engine's block solve (src/core/stationary_performance.cpp). Oracles: the
// dense joint equation Sigma = AA Sigma AA^T + N of docs/exact-performance.md (4), formed explicitly and
// solved by the Kronecker system for small sizes and by SLICOT SG03AD at seeded random sizes; residuals; one
// StationaryTruth shared by several filters gives the Model overload's numbers.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "kfx/error.hpp"
#include "kfx/performance.hpp"
#include "kfx/riccati.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using kfx::testing::RelativeDifference;
using kfx::testing::TestRng;

struct Joint {
  MatrixXd AA, N;
};

// The joint system (1)-(4), dense: AA = [[A, 0], [K C A, Phi]], N = BB diag(Q, R) BB^T.
Joint DenseJoint(const ModelStep& s, const LinearFilterStep& f) {
  const Eigen::Index n = s.A.rows(), nz = f.Phi.rows();
  MatrixXd BB = MatrixXd::Zero(n + nz, n + s.C.rows());
  BB.topLeftCorner(n, n).setIdentity();
  BB.bottomLeftCorner(nz, n) = f.K * s.C;
  BB.bottomRightCorner(nz, s.C.rows()) = f.K;
  MatrixXd W = MatrixXd::Zero(n + s.C.rows(), n + s.C.rows());
  W.topLeftCorner(n, n) = s.Q;
  W.bottomRightCorner(s.C.rows(), s.C.rows()) = s.R;
  Joint j;
  j.AA = MatrixXd::Zero(n + nz, n + nz);
  j.AA.topLeftCorner(n, n) = s.A;
  j.AA.bottomLeftCorner(nz, n) = f.K * s.C * s.A;
  j.AA.bottomRightCorner(nz, nz) = f.Phi;
  j.N = BB * W * BB.transpose();
  j.N = 0.5 * (j.N + j.N.transpose());
  return j;
}

MatrixXd KroneckerLyapunov(const MatrixXd& A, const MatrixXd& Q) {
  const Eigen::Index n = A.rows();
  MatrixXd K(n * n, n * n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j) K.block(i * n, j * n, n, n) = A(i, j) * A;
  K = MatrixXd::Identity(n * n, n * n) - K;
  const VectorXd q = Eigen::Map<const VectorXd>(Q.data(), n * n);
  const VectorXd x = K.fullPivLu().solve(q);
  return Eigen::Map<const MatrixXd>(x.data(), n, n);
}

// [I, -O] Sigma [I, -O]^T (O empty: the identity).
MatrixXd ErrorFromSigma(const MatrixXd& Sigma, Eigen::Index n, const MatrixXd& O) {
  const Eigen::Index nz = Sigma.rows() - n;
  MatrixXd L(n, n + nz);
  L.leftCols(n).setIdentity();
  L.rightCols(nz) = O.size() == 0 ? MatrixXd(-MatrixXd::Identity(n, nz)) : MatrixXd(-O);
  return L * Sigma * L.transpose();
}

// A stable random filter with n_z states (output map O, n x n_z; empty when n_z = n and identity wanted).
LinearFilterStep RandomFilter(TestRng& rng, Eigen::Index nz, Eigen::Index n, Eigen::Index m, bool identity_output) {
  LinearFilterStep f;
  f.Phi = rng.WithSpectralRadius(nz, 0.93);
  f.K = rng.Gaussian(nz, m);
  if (!identity_output) f.O = rng.Gaussian(n, nz);
  return f;
}

TEST(StationaryBlocks, AgreesWithTheKroneckerSolveOfTheJointEquation) {
  TestRng rng(31);
  for (const auto& [n, nz, m] :
       {std::tuple{1, 1, 1}, std::tuple{2, 3, 1}, std::tuple{4, 2, 2}, std::tuple{5, 5, 2}, std::tuple{6, 4, 3}}) {
    const ModelStep s = RandomModelStep(rng, n, m, 0.9);
    const Model truth(s, VectorXd::Zero(n), rng.Spd(n));
    const LinearFilterStep f = RandomFilter(rng, nz, n, m, nz == n && n % 2 == 1);
    const StationaryPerformance p = ExactStationaryPerformance(truth, LinearFilter(f, VectorXd::Zero(nz)));
    ASSERT_TRUE(p.summary.ok()) << p.summary.message;
    EXPECT_EQ(p.method, StationaryMethod::kJoint);
    const Joint j = DenseJoint(s, f);
    const MatrixXd expected = ErrorFromSigma(KroneckerLyapunov(j.AA, j.N), n, f.O);
    EXPECT_LE(RelativeDifference(p.error_cov, expected), 1e-11) << n << ", " << nz << ", " << m;
    EXPECT_LE(p.summary.relative_residual, 1e-14);
  }
}

// Seeded random sizes (across the recursion's base size 32), against the dense joint equation solved by
// SLICOT SG03AD (SolveGeneralizedDiscreteLyapunov with E = I); one StationaryTruth serves every filter and gives the
// Model overload's result.
TEST(StationaryBlocks, RandomSizesAgreeWithTheDenseJointSolve) {
  std::mt19937 sizes(77);
  std::uniform_int_distribution<int> size(10, 70);
  TestRng rng(32);
  for (int trial = 0; trial < 4; ++trial) {
    const int n = size(sizes);
    const int m = 1 + size(sizes) / 10;
    const ModelStep s = RandomModelStep(rng, n, m, 0.97);
    const Model truth(s, VectorXd::Zero(n), rng.Spd(n));
    const StationaryTruth shared(truth);
    ASSERT_TRUE(shared.summary().ok());
    EXPECT_NEAR(shared.spectral_radius(), 0.97, 1e-12);
    const LyapunovSolution sxx = SolveDiscreteLyapunov(s.A, s.Q, LyapunovOptions{LyapunovMethod::kSmith});
    EXPECT_LE(RelativeDifference(shared.state_covariance(), sxx.X), 1e-11);
    for (int k = 0; k < 3; ++k) {
      const Eigen::Index nz = k == 0 ? n : size(sizes);
      const LinearFilterStep f = RandomFilter(rng, nz, n, m, k == 0);
      const LinearFilter filter(f, VectorXd::Zero(nz));
      const StationaryPerformanceOptions weighted{rng.Spd(n)};
      const StationaryPerformance p = ExactStationaryPerformance(shared, filter, weighted);
      ASSERT_TRUE(p.summary.ok()) << p.summary.message;
      EXPECT_LE(p.summary.relative_residual, 1e-13);
      const Joint j = DenseJoint(s, f);
      const LyapunovSolution dense =
          SolveGeneralizedDiscreteLyapunov(j.AA, MatrixXd::Identity(n + nz, n + nz), j.N);  // SLICOT SG03AD
      ASSERT_TRUE(dense.summary.ok());
      const MatrixXd expected = ErrorFromSigma(dense.X, n, f.O);
      EXPECT_LE(RelativeDifference(p.error_cov, expected), 1e-10) << "n = " << n << ", nz = " << nz;
      EXPECT_NEAR(p.weighted_mse, weighted.weight.cwiseProduct(expected).sum(), 1e-10 * std::abs(p.weighted_mse));
      const StationaryPerformance q = ExactStationaryPerformance(truth, filter, weighted);
      EXPECT_EQ(q.error_cov, p.error_cov);  // the same computation, once per truth or per call
      EXPECT_EQ(q.weighted_mse, p.weighted_mse);
    }
  }
}

// An unstable truth has no x-block; a consistent filter still has a stationary error (error coordinates),
// an inconsistent one none.
TEST(StationaryBlocks, UnstableTruthKeepsTheErrorCoordinatesRoute) {
  TestRng rng(33);
  const int n = 4, m = 2;
  const ModelStep s = RandomModelStep(rng, n, m, 1.02);
  const StationaryTruth shared(Model(s, VectorXd::Zero(n), rng.Spd(n)));
  EXPECT_EQ(shared.summary().termination, Termination::kUnstable);
  EXPECT_EQ(shared.state_covariance().size(), 0);
  const DareSolution d = SolveFilterDare(s.A, s.C, s.Q, s.R);
  ASSERT_TRUE(d.summary.ok());
  LinearFilterStep f;
  f.K = d.filter_gain;
  f.Phi = (MatrixXd::Identity(n, n) - f.K * s.C) * s.A;
  const StationaryPerformance p = ExactStationaryPerformance(shared, LinearFilter(f, VectorXd::Zero(n)));
  ASSERT_TRUE(p.summary.ok()) << p.summary.message;
  EXPECT_EQ(p.method, StationaryMethod::kErrorCoordinates);
  EXPECT_LE(RelativeDifference(p.error_cov, d.P_filt), 1e-10);
  f.Phi = rng.WithSpectralRadius(n, 0.5);
  const StationaryPerformance u = ExactStationaryPerformance(shared, LinearFilter(f, VectorXd::Zero(n)));
  EXPECT_EQ(u.summary.termination, Termination::kUnstable);
}

TEST(StationaryBlocks, RejectsATimeVaryingModelAndAnIncompatibleFilter) {
  TestRng rng(34);
  const ModelStep s = RandomModelStep(rng, 3, 1, 0.5);
  const Model varying(std::vector<ModelStep>{s, s}, VectorXd::Zero(3), rng.Spd(3));
  EXPECT_TRUE(kfx::testing::ThrowsErrorStartingWith([&] { StationaryTruth{varying}; }, "truth:"));
  const StationaryTruth shared(Model(s, VectorXd::Zero(3), rng.Spd(3)));
  LinearFilterStep f;  // (braces evaluated in order: Phi, then K)
  f.Phi = rng.WithSpectralRadius(3, 0.5);
  f.K = rng.Gaussian(3, 2);
  EXPECT_TRUE(kfx::testing::ThrowsErrorStartingWith(
      [&] { ExactStationaryPerformance(shared, LinearFilter(f, VectorXd::Zero(3))); }, "filter:"));
}

}  // namespace
}  // namespace kfx
