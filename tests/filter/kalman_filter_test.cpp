// Kalman filter and RTS smoother against independent truth: scalar closed forms, the alpha-beta
// (Kalata) closed form of the double integrator, the DARE, a batch information-form solution, and
// the exact Gaussian log-likelihood of the stacked measurements.
#include "kfx/kalman_filter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/riccati.hpp"
#include "kfx/simulation.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
const double kNaN = std::numeric_limits<double>::quiet_NaN();

MatrixXd Scalar(double v) { return MatrixXd::Constant(1, 1, v); }

// Discrete white-noise-acceleration model: A = [[1, T], [0, 1]], w = G a, G = [T^2/2, T]^T.
ModelStep Dwna(double T, double sigma_w, double sigma_v) {
  MatrixXd A(2, 2), G(2, 1), C(1, 2);
  A << 1, T, 0, 1;
  G << T * T / 2, T;
  C << 1, 0;
  return MakeStepWithNoiseInput(A, G, Scalar(sigma_w * sigma_w), C, Scalar(sigma_v * sigma_v));
}

TEST(KalmanFilter, ScalarRandomWalkMatchesClosedFormRecursion) {
  const double q = 0.3, r = 2.0, p0 = 5.0, m0 = 1.0;
  Model model(MakeStep(Scalar(1), Scalar(1), Scalar(q), Scalar(r)), VectorXd::Constant(1, m0), Scalar(p0));
  TimeSeries y(6, 1);
  y << 0.5, 1.7, -0.2, 2.5, 1.1, 0.9;
  const FilterRun run = RunFilter(model, y);
  double x = m0, p = p0, ll = 0.0;
  for (int k = 1; k <= 6; ++k) {
    const double pp = p + q, s = pp + r, kg = pp / s, nu = y(k - 1, 0) - x;
    x += kg * nu;
    p = pp * r / s;  // = (1 - K) P_pred
    ll += -0.5 * (std::log(2 * M_PI) + std::log(s) + nu * nu / s);
    EXPECT_NEAR(run.x_filt(k, 0), x, 1e-14);
    EXPECT_NEAR(run.P_filt[static_cast<size_t>(k)](0, 0), p, 1e-14);
    EXPECT_NEAR(run.P_pred_diag(k, 0), pp, 1e-14);
    EXPECT_NEAR(run.innovations(k - 1, 0), nu, 1e-14);
  }
  EXPECT_NEAR(run.log_likelihood, ll, 1e-12);
}

TEST(KalmanFilter, ScalarRandomWalkConvergesToClosedFormSteadyState) {
  const double q = 0.3, r = 2.0;
  Model model(MakeStep(Scalar(1), Scalar(1), Scalar(q), Scalar(r)), VectorXd::Zero(1), Scalar(100.0));
  const KalmanSchedule sch = ComputeKalmanSchedule(model, KalmanScheduleOptions{200});
  const double p_pred = (q + std::sqrt(q * q + 4 * q * r)) / 2;  // root of P^2 - q P - q r = 0
  EXPECT_NEAR(sch.P_pred.back()(0, 0), p_pred, 1e-13);
  EXPECT_NEAR(sch.filter_gain.back()(0, 0), p_pred / (p_pred + r), 1e-13);
}

// Kalata (1984): for the DWNA model the steady-state filter gain is [alpha, beta / T] with
// tracking index lambda = sigma_w T^2 / sigma_v and
//   alpha = -(l^2 + 8 l - (l + 4) sqrt(l^2 + 8 l)) / 8,   beta = (l^2 + 4 l - l sqrt(l^2 + 8 l)) / 4.
TEST(KalmanFilter, DoubleIntegratorSteadyStateGainMatchesAlphaBetaClosedForm) {
  for (const double T : {0.5, 1.0, 2.0}) {
    for (const double lambda_target : {0.1, 1.0, 7.0}) {
      const double sigma_v = 1.5, sigma_w = lambda_target * sigma_v / (T * T);
      const double l = sigma_w * T * T / sigma_v;
      const double root = std::sqrt(l * l + 8 * l);
      const double alpha = -(l * l + 8 * l - (l + 4) * root) / 8;
      const double beta = (l * l + 4 * l - l * root) / 4;
      MatrixXd expected(2, 1);
      expected << alpha, beta / T;
      const ModelStep s = Dwna(T, sigma_w, sigma_v);
      const DareSolution dare = SolveFilterDare(s.A, s.C, s.Q, s.R);
      ASSERT_TRUE(dare.summary.ok()) << dare.summary.FullReport();
      EXPECT_MATRICES_NEAR(dare.filter_gain, expected, 1e-10);
      Model model(s, VectorXd::Zero(2), 10.0 * MatrixXd::Identity(2, 2));
      const KalmanSchedule sch = ComputeKalmanSchedule(model, KalmanScheduleOptions{3000});
      EXPECT_MATRICES_NEAR(sch.filter_gain.back(), expected, 1e-9) << "T = " << T << ", lambda = " << l;
    }
  }
}

