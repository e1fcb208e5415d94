#include "kfx/simulation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "kfx/error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

TEST(Rng, ReproducibleAndStreamsDiffer) {
  Rng a(42), b(42), c(Rng::StreamSeed(42, 1));
  for (int i = 0; i < 100; ++i) EXPECT_EQ(a.Normal(), b.Normal());
  EXPECT_NE(Rng(Rng::StreamSeed(42, 0)).Normal(), c.Normal());
  EXPECT_NE(Rng::StreamSeed(1, 2), Rng::StreamSeed(2, 1));
}

TEST(Rng, NormalMomentsWithinConfidenceInterval) {
  Rng rng(7);
  const int N = 200000;
  double s = 0, s2 = 0, s4 = 0;
  for (int i = 0; i < N; ++i) {
    const double x = rng.Normal();
    s += x;
    s2 += x * x;
    s4 += x * x * x * x;
  }
  EXPECT_LT(std::abs(s / N), 4.5 / std::sqrt(N));              // sd of mean = 1/sqrt(N)
  EXPECT_LT(std::abs(s2 / N - 1), 4.5 * std::sqrt(2.0 / N));   // var of x^2 = 2
  EXPECT_LT(std::abs(s4 / N - 3), 4.5 * std::sqrt(96.0 / N));  // var of x^4 = 105 - 9
}

TEST(PsdFactor, ReproducesSemidefiniteMatrices) {
  kfx::testing::TestRng rng(3);
  for (const Eigen::Index n : {0, 1, 4, 30}) {
    const MatrixXd G = rng.Gaussian(n, std::max<Eigen::Index>(n / 2, 1));
    const MatrixXd M = G * G.transpose();  // rank-deficient PSD
    const MatrixXd F = PsdFactor(M);
    EXPECT_MATRICES_NEAR(F * F.transpose(), M, 1e-10 * std::max(1.0, M.norm()));
  }
}

TEST(Simulate, ReproducibleShapesAndCovariance) {
  kfx::testing::TestRng rng(9);
  const Eigen::Index n = 3, m = 2;
  MatrixXd A = rng.WithSpectralRadius(n, 0.9);
  MatrixXd C = rng.Gaussian(m, n);
  MatrixXd Q = rng.Spd(n);
  MatrixXd R = rng.Spd(m);
  MatrixXd P0 = rng.Spd(n);
  VectorXd m0 = rng.Gaussian(n, 1);
  Model model(MakeStep(A, C, Q, R), m0, P0);
  const Trajectory t1 = Simulate(model, {10, 5}), t2 = Simulate(model, {10, 5});
  EXPECT_EQ(t1.x.rows(), 11);
  EXPECT_EQ(t1.y.rows(), 10);
  EXPECT_MATRICES_NEAR(MatrixXd(t1.x), MatrixXd(t2.x), 0.0);
  const auto batch = SimulateBatch(model, 20000, {2, 11});
  // Sample mean and covariance of x_1 and y_1 against m1 = A m0, P1 = A P0 A^T + Q, C P1 C^T + R.
  const VectorXd m1 = A * m0;
  const MatrixXd P1 = A * P0 * A.transpose() + Q;
  VectorXd mean = VectorXd::Zero(n);
  MatrixXd cov = MatrixXd::Zero(n, n), ycov = MatrixXd::Zero(m, m);
  for (const auto& t : batch) {
    const VectorXd d = t.x.row(1).transpose() - m1;
    mean += d;
    cov += d * d.transpose();
    const VectorXd e = t.y.row(0).transpose() - C * m1;
    ycov += e * e.transpose();
  }
  const double N = static_cast<double>(batch.size());
  mean /= N;
  cov /= N;
  ycov /= N;
  for (Eigen::Index i = 0; i < n; ++i) EXPECT_LT(std::abs(mean(i)), 4.5 * std::sqrt(P1(i, i) / N));
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j)
      EXPECT_LT(std::abs(cov(i, j) - P1(i, j)), 4.5 * std::sqrt((P1(i, i) * P1(j, j) + P1(i, j) * P1(i, j)) / N));
  const MatrixXd S = C * P1 * C.transpose() + R;
  for (Eigen::Index i = 0; i < m; ++i)
    EXPECT_LT(std::abs(ycov(i, i) - S(i, i)), 4.5 * std::sqrt(2 * S(i, i) * S(i, i) / N));
  EXPECT_THROW(SimulateBatch(model, -1, {2, 1}), Error);
  EXPECT_THROW(Simulate(model, {-1, 1}), Error);  // no horizon
}

