// FilterMany (n independent small filters) against kfx's Kalman filter (RunFilter, Joseph form) run
// on each filter's own Model: seeded random sizes, shared and per-filter blocks, missing values.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>

#include "kfx/block_diagonal.hpp"
#include "kfx/kalman_filter.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using testing::TestRng;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Case {
  ManyFilterModel model;
  TimeSeries y;
  Index n;
};

// n filters, every block per filter (shared = false) or one block for all; y with a fraction of NaN.
Case MakeCase(Index n, Index c, Index d, Index T, bool shared, double missing, std::uint64_t seed) {
  TestRng rng(seed);
  const Index blocks = shared ? 1 : n;
  Case k;
  k.n = n;
  ManyFilterModel& m = k.model;
  m.F.resize(c, blocks * c);
  m.H.resize(d, blocks * c);
  m.Q.resize(c, blocks * c);
  m.R.resize(d, blocks * d);
  m.P0.resize(c, blocks * c);
  for (Index i = 0; i < blocks; ++i) {
    m.F.middleCols(i * c, c) = rng.WithSpectralRadius(c, 0.97);
    m.H.middleCols(i * c, c) = rng.Gaussian(d, c);
    m.Q.middleCols(i * c, c) = rng.Spd(c, 0.05);
    m.R.middleCols(i * d, d) = rng.Spd(d, 0.2);
    m.P0.middleCols(i * c, c) = rng.Spd(c, 0.5);
  }
  m.x0 = rng.Gaussian(c, shared ? 1 : n);
  k.y = rng.Gaussian(T, n * d);
  std::mt19937_64 gen(seed + 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (Index t = 0; t < T; ++t)
    for (Index j = 0; j < n * d; ++j)
      if (u(gen) < missing) k.y(t, j) = kNaN;
  return k;
}

MatrixXd BlockOf(const MatrixXd& m, Index i, Index b) { return m.cols() == b ? m : MatrixXd(m.middleCols(i * b, b)); }

// Filter i by RunFilter on its own Model: the independent reference.
FilterRun Reference(const Case& k, Index i) {
  const ManyFilterModel& m = k.model;
  const Index c = m.c(), d = m.d();
  const Model model(MakeStep(BlockOf(m.F, i, c), BlockOf(m.H, i, c), BlockOf(m.Q, i, c), BlockOf(m.R, i, d)),
                    m.x0.cols() == 1 ? Eigen::VectorXd(m.x0.col(0)) : Eigen::VectorXd(m.x0.col(i)),
                    BlockOf(m.P0, i, c));
  FilterRunOptions options;
  options.store_covariances = true;
  return RunFilter(model, k.y.middleCols(i * d, d), options);
}

void ExpectMatchesReference(const Case& k, double tol) {
  const ManyFiltersRun run = FilterMany(k.model, k.y);
  const Index c = k.model.c(), T = k.y.rows();
  ASSERT_EQ(run.x_filt.rows(), T);
  ASSERT_EQ(run.x_filt.cols(), k.n * c);
  for (Index i = 0; i < k.n; ++i) {
    const FilterRun ref = Reference(k, i);
    const MatrixXd x = run.x_filt.middleCols(i * c, c), x_ref = ref.x_filt.bottomRows(T);
    EXPECT_LE(testing::RelativeDifference(x, x_ref), tol) << "filter " << i;
    EXPECT_LE(testing::RelativeDifference(run.P_filt.middleCols(i * c, c), ref.P_filt.back()), tol) << "filter " << i;
  }
}

TEST(FilterMany, MatchesTheKalmanFilterOfEachFilterOnSeededSizes) {
  std::mt19937_64 gen(24);
  for (int trial = 0; trial < 12; ++trial) {
    const Index c = 1 + static_cast<Index>(gen() % 5);    // c <= 5
    const Index d = 1 + static_cast<Index>(gen() % 3);    // d <= 3
    const Index n = 1 + static_cast<Index>(gen() % 150);  // crosses chunks of 64
    const bool shared = trial % 2 == 0;
    SCOPED_TRACE("c = " + std::to_string(c) + ", d = " + std::to_string(d) + ", n = " + std::to_string(n) +
                 (shared ? ", shared" : ", per filter"));
    ExpectMatchesReference(MakeCase(n, c, d, 60, shared, 0.0, 100 + trial), 1e-12);
  }
}

TEST(FilterMany, EveryFixedShapeKernelMatches) {
  for (Index c = 1; c <= 4; ++c)
    for (Index d = 1; d <= 2; ++d) {
      SCOPED_TRACE("c = " + std::to_string(c) + ", d = " + std::to_string(d));
      ExpectMatchesReference(MakeCase(70, c, d, 40, false, 0.0, 10 * c + d), 1e-12);
    }
}

TEST(FilterMany, MissingMeasurementsAreSkippedAsTheKalmanFilterSkipsThem) {
  for (Index d : {1, 2, 3}) {
    SCOPED_TRACE("d = " + std::to_string(d));
    ExpectMatchesReference(MakeCase(90, 2, d, 50, false, 0.2, 7 + d), 1e-12);
  }
}

TEST(FilterMany, LongRunStaysAtTheDareSolution) {
  // The covariance after many steps is the filter DARE's P_{k|k}: a closed-form check of the recursion.
  Case k = MakeCase(5, 2, 1, 400, true, 0.0, 3);
  const ManyFiltersRun run = FilterMany(k.model, k.y);
  const DareSolution dare = SolveFilterDare(k.model.F, k.model.H, k.model.Q, k.model.R);
  ASSERT_TRUE(dare.summary.ok());
  for (Index i = 0; i < k.n; ++i) EXPECT_MATRICES_NEAR(run.P_filt.middleCols(i * 2, 2), dare.P_filt, 1e-10);
}

TEST(FilterMany, RejectsBadInput) {
  using testing::ThrowsErrorNaming;
  const Case k = MakeCase(10, 2, 1, 5, false, 0.0, 1);
  auto run = [&](ManyFilterModel m, TimeSeries y) { FilterMany(m, y); };
  ManyFilterModel m = k.model;
  m.F.conservativeResize(2, 7);
  EXPECT_TRUE(ThrowsErrorNaming([&] { run(m, k.y); }, "F"));
  m = k.model;
  m.H.resize(1, 3);
  EXPECT_TRUE(ThrowsErrorNaming([&] { run(m, k.y); }, "H"));
  m = k.model;
  m.Q(0, 4) = -5.0;  // filter 2 not PSD (and not symmetric)
  EXPECT_TRUE(ThrowsErrorNaming([&] { run(m, k.y); }, "filter 2"));
  m = k.model;
  m.R(0, 3) = 0.0;  // filter 3: R = 0 is not PD
  EXPECT_TRUE(ThrowsErrorNaming([&] { run(m, k.y); }, "R (filter 3)"));
  m = k.model;
  m.P0(0, 0) = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(ThrowsErrorNaming([&] { run(m, k.y); }, "P0"));
  m = k.model;
  m.x0.resize(2, 3);
  m.x0.setZero();
  EXPECT_TRUE(ThrowsErrorNaming([&] { run(m, k.y); }, "x0"));
  TimeSeries y = k.y;
  y(1, 1) = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(ThrowsErrorNaming([&] { run(k.model, y); }, "y"));
  EXPECT_TRUE(ThrowsErrorNaming([&] { run(k.model, TimeSeries(5, 0)); }, "y"));
  TimeSeries out(4, 20);
  MatrixXd P;
  EXPECT_TRUE(ThrowsErrorNaming([&] { FilterMany(k.model, k.y, out, &P); }, "x_filt"));
}

}  // namespace
}  // namespace kfx