TEST(KalmanFilter, RiccatiRecursionConvergesToDare) {
  kfx::testing::TestRng rng(7);
  for (const Eigen::Index n : {2, 5, 20}) {
    const Eigen::Index m = std::max<Eigen::Index>(1, n / 2);
    const ModelStep s = RandomModelStep(rng, n, m, 1.1);
    Model model(s, VectorXd::Zero(n), MatrixXd::Identity(n, n));
    const KalmanSchedule sch = ComputeKalmanSchedule(model, KalmanScheduleOptions{400});
    const DareSolution dare = SolveFilterDare(s.A, s.C, s.Q, s.R);
    ASSERT_TRUE(dare.summary.ok()) << dare.summary.FullReport();
    const double scale = dare.P_pred.norm();
    EXPECT_LT((sch.P_pred.back() - dare.P_pred).norm() / scale, 1e-11) << "n = " << n;
    EXPECT_LT((sch.P_filt.back() - dare.P_filt).norm() / scale, 1e-11) << "n = " << n;
    EXPECT_MATRICES_NEAR(sch.filter_gain.back(), dare.filter_gain, 1e-9 * std::max(1.0, dare.filter_gain.norm()));
  }
}

TEST(KalmanFilter, JosephAndStandardFormsAgreeOnWellConditionedProblem) {
  kfx::testing::TestRng rng(3);
  const Eigen::Index n = 6, m = 3;
  const ModelStep s = RandomModelStep(rng, n, m, 0.9);
  Model model(s, VectorXd::Zero(n), MatrixXd::Identity(n, n));
  KalmanFilterOptions standard;
  standard.update_form = CovarianceUpdateForm::kStandard;
  const KalmanSchedule a = ComputeKalmanSchedule(model, KalmanScheduleOptions{50});
  const KalmanSchedule b = ComputeKalmanSchedule(model, KalmanScheduleOptions{50, standard});
  for (int k = 0; k <= 50; ++k)
    EXPECT_MATRICES_NEAR(a.P_filt[static_cast<size_t>(k)], b.P_filt[static_cast<size_t>(k)], 1e-12);
}

TEST(KalmanFilter, ClassMatchesFunctionsAndRun) {
  kfx::testing::TestRng rng(11);
  const Eigen::Index n = 4, m = 2;
  const ModelStep s = RandomModelStep(rng, n, m, 0.95);
  Model model(s, rng.Gaussian(n, 1), MatrixXd::Identity(n, n));
  const Trajectory tr = Simulate(model, {20, 5});
  const FilterRun run = RunFilter(model, tr.y);
  KalmanFilter kf(model);
  EXPECT_THROW(kf.Update(tr.y.row(0).transpose()), Error);  // Update before Predict
  for (int k = 1; k <= 20; ++k) {
    kf.Step(tr.y.row(k - 1).transpose());
    EXPECT_MATRICES_NEAR(kf.estimate().x, run.x_filt.row(k).transpose(), 1e-13);
    EXPECT_MATRICES_NEAR(kf.estimate().P, run.P_filt[static_cast<size_t>(k)], 1e-13);
  }
  EXPECT_EQ(kf.k(), 20);
  kf.Reset();
  EXPECT_EQ(kf.k(), 0);
}