TEST(Simulate, ProgressCountsEveryStepAndLeavesTheTrajectoryAlone) {
  kfx::testing::TestRng rng(2);
  const MatrixXd P0 = rng.Spd(3);  // one draw per statement, in GCC's former order of the arguments (TestRng)
  Model model(RandomModelStep(rng, 3, 2, 0.9), VectorXd::Zero(3), P0);
  std::vector<long> steps;
  SimulationOptions o{12, 4};
  o.progress = [&](long done, long total) {
    EXPECT_EQ(total, 12);
    steps.push_back(done);
  };
  const Trajectory with = Simulate(model, o), without = Simulate(model, {12, 4});
  EXPECT_MATRICES_NEAR(MatrixXd(with.x), MatrixXd(without.x), 0.0);
  ASSERT_EQ(steps.size(), 12u);
  for (size_t i = 0; i < steps.size(); ++i) EXPECT_EQ(steps[i], static_cast<long>(i) + 1);
}

TEST(Simulate, NoiseInputDrawsInItsOwnDimension) {
  // w = B u with a single input: every w_k lies along B.
  MatrixXd A = 0.5 * MatrixXd::Identity(3, 3), B(3, 1);
  B << 1, -2, 0.5;
  Model model(MakeStepWithNoiseInput(A, B, MatrixXd::Identity(1, 1), MatrixXd::Ones(1, 3), MatrixXd::Identity(1, 1)),
              VectorXd::Zero(3), MatrixXd::Zero(3, 3));
  const Trajectory t = Simulate(model, {5, 1});
  for (int k = 1; k <= 5; ++k) {
    const VectorXd w = t.x.row(k).transpose() - A * t.x.row(k - 1).transpose();
    const VectorXd b = B.col(0);
    const double along = w.dot(b) / b.squaredNorm();
    EXPECT_MATRICES_NEAR(w, along * b, 1e-13);
  }
}

// Issue 20, class 4: no trajectory with inf or NaN. Q near DBL_MAX is factored without overflow (before,
// 0.5 (Q + Q^T) overflowed to inf and the run wrote inf and NaN); a diverging model is a NumericalError naming
// the step where the state overflows (before: inf written with exit code 0).
TEST(Simulate, HugeNoiseIsFiniteAndDivergenceIsAnErrorNamingTheStep) {
  const double huge = 1e308;
  const MatrixXd one = MatrixXd::Ones(1, 1);
  const Model noisy(MakeStep(0.5 * one, one, huge * one, one), VectorXd::Zero(1), one);
  const Trajectory tr = Simulate(noisy, SimulationOptions{50, 3});
  EXPECT_TRUE(tr.x.allFinite());
  EXPECT_TRUE(tr.y.allFinite());
  // x_1 = 0.5 x_0 + sqrt(1e308) w: the sample standard deviation of the increments is about 1e154.
  const double rms = tr.x.stableNorm() / std::sqrt(static_cast<double>(tr.x.rows()));  // (squaredNorm overflows)
  EXPECT_GT(rms, 1e153);
  EXPECT_LT(rms, 1e155);
  EXPECT_EQ(PsdFactor(huge * MatrixXd::Identity(2, 2)).cwiseAbs().maxCoeff(), std::sqrt(huge));
  // x_k = 10^k x_0 overflows near k = 308.
  const Model diverging(MakeStep(10.0 * one, one, one, one), VectorXd::Ones(1), one);
  EXPECT_TRUE(Simulate(diverging, SimulationOptions{300, 3}).x.allFinite());
  try {
    Simulate(diverging, SimulationOptions{400, 3});
    ADD_FAILURE() << "expected a NumericalError";
  } catch (const NumericalError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("not finite at step 3"), std::string::npos) << msg;  // a step in 300..399
    EXPECT_NE(msg.find("diverges"), std::string::npos) << msg;
  }
}

}  // namespace
}  // namespace kfx