// Above kSymmetricProductMin, Predict and the Joseph update use DTRMM/DSYR2K: against the textbook
// formulas, (I - K C) P (I - K C)^T + K R K^T formed explicitly.
TEST(KalmanFilter, SymmetricBlasProductsMatchTextbookFormulas) {
  kfx::testing::TestRng rng(29);
  for (const Eigen::Index n : {31, 32, 60}) {
    const Eigen::Index m = 7;
    const ModelStep s = RandomModelStep(rng, n, m, 0.9);
    const VectorXd x = rng.Gaussian(n, 1);  // one draw per statement (braces evaluated x, then P)
    const Estimate e{x, rng.Spd(n)};
    const Estimate pred = Predict(e, s);
    const MatrixXd P_pred = s.A * e.P * s.A.transpose() + s.Q;
    EXPECT_MATRICES_NEAR(pred.P, P_pred, 1e-13 * P_pred.norm());
    EXPECT_EQ((pred.P - pred.P.transpose()).norm(), 0.0);
    const VectorXd y = rng.Gaussian(m, 1);
    const UpdateResult u = Update(pred, s, y);
    const MatrixXd S = s.C * P_pred * s.C.transpose() + s.R;
    const MatrixXd K = P_pred * s.C.transpose() * S.inverse();
    const MatrixXd IKC = MatrixXd::Identity(n, n) - K * s.C;
    const MatrixXd P_filt = IKC * P_pred * IKC.transpose() + K * s.R * K.transpose();
    EXPECT_MATRICES_NEAR(u.gain, K, 1e-11 * K.norm());
    EXPECT_MATRICES_NEAR(u.estimate.P, P_filt, 1e-12 * P_filt.norm());
    EXPECT_EQ((u.estimate.P - u.estimate.P.transpose()).norm(), 0.0);
    // The standard form P - K C P (Eigen products, unchanged) agrees at this conditioning.
    KalmanFilterOptions standard;
    standard.update_form = CovarianceUpdateForm::kStandard;
    EXPECT_MATRICES_NEAR(Update(pred, s, y, standard).estimate.P, P_filt, 1e-11 * P_filt.norm());
  }
}

// n, m <= 8 run on fixed-maximum-size matrices with loop products; larger sizes on Eigen/BLAS. A
// system embedded in a larger one by decoupled extra states (A, Q, P0 block diagonal, C zero on
// them) keeps its cross-covariances exactly zero, so its block of the large (dynamic-path) run is
// the same filter computed by the other code path.
TEST(KalmanFilter, SmallSizePathMatchesDynamicPathOnAnEmbeddedSystem) {
  kfx::testing::TestRng rng(31);
  struct Shape {
    Eigen::Index n, m;
  };
  for (const Shape sh : {Shape{1, 1}, Shape{2, 1}, Shape{4, 2}, Shape{5, 3}, Shape{8, 3}, Shape{8, 8}, Shape{3, 5}}) {
    const Eigen::Index n = sh.n, m = sh.m, p = 10 - n, N = n + p;
    std::vector<ModelStep> small, large;
    for (int k = 0; k < 6; ++k) {  // time-varying, cycled over 60 steps
      ModelStep s = RandomModelStep(rng, n, m, 0.95);
      MatrixXd A = MatrixXd::Zero(N, N), Q = MatrixXd::Zero(N, N), C = MatrixXd::Zero(m, N);
      A.topLeftCorner(n, n) = s.A;
      A.bottomRightCorner(p, p) = 0.5 * MatrixXd::Identity(p, p);
      Q.topLeftCorner(n, n) = s.Q;
      Q.bottomRightCorner(p, p) = MatrixXd::Identity(p, p);
      C.leftCols(n) = s.C;
      large.push_back(MakeStep(A, C, Q, s.R));
      small.push_back(std::move(s));
    }
    std::vector<ModelStep> small_steps, large_steps;
    for (int k = 0; k < 60; ++k) {
      small_steps.push_back(small[static_cast<size_t>(k % 6)]);
      large_steps.push_back(large[static_cast<size_t>(k % 6)]);
    }
    const MatrixXd P0 = rng.Spd(n);
    MatrixXd P0_large = MatrixXd::Identity(N, N);
    P0_large.topLeftCorner(n, n) = P0;
    const VectorXd m0 = rng.Gaussian(n, 1);
    VectorXd m0_large = VectorXd::Zero(N);
    m0_large.head(n) = m0;
    const Model model_small(small_steps, m0, P0), model_large(large_steps, m0_large, P0_large);
    TimeSeries y = rng.Gaussian(60, m);
    y(7, 0) = kNaN;                                        // a partly missing measurement
    for (Eigen::Index i = 0; i < m; ++i) y(20, i) = kNaN;  // a step with nothing observed
    for (const CovarianceUpdateForm form : {CovarianceUpdateForm::kJoseph, CovarianceUpdateForm::kStandard}) {
      FilterRunOptions options;
      options.filter.update_form = form;
      const FilterRun a = RunFilter(model_small, y, options), b = RunFilter(model_large, y, options);
      SCOPED_TRACE("n = " + std::to_string(n) + ", m = " + std::to_string(m));
      EXPECT_MATRICES_NEAR(a.x_filt, b.x_filt.leftCols(n), 1e-12 * b.x_filt.norm());
      EXPECT_MATRICES_NEAR(a.x_pred, b.x_pred.leftCols(n), 1e-12 * b.x_pred.norm());
      EXPECT_NEAR(a.log_likelihood, b.log_likelihood, 1e-12 * std::abs(b.log_likelihood));
      EXPECT_EQ(a.num_observed, b.num_observed);
      for (size_t k = 0; k < a.P_filt.size(); ++k) {
        EXPECT_MATRICES_NEAR(a.P_filt[k], b.P_filt[k].topLeftCorner(n, n), 1e-12 * b.P_filt[k].norm());
        EXPECT_MATRICES_NEAR(a.P_pred[k], b.P_pred[k].topLeftCorner(n, n), 1e-12 * b.P_pred[k].norm());
      }
      // The one-step functions take the same paths.
      const Estimate e{m0, P0}, e_large{m0_large, P0_large};
      const Estimate pa = Predict(e, small[0], options.filter), pb = Predict(e_large, large[0], options.filter);
      const UpdateResult ua = Update(pa, small[0], y.row(7).transpose(), options.filter);
      const UpdateResult ub = Update(pb, large[0], y.row(7).transpose(), options.filter);
      EXPECT_MATRICES_NEAR(ua.estimate.P, ub.estimate.P.topLeftCorner(n, n), 1e-12 * ub.estimate.P.norm());
      EXPECT_MATRICES_NEAR(ua.gain, ub.gain.topRows(n), 1e-12 * ub.gain.norm());
      EXPECT_MATRICES_NEAR(ua.innovation_cov, ub.innovation_cov, 1e-12 * ub.innovation_cov.norm());
      EXPECT_NEAR(ua.log_likelihood, ub.log_likelihood, 1e-12 * std::abs(ub.log_likelihood));
      EXPECT_EQ(ua.observed, ub.observed);
    }
  }
}

// The steady-state fast path against the full recursion: same estimates, log-likelihood and
// covariances to the tolerance's order; a missing measurement resumes the full recursion.
TEST(KalmanFilter, SteadyStateFastPathMatchesFullRecursion) {
  kfx::testing::TestRng rng(17);
  const Eigen::Index n = 5, m = 2;
  const ModelStep s = RandomModelStep(rng, n, m, 0.95);
  Model model(s, rng.Gaussian(n, 1), MatrixXd::Identity(n, n));
  TimeSeries y = Simulate(model, {300, 4}).y;
  y(200, 1) = kNaN;
  const FilterRun full = RunFilter(model, y);
  FilterRunOptions fast_options;
  fast_options.steady_state_tolerance = 1e-13;
  const FilterRun fast = RunFilter(model, y, fast_options);
  EXPECT_EQ(full.steady_state_steps, 0);
  // Frozen before step 200, resumed there, frozen again after.
  EXPECT_GT(fast.steady_state_steps, 150);
  EXPECT_LT(fast.steady_state_steps, 299);
  EXPECT_EQ(fast.num_observed[200], 1);
  const double xs = full.x_filt.norm();
  EXPECT_LT((fast.x_filt - full.x_filt).norm() / xs, 1e-11);
  EXPECT_LT((fast.x_pred - full.x_pred).norm() / xs, 1e-11);
  EXPECT_TRUE((fast.innovations.array().isNaN() == full.innovations.array().isNaN()).all());
  EXPECT_NEAR(fast.log_likelihood, full.log_likelihood, 1e-9 * std::abs(full.log_likelihood));
  for (int k = 0; k <= 300; ++k) {
    const auto i = static_cast<size_t>(k);
    EXPECT_LT((fast.P_filt[i] - full.P_filt[i]).norm(), 1e-11 * full.P_filt[i].norm()) << "k = " << k;
    EXPECT_LT((fast.P_pred[i] - full.P_pred[i]).norm(), 1e-11 * full.P_pred[i].norm()) << "k = " << k;
  }
  EXPECT_LT((fast.P_filt_diag - full.P_filt_diag).norm(), 1e-11 * full.P_filt_diag.norm());
  fast_options.steady_state_tolerance = -1.0;
  EXPECT_THROW(RunFilter(model, y, fast_options), Error);
}

// Stacked Gaussian: Y = G xi + v with xi = (x0, w_1..w_T); the log-density of the observed entries.
double BatchLogLikelihood(const ModelStep& s, const VectorXd& m0, const MatrixXd& P0, const TimeSeries& y) {
  const Eigen::Index n = s.A.rows(), m = s.C.rows();
  const int T = static_cast<int>(y.rows());
  const Eigen::Index nxi = n * (T + 1);
  MatrixXd Sxi = MatrixXd::Zero(nxi, nxi);
  Sxi.topLeftCorner(n, n) = P0;
  for (int k = 1; k <= T; ++k) Sxi.block(n * k, n * k, n, n) = s.Q;
  MatrixXd M = MatrixXd::Zero(n, nxi);  // x_k = M xi + mean_k
  M.leftCols(n).setIdentity();
  VectorXd mean_x = m0;
  std::vector<Eigen::Index> rows;
  MatrixXd G(m * T, nxi);
  VectorXd mu(m * T), yv(m * T);
  for (int k = 1; k <= T; ++k) {
    M = (s.A * M).eval();
    M.block(0, n * k, n, n) += MatrixXd::Identity(n, n);
    mean_x = s.A * mean_x;
    G.middleRows(m * (k - 1), m) = s.C * M;
    mu.segment(m * (k - 1), m) = s.C * mean_x;
    for (Eigen::Index i = 0; i < m; ++i) {
      yv(m * (k - 1) + i) = y(k - 1, i);
      if (!std::isnan(y(k - 1, i))) rows.push_back(m * (k - 1) + i);
    }
  }
  MatrixXd Sy = G * Sxi * G.transpose();
  for (int k = 0; k < T; ++k) Sy.block(m * k, m * k, m, m) += s.R;
  const MatrixXd So = Sy(rows, rows);
  const VectorXd d = yv(rows) - mu(rows);
  Eigen::LLT<MatrixXd> llt(So);
  const double logdet = 2 * llt.matrixLLT().diagonal().array().log().sum();
  return -0.5 * (static_cast<double>(rows.size()) * std::log(2 * M_PI) + logdet + d.dot(llt.solve(d)));
}

TEST(KalmanFilter, LogLikelihoodEqualsStackedGaussianDensityWithMissingData) {
  kfx::testing::TestRng rng(21);
  const Eigen::Index n = 3, m = 2;
  const ModelStep s = RandomModelStep(rng, n, m, 1.05);
  const VectorXd m0 = rng.Gaussian(n, 1);
  const MatrixXd P0 = rng.Spd(n);
  Model model(s, m0, P0);
  TimeSeries y = Simulate(model, {8, 99}).y;
  EXPECT_NEAR(RunFilter(model, y).log_likelihood, BatchLogLikelihood(s, m0, P0, y), 1e-10);
  y(2, 0) = kNaN;            // one entry missing
  y(4, 0) = y(4, 1) = kNaN;  // a whole step missing
  const FilterRun run = RunFilter(model, y);
  EXPECT_NEAR(run.log_likelihood, BatchLogLikelihood(s, m0, P0, y), 1e-10);
  EXPECT_EQ(run.num_observed[2], 1);
  EXPECT_EQ(run.num_observed[4], 0);
  EXPECT_TRUE(std::isnan(run.innovations(4, 0)) && std::isnan(run.innovations(4, 1)));
}

TEST(KalmanFilter, MissingMeasurementsUseObservedRowsOnly) {
  kfx::testing::TestRng rng(5);
  const Eigen::Index n = 4, m = 3;
  const ModelStep s = RandomModelStep(rng, n, m, 0.9);
  const VectorXd x0 = rng.Gaussian(n, 1);  // one draw per statement (braces evaluated x, then P)
  const Estimate prior{x0, rng.Spd(n)};
  VectorXd y = rng.Gaussian(m, 1);
  // All missing: the estimate is the prior.
  const UpdateResult none = Update(prior, s, VectorXd::Constant(m, kNaN));
  EXPECT_MATRICES_NEAR(none.estimate.x, prior.x, 0.0);
  EXPECT_MATRICES_NEAR(none.estimate.P, prior.P, 0.0);
  EXPECT_EQ(none.log_likelihood, 0.0);
  // Entry 1 missing: same as the update with rows {0, 2} of C and R.
  y(1) = kNaN;
  const std::vector<Eigen::Index> keep{0, 2};
  ModelStep reduced = MakeStep(s.A, s.C(keep, Eigen::all), s.Q, s.R(keep, keep));
  const UpdateResult partial = Update(prior, s, y);
  const UpdateResult direct = Update(prior, reduced, y(keep));
  EXPECT_MATRICES_NEAR(partial.estimate.x, direct.estimate.x, 1e-14);
  EXPECT_MATRICES_NEAR(partial.estimate.P, direct.estimate.P, 1e-14);
  EXPECT_NEAR(partial.log_likelihood, direct.log_likelihood, 1e-14);
  y(0) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(Update(prior, s, y), Error);
  EXPECT_THROW(Update(prior, s, VectorXd::Zero(m + 1)), Error);
  EXPECT_THROW(Predict(Estimate{VectorXd::Zero(n + 1), MatrixXd::Identity(n, n)}, s), Error);
}

// The smoother against the batch (information-form) posterior of all states x_0..x_T.
TEST(RtsSmoother, MatchesBatchInformationFormSolution) {
  kfx::testing::TestRng rng(13);
  const Eigen::Index n = 3, m = 1;
  const int T = 7;
  const ModelStep s = RandomModelStep(rng, n, m, 1.02);
  const VectorXd m0 = rng.Gaussian(n, 1);
  const MatrixXd P0 = rng.Spd(n);
  Model model(s, m0, P0);
  TimeSeries y = Simulate(model, {T, 17}).y;
  y(3, 0) = kNaN;
  const Eigen::Index N = n * (T + 1);
  MatrixXd J = MatrixXd::Zero(N, N);
  VectorXd h = VectorXd::Zero(N);
  const MatrixXd P0i = P0.llt().solve(MatrixXd::Identity(n, n));
  const MatrixXd Qi = s.Q.llt().solve(MatrixXd::Identity(n, n));
  const MatrixXd Ri = s.R.llt().solve(MatrixXd::Identity(m, m));
  J.topLeftCorner(n, n) += P0i;
  h.head(n) += P0i * m0;
  for (int k = 1; k <= T; ++k) {
    // (x_k - A x_{k-1})^T Q^{-1} (x_k - A x_{k-1})
    J.block(n * k, n * k, n, n) += Qi;
    J.block(n * (k - 1), n * (k - 1), n, n) += s.A.transpose() * Qi * s.A;
    J.block(n * k, n * (k - 1), n, n) -= Qi * s.A;
    J.block(n * (k - 1), n * k, n, n) -= s.A.transpose() * Qi;
    if (!std::isnan(y(k - 1, 0))) {
      J.block(n * k, n * k, n, n) += s.C.transpose() * Ri * s.C;
      h.segment(n * k, n) += s.C.transpose() * Ri * y.row(k - 1).transpose();
    }
  }
  const MatrixXd cov = J.llt().solve(MatrixXd::Identity(N, N));
  const VectorXd mean = cov * h;
  const SmootherRun sm = RtsSmooth(model, RunFilter(model, y));
  for (int k = 0; k <= T; ++k) {
    EXPECT_MATRICES_NEAR(sm.x.row(k).transpose(), mean.segment(n * k, n), 1e-10) << "k = " << k;
    EXPECT_MATRICES_NEAR(sm.P[static_cast<size_t>(k)], cov.block(n * k, n * k, n, n), 1e-10) << "k = " << k;
  }
  // The last smoothed estimate is the last filtered one.
  const FilterRun run = RunFilter(model, y);
  EXPECT_MATRICES_NEAR(sm.x.row(T), run.x_filt.row(T), 0.0);
  FilterRunOptions no_cov;
  no_cov.store_covariances = false;
  EXPECT_THROW(RtsSmooth(model, RunFilter(model, y, no_cov)), Error);
}

TEST(RtsSmoother, SingularPredictedCovarianceUsesPseudoInverse) {
  // Q = 0 and P0 singular: P_{k+1|k} is singular; the smoother must stay finite and agree with
  // the filter where nothing is learned afterwards about the unexcited direction.
  MatrixXd A = MatrixXd::Identity(2, 2), C(1, 2);
  C << 1, 0;
  MatrixXd P0 = MatrixXd::Zero(2, 2);
  P0(0, 0) = 1.0;
  Model model(MakeStep(A, C, MatrixXd::Zero(2, 2), Scalar(0.5)), VectorXd::Zero(2), P0);
  TimeSeries y(3, 1);
  y << 1.0, 1.2, 0.8;
  const SmootherRun sm = RtsSmooth(model, RunFilter(model, y));
  EXPECT_TRUE(sm.x.allFinite());
  // Constant state seen through three measurements: every smoothed estimate is the posterior mean.
  const double post = (1.0 + 1.2 + 0.8) / (0.5 + 3.0);  // prior var 1, noise var 0.5: mean = sum y / (0.5 + 3)
  for (int k = 0; k <= 3; ++k) EXPECT_NEAR(sm.x(k, 0), post, 1e-12);
}

// The progress hook is also the cancellation hook (include/kfx/progress.hpp): counts in order, and an
// exception thrown by the callback leaves the run unchanged (the Python bindings deliver Ctrl-C this way).
TEST(KalmanFilter, ProgressCountsEveryStepAndAThrowingCallbackStopsTheRun) {
  struct Stop {
    long at;
  };
  Model model(Dwna(1.0, 0.5, 1.0), VectorXd::Zero(2), MatrixXd::Identity(2, 2));
  const TimeSeries y = Simulate(model, SimulationOptions{7, 3}).y;
  std::vector<std::pair<long, long>> seen;
  FilterRunOptions o;
  o.progress = [&](long done, long total) { seen.emplace_back(done, total); };
  const FilterRun run = RunFilter(model, y, o);
  ASSERT_EQ(seen.size(), 7u);
  for (size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], std::make_pair(static_cast<long>(i) + 1, 7L));
  seen.clear();
  SmootherOptions so;
  so.progress = o.progress;
  RtsSmooth(model, run, so);
  ASSERT_EQ(seen.size(), 7u);
  EXPECT_EQ(seen.front(), std::make_pair(1L, 7L));
  EXPECT_EQ(seen.back(), std::make_pair(7L, 7L));
  o.progress = [](long done, long) {
    if (done == 3) throw Stop{done};
  };
  try {
    RunFilter(model, y, o);
    ADD_FAILURE() << "the run did not stop";
  } catch (const Stop& s) {
    EXPECT_EQ(s.at, 3);
  }
}

TEST(KalmanFilter, RunValidatesData) {
  Model model(MakeStep(Scalar(1), Scalar(1), Scalar(1), Scalar(1)), VectorXd::Zero(1), Scalar(1));
  EXPECT_THROW(RunFilter(model, TimeSeries::Zero(3, 2)), Error);
  TimeSeries y = TimeSeries::Zero(3, 1);
  y(1, 0) = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { RunFilter(model, y); }, "row 1"));
}

// Class 10 of docs/robustness.md: the one-step functions check the estimate and the step as a Model
// checks its prior and steps (symmetric PSD within kfx's tolerances), for every form.
TEST(KalmanFilter, StepFunctionsValidateTheEstimateAndTheStep) {
  const ModelStep s = Dwna(1.0, 0.5, 1.0);
  const VectorXd x = VectorXd::Zero(2), y = VectorXd::Ones(1);
  const MatrixXd indefinite = (MatrixXd(2, 2) << 1, 2, 2, 1).finished();  // eigenvalues 3, -1
  const MatrixXd asymmetric = (MatrixXd(2, 2) << 1, 0.5, 0, 1).finished();
  for (const FilterForm form : EnumValues<FilterForm>::kAll) {
    KalmanFilterOptions o;
    o.form = form;
    SCOPED_TRACE(ToString(form));
    EXPECT_TRUE(testing::ThrowsErrorStartingWith(
        [&] {
          Predict({x, indefinite}, s, o);
        },
        "estimate.P:", {"semidefinite"}));
    EXPECT_TRUE(testing::ThrowsErrorStartingWith(
        [&] {
          Update({x, indefinite}, s, y, o);
        },
        "prior.P:", {"semidefinite"}));
    EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { Update({x, asymmetric}, s, y, o); }, "prior.P:", {"symmetric"}));
    EXPECT_TRUE(testing::ThrowsErrorStartingWith(
        [&] {
          Predict({VectorXd::Constant(2, kNaN), MatrixXd::Identity(2, 2)}, s, o);
        },
        "estimate.x:"));
    // A step that was never validated: indefinite Q, R not positive definite.
    ModelStep bad = s;
    bad.Q = indefinite;
    bad.B.resize(0, 0);
    bad.U.resize(0, 0);
    EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { Predict({x, MatrixXd::Identity(2, 2)}, bad, o); }, "step.Q:"));
    bad = s;
    bad.R = Scalar(-1.0);
    EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { Update({x, MatrixXd::Identity(2, 2)}, bad, y, o); }, "step.R:"));
    // Within the tolerance (a rounding-level negative eigenvalue of -1e-14 on a unit scale) it is accepted.
    // (The information form needs P > 0 and says so itself.)
    const MatrixXd psd_rounded = (MatrixXd(2, 2) << 1, 1, 1, 1 - 1e-14).finished();
    if (form != FilterForm::kInformation) {
      EXPECT_NO_THROW(Predict({x, psd_rounded}, s, o));
    }
  }
}

// SteadyStateDare: without S the plain filter DARE; with S (kfx's pairing) the limit of the Kalman
// schedule (the correlated update, an independent recursion) and the fixed point of its Riccati map.
TEST(SteadyStateDare, WithoutSIsTheFilterDareAndWithSIsTheLimitOfTheCorrelatedSchedule) {
  testing::TestRng rng(2212);
  const Eigen::Index n = 4, m = 2;
  const MatrixXd L = rng.Gaussian(n + m, n + m);
  MatrixXd J = L * L.transpose();
  J.diagonal().array() += 0.1;
  const MatrixXd C = rng.Gaussian(m, n);
  const MatrixXd A = rng.WithSpectralRadius(n, 0.9);
  ModelStep plain = MakeStep(A, C, J.topLeftCorner(n, n), J.bottomRightCorner(m, m));
  const DareSolution d0 = SteadyStateDare(plain);
  const DareSolution ref = SolveFilterDare(plain.A, plain.C, plain.Q, plain.R);
  ASSERT_TRUE(d0.summary.ok());
  EXPECT_EQ(testing::RelativeDifference(d0.P_pred, ref.P_pred), 0.0);
  EXPECT_EQ(testing::RelativeDifference(d0.filter_gain, ref.filter_gain), 0.0);

  ModelStep s = plain;
  s.S = J.topRightCorner(n, m);
  const DareSolution d = SteadyStateDare(s);
  ASSERT_TRUE(d.summary.ok()) << d.summary.BriefReport();
  const Model model(s, VectorXd::Zero(n), MatrixXd::Identity(n, n));
  const KalmanSchedule sch = ComputeKalmanSchedule(model, KalmanScheduleOptions{600});
  EXPECT_LE(testing::RelativeDifference(d.P_pred, sch.P_pred.back()), 1e-10);
  EXPECT_LE(testing::RelativeDifference(d.P_filt, sch.P_filt.back()), 1e-10);
  EXPECT_LE(testing::RelativeDifference(d.filter_gain, sch.filter_gain.back()), 1e-10);
  EXPECT_LE(testing::RelativeDifference(d.predictor_gain, MatrixXd(A * sch.filter_gain.back())), 1e-10);
  // The fixed point: P = A (P - K W K^T) A^T + Q, K = (P C^T + S) W^{-1}, W = C P C^T + C S + S^T C^T + R.
  const MatrixXd& P = d.P_pred;
  const MatrixXd W = C * P * C.transpose() + C * s.S + s.S.transpose() * C.transpose() + s.R;
  const MatrixXd K = (P * C.transpose() + s.S) * W.inverse();
  const MatrixXd next = A * (P - K * W * K.transpose()) * A.transpose() + s.Q;
  EXPECT_LE(testing::RelativeDifference(next, P), 1e-12);
  EXPECT_LE(testing::RelativeDifference(d.innovation_cov, W), 1e-12);
  // S changes the answer: the DARE without it is another filter.
  EXPECT_GT(testing::RelativeDifference(d.P_pred, ref.P_pred), 1e-3);
}

TEST(SteadyStateDare, NoiseThatCancelsInTheMeasurementIsNamedS) {
  // [[1, -1], [-1, 1]] is PSD and R = 1 is PD, but C w + v = 0: C Q C^T + C S + S^T C^T + R = 0.
  ModelStep s = MakeStep(Scalar(0.5), Scalar(1), Scalar(1), Scalar(1));
  s.S = Scalar(-1);
  EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { SteadyStateDare(s); }, "S:"));
}

}  // namespace
}  // namespace kfx
