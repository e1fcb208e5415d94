// Known inputs (G g, D g) and correlated noise S = E[w_k v_k^T] in the model, the Kalman filter in every
// form, the RTS smoother and the log-likelihood (issue 22). Oracles: the batch (stacked Gaussian) posterior,
// the filter on an augmented state that carries the input, the filter on the equivalent decorrelated model
// (derived independently of the correlated update), a closed form for a driven scalar system, and every
// new validation path.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/simulation.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using testing::ThrowsErrorStartingWith;
const double kNaN = std::numeric_limits<double>::quiet_NaN();

struct NamedForm {
  const char* name;
  FilterForm form;
  CovarianceUpdateForm update;
};
const NamedForm kAll[] = {{"Joseph", FilterForm::kConventional, CovarianceUpdateForm::kJoseph},
                          {"standard", FilterForm::kConventional, CovarianceUpdateForm::kStandard},
                          {"square root", FilterForm::kSquareRoot, CovarianceUpdateForm::kJoseph},
                          {"UD", FilterForm::kUD, CovarianceUpdateForm::kJoseph},
                          {"information", FilterForm::kInformation, CovarianceUpdateForm::kJoseph}};

FilterRunOptions RunOptions(const NamedForm& f) {
  FilterRunOptions o;
  o.filter.form = f.form;
  o.filter.update_form = f.update;
  return o;
}

// A random step with known input (q columns) and, if `cross`, a cross-covariance S with the joint
// covariance [[Q, S], [S^T, R]] positive definite (S = L21-block of a random factor).
ModelStep RandomStep(testing::TestRng& rng, Index n, Index m, Index q, bool cross) {
  const MatrixXd F = rng.Gaussian(n + m, n + m) / std::sqrt(static_cast<double>(n + m));
  MatrixXd joint = F * F.transpose();
  joint.diagonal().array() += 0.1;
  // One draw per statement (C, then A: GCC's former argument order), so that every compiler tests the same system.
  const MatrixXd C = rng.Gaussian(m, n);
  const MatrixXd A = rng.WithSpectralRadius(n, 0.9);
  ModelStep s = MakeStep(A, C, joint.topLeftCorner(n, n), joint.bottomRightCorner(m, m));
  if (cross) s.S = joint.topRightCorner(n, m);
  if (q > 0) {
    s.G = rng.Gaussian(n, q);
    s.D = rng.Gaussian(m, q);
  }
  return s;
}

// The batch posterior: z = (x_0, w_1, v_1, ..., w_T, v_T) is Gaussian; every x_k and y_k is an affine map
// of z. Conditioning on the observed entries of y gives x_{k|k} (first k measurements) and x_{k|T}.
struct Batch {
  std::vector<MatrixXd> L;  // x_k = L_k z + c_k
  std::vector<VectorXd> c;
  MatrixXd M;  // y (stacked, T m) = M z + d
  VectorXd d, mu;
  MatrixXd Sigma;
};

Batch BuildBatch(const std::vector<ModelStep>& steps, const VectorXd& m0, const MatrixXd& P0, const TimeSeries& g) {
  const int T = static_cast<int>(steps.size());
  const Index n = m0.size(), m = steps[0].C.rows(), nz = n + T * (n + m);
  Batch b;
  b.mu = VectorXd::Zero(nz);
  b.mu.head(n) = m0;
  b.Sigma = MatrixXd::Zero(nz, nz);
  b.Sigma.topLeftCorner(n, n) = P0;
  b.M = MatrixXd::Zero(T * m, nz);
  b.d = VectorXd::Zero(T * m);
  MatrixXd L = MatrixXd::Zero(n, nz);
  L.leftCols(n).setIdentity();
  VectorXd c = VectorXd::Zero(n);
  b.L.push_back(L);
  b.c.push_back(c);
  for (int k = 1; k <= T; ++k) {
    const ModelStep& s = steps[static_cast<size_t>(k - 1)];
    const Index off = n + (k - 1) * (n + m);
    MatrixXd joint(n + m, n + m);
    joint << s.Q, (s.S.size() > 0 ? s.S : MatrixXd::Zero(n, m)),
        (s.S.size() > 0 ? MatrixXd(s.S.transpose()) : MatrixXd::Zero(m, n)), s.R;
    b.Sigma.block(off, off, n + m, n + m) = joint;
    const VectorXd gk = g.cols() > 0 ? VectorXd(g.row(k - 1).transpose()) : VectorXd();
    L = s.A * L;
    L.block(0, off, n, n) += MatrixXd::Identity(n, n);
    c = s.A * c;
    if (s.G.size() > 0) c += s.G * gk;
    b.M.middleRows((k - 1) * m, m) = s.C * L;
    b.M.block((k - 1) * m, off + n, m, m) += MatrixXd::Identity(m, m);
    b.d.segment((k - 1) * m, m) = s.C * c;
    if (s.D.size() > 0) b.d.segment((k - 1) * m, m) += s.D * gk;
    b.L.push_back(L);
    b.c.push_back(c);
  }
  return b;
}

// Mean and covariance of x_k given the observed entries of y_1..y_upto; the log-likelihood of them.
void Condition(const Batch& b, const TimeSeries& y, int k, int upto, VectorXd* mean, MatrixXd* cov,
               double* loglik = nullptr) {
  const Index m = y.cols();
  std::vector<Index> o;
  VectorXd yo;
  for (int j = 0; j < upto; ++j)
    for (Index i = 0; i < m; ++i)
      if (!std::isnan(y(j, i))) o.push_back(j * m + i);
  const MatrixXd& L = b.L[static_cast<size_t>(k)];
  if (o.empty()) {  // nothing observed: the prior (no zero-size products: BLAS rejects a zero leading dimension)
    *mean = L * b.mu + b.c[static_cast<size_t>(k)];
    *cov = L * b.Sigma * L.transpose();
    if (loglik) *loglik = 0.0;
    return;
  }
  yo.resize(static_cast<Index>(o.size()));
  for (size_t r = 0; r < o.size(); ++r) yo(static_cast<Index>(r)) = y(o[r] / m, o[r] % m);
  const MatrixXd Mo = b.M(o, Eigen::all);
  const MatrixXd W = Mo * b.Sigma * Mo.transpose();
  const VectorXd resid = yo - Mo * b.mu - b.d(o);
  const MatrixXd cross = b.L[static_cast<size_t>(k)] * b.Sigma * Mo.transpose();
  const Eigen::LLT<MatrixXd> llt(W);
  *mean = b.L[static_cast<size_t>(k)] * b.mu + b.c[static_cast<size_t>(k)] + cross * llt.solve(resid);
  *cov = b.L[static_cast<size_t>(k)] * b.Sigma * b.L[static_cast<size_t>(k)].transpose() -
         cross * llt.solve(cross.transpose());
  if (loglik) {
    const double log_det = 2.0 * MatrixXd(llt.matrixL()).diagonal().array().log().sum();
    *loglik = -0.5 * (static_cast<double>(o.size()) * std::log(2.0 * M_PI) + log_det + resid.dot(llt.solve(resid)));
  }
}

void ExpectBatchAgreement(const std::vector<ModelStep>& steps, const VectorXd& m0, const MatrixXd& P0,
                          const TimeSeries& y, const TimeSeries& g, double tol) {
  const Model model(steps, m0, P0);
  const Batch batch = BuildBatch(steps, m0, P0, g);
  const int T = static_cast<int>(steps.size());
  for (const NamedForm& f : kAll) {
    SCOPED_TRACE(f.name);
    const FilterRun run = RunFilter(model, y, g, RunOptions(f));
    const SmootherRun sm = RtsSmooth(model, run);
    for (int k = 1; k <= T; ++k) {
      SCOPED_TRACE("k = " + std::to_string(k));
      VectorXd mean;
      MatrixXd cov;
      Condition(batch, y, k, k, &mean, &cov);
      EXPECT_MATRICES_NEAR(VectorXd(run.x_filt.row(k).transpose()), mean, tol);
      EXPECT_MATRICES_NEAR(run.P_filt[static_cast<size_t>(k)], cov, tol);
      Condition(batch, y, k, k - 1, &mean, &cov);
      EXPECT_MATRICES_NEAR(VectorXd(run.x_pred.row(k).transpose()), mean, tol);
      EXPECT_MATRICES_NEAR(run.P_pred[static_cast<size_t>(k)], cov, tol);
    }
    for (int k = 0; k <= T; ++k) {
      SCOPED_TRACE("smoothed k = " + std::to_string(k));
      VectorXd mean;
      MatrixXd cov;
      Condition(batch, y, k, T, &mean, &cov);
      EXPECT_MATRICES_NEAR(VectorXd(sm.x.row(k).transpose()), mean, tol);
      EXPECT_MATRICES_NEAR(sm.P[static_cast<size_t>(k)], cov, tol);
    }
    VectorXd mean;
    MatrixXd cov;
    double loglik = 0.0;
    Condition(batch, y, T, T, &mean, &cov, &loglik);
    EXPECT_NEAR(run.log_likelihood, loglik, tol * std::abs(loglik));
  }
}

struct Case {
  Index q;
  bool cross;
  bool missing;
};

TEST(KnownInputAndCrossCovariance, FilterSmootherAndLikelihoodEqualBatchPosterior) {
  const Case cases[] = {{0, true, false}, {2, false, false}, {2, true, false}, {1, true, true}};
  unsigned seed = 3;
  for (const Case& c : cases) {
    SCOPED_TRACE("q = " + std::to_string(c.q) + (c.cross ? ", S" : ", no S") + (c.missing ? ", missing" : ""));
    const Index n = 3, m = 2;
    const int T = 6;
    testing::TestRng rng(seed++);
    std::vector<ModelStep> steps;
    for (int k = 0; k < T; ++k) steps.push_back(RandomStep(rng, n, m, c.q, c.cross));  // time-varying
    const VectorXd m0 = rng.Gaussian(n, 1);
    const MatrixXd P0 = rng.Spd(n, 0.5);
    TimeSeries g = rng.Gaussian(T, c.q);
    TimeSeries y = rng.Gaussian(T, m);
    if (c.missing) {
      y(1, 0) = kNaN;
      y.row(3).setConstant(kNaN);
      y(5, 1) = kNaN;
    }
    ExpectBatchAgreement(steps, m0, P0, y, g, 1e-9);
  }
}

// The known input against the filter on the augmented state xi_k = [x_k; 1]: A_k' = [[A, G g_k], [0, 1]],
// C_k' = [C, D g_k], Q' = blkdiag(Q, 0), P0' = blkdiag(P0, 0): the input as a state known exactly.
TEST(KnownInput, EqualsFilterOnAugmentedState) {
  const Index n = 4, m = 2, q = 3;
  const int T = 40;
  testing::TestRng rng(21);
  const ModelStep s = RandomStep(rng, n, m, q, false);
  const VectorXd m0 = rng.Gaussian(n, 1);
  const MatrixXd P0 = rng.Spd(n, 0.5);
  const Model model(s, m0, P0);
  const TimeSeries g = rng.Gaussian(T, q);
  const TimeSeries y = Simulate(model, g, SimulationOptions{T, 5}).y;
  std::vector<ModelStep> aug;
  for (int k = 1; k <= T; ++k) {
    const VectorXd gk = g.row(k - 1).transpose();
    MatrixXd A = MatrixXd::Zero(n + 1, n + 1), C(m, n + 1), Q = MatrixXd::Zero(n + 1, n + 1);
    A.topLeftCorner(n, n) = s.A;
    A.topRightCorner(n, 1) = s.G * gk;
    A(n, n) = 1.0;
    C << s.C, s.D * gk;
    Q.topLeftCorner(n, n) = s.Q;
    aug.push_back(MakeStep(A, C, Q, s.R));
  }
  VectorXd am0(n + 1);
  am0 << m0, 1.0;
  MatrixXd aP0 = MatrixXd::Zero(n + 1, n + 1);
  aP0.topLeftCorner(n, n) = P0;
  const Model augmented(aug, am0, aP0);
  const FilterRun ref = RunFilter(augmented, y);
  const SmootherRun ref_sm = RtsSmooth(augmented, ref);
  for (const NamedForm& f : kAll) {
    SCOPED_TRACE(f.name);
    const FilterRun run = RunFilter(model, y, g, RunOptions(f));
    EXPECT_MATRICES_NEAR(MatrixXd(run.x_filt), MatrixXd(ref.x_filt.leftCols(n)), 1e-9);
    EXPECT_MATRICES_NEAR(run.P_filt[static_cast<size_t>(T)], ref.P_filt[static_cast<size_t>(T)].topLeftCorner(n, n),
                         1e-9);
    EXPECT_NEAR(run.log_likelihood, ref.log_likelihood, 1e-9 * std::abs(ref.log_likelihood));
    const SmootherRun sm = RtsSmooth(model, run);
    EXPECT_MATRICES_NEAR(MatrixXd(sm.x), MatrixXd(ref_sm.x.leftCols(n)), 1e-8);
  }
  // The steady-state fast path keeps the input in the prediction.
  FilterRunOptions fast;
  fast.steady_state_tolerance = 1e-12;
  const FilterRun frozen = RunFilter(model, y, g, fast);
  EXPECT_GT(frozen.steady_state_steps, 0);
  EXPECT_MATRICES_NEAR(MatrixXd(frozen.x_filt), MatrixXd(ref.x_filt.leftCols(n)), 1e-8);
}

// The cross term against the equivalent model without it. With Sigma = S R^{-1}, M = I + C Sigma (invertible
// here), the state xc_k = x_k - Sigma v_k is uncorrelated with v_k and
//   xc_k = (A - A Sigma M^{-1} C) xc_{k-1} + G g_k + A Sigma M^{-1} (y_{k-1} - D g_{k-1}) + w'_k   (k >= 2;
//   xc_1 = A x_0 + G g_1 + w'_1),  cov w'_k = Q - Sigma S^T,
//   y_k = C xc_k + D g_k + M v_k,  cov M v_k = M R M^T,
// so y_{k-1} and g_{k-1} are known inputs of a decorrelated model; then
//   x_{k|k} = xc_{k|k} + Sigma M^{-1} (y_k - D g_k - C xc_{k|k}),  P_{k|k} = N Pc_{k|k} N^T,  N = I - Sigma M^{-1} C.
TEST(CrossCovariance, EqualsFilterOnEquivalentDecorrelatedModel) {
  const Index n = 4, m = 2, q = 1;
  const int T = 30;
  testing::TestRng rng(31);
  const ModelStep s = RandomStep(rng, n, m, q, true);
  const VectorXd m0 = rng.Gaussian(n, 1);
  const MatrixXd P0 = rng.Spd(n, 0.5);
  const Model model(s, m0, P0);
  const TimeSeries g = rng.Gaussian(T, q);
  const TimeSeries y = Simulate(model, g, SimulationOptions{T, 9}).y;
  const MatrixXd Sigma = s.R.llt().solve(s.S.transpose()).transpose();
  const MatrixXd Mm = MatrixXd::Identity(m, m) + s.C * Sigma;
  const MatrixXd SMi = Sigma * Mm.inverse();  // test code: M is 2 x 2 and well conditioned
  const MatrixXd Qd = s.Q - Sigma * s.S.transpose();
  const MatrixXd Rd = Mm * s.R * Mm.transpose();
  std::vector<ModelStep> dec;
  TimeSeries gd = TimeSeries::Zero(T, 2 * q + m);  // [g_k, g_{k-1}, y_{k-1}]
  for (int k = 1; k <= T; ++k) {
    ModelStep d = MakeStep(k == 1 ? s.A : MatrixXd(s.A - s.A * SMi * s.C), s.C, Qd, Rd);
    d.G = MatrixXd::Zero(n, 2 * q + m);
    d.G.leftCols(q) = s.G;
    if (k > 1) {
      d.G.middleCols(q, q) = -s.A * SMi * s.D;
      d.G.rightCols(m) = s.A * SMi;
      gd.row(k - 1).segment(q, q) = g.row(k - 2);
      gd.row(k - 1).tail(m) = y.row(k - 2);
    }
    gd.row(k - 1).head(q) = g.row(k - 1);
    d.D = MatrixXd::Zero(m, 2 * q + m);
    d.D.leftCols(q) = s.D;
    dec.push_back(d);
  }
  const FilterRun ref = RunFilter(Model(dec, m0, P0), y, gd);
  const MatrixXd N = MatrixXd::Identity(n, n) - SMi * s.C;
  for (const NamedForm& f : kAll) {
    SCOPED_TRACE(f.name);
    const FilterRun run = RunFilter(model, y, g, RunOptions(f));
    for (int k = 1; k <= T; ++k) {
      const VectorXd xc = ref.x_filt.row(k).transpose();
      const VectorXd x = xc + SMi * (y.row(k - 1).transpose() - s.D * g.row(k - 1).transpose() - s.C * xc);
      ASSERT_MATRICES_NEAR(VectorXd(run.x_filt.row(k).transpose()), x, 1e-9);
      ASSERT_MATRICES_NEAR(run.P_filt[static_cast<size_t>(k)], N * ref.P_filt[static_cast<size_t>(k)] * N.transpose(),
                           1e-9);
    }
    EXPECT_NEAR(run.log_likelihood, ref.log_likelihood, 1e-9 * std::abs(ref.log_likelihood));
  }
}

// A driven scalar system with an exactly known state (P0 = 0, Q = 0): x_k = a x_{k-1} + b g_k, so
// x_{k|k} = a^k m0 + sum_j a^{k-j} b g_j with P_{k|k} = 0, and the innovation is y_k - x_k - d g_k = v_k;
// the simulated state is the same closed form.
TEST(KnownInput, DrivenScalarSystemClosedForm) {
  const double a = 0.9, b = 2.0, d = 0.5, m0 = 1.5;
  ModelStep s =
      MakeStep(MatrixXd::Constant(1, 1, a), MatrixXd::Ones(1, 1), MatrixXd::Zero(1, 1), MatrixXd::Constant(1, 1, 0.25));
  s.G = MatrixXd::Constant(1, 1, b);
  s.D = MatrixXd::Constant(1, 1, d);
  const Model model(s, VectorXd::Constant(1, m0), MatrixXd::Zero(1, 1));
  const int T = 25;
  TimeSeries g(T, 1);
  for (int k = 1; k <= T; ++k) g(k - 1, 0) = std::sin(0.3 * k);
  const Trajectory tr = Simulate(model, g, SimulationOptions{T, 4});
  const FilterRun run = RunFilter(model, tr.y, g);
  double x = m0;
  for (int k = 1; k <= T; ++k) {
    x = a * x + b * g(k - 1, 0);
    EXPECT_NEAR(tr.x(k, 0), x, 1e-12 * std::abs(x) + 1e-14);
    EXPECT_NEAR(run.x_filt(k, 0), x, 1e-12 * std::abs(x) + 1e-14);
    EXPECT_NEAR(run.innovations(k - 1, 0), tr.y(k - 1, 0) - x - d * g(k - 1, 0), 1e-12);
    EXPECT_EQ(run.P_filt[static_cast<size_t>(k)](0, 0), 0.0);
  }
}

// Simulation with S: the sample cross-covariance of (w_k, v_k) is S within 4 standard errors.
TEST(CrossCovariance, SimulationDrawsTheJointNoise) {
  testing::TestRng rng(41);
  const Index n = 2, m = 2;
  const ModelStep s = RandomStep(rng, n, m, 0, true);
  const Model model(s, VectorXd::Zero(n), MatrixXd::Zero(n, n));
  const int T = 40000;
  const Trajectory tr = Simulate(model, SimulationOptions{T, 17});
  MatrixXd sum = MatrixXd::Zero(n, m), sum_sq = MatrixXd::Zero(n, m);
  for (int k = 1; k <= T; ++k) {
    const VectorXd w = tr.x.row(k).transpose() - s.A * tr.x.row(k - 1).transpose();
    const VectorXd v = tr.y.row(k - 1).transpose() - s.C * tr.x.row(k).transpose();
    const MatrixXd wv = w * v.transpose();
    sum += wv;
    sum_sq += wv.cwiseProduct(wv);
  }
  const MatrixXd mean = sum / T;
  const MatrixXd se = ((sum_sq / T - mean.cwiseProduct(mean)) / T).cwiseSqrt();
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < m; ++j) EXPECT_LT(std::abs(mean(i, j) - s.S(i, j)), 4.0 * se(i, j)) << i << "," << j;
}

// Invalid input, one test per class: each throws kfx::Error whose message starts with the argument.
class InvalidKnownInput : public ::testing::Test {
 protected:
  ModelStep With(void (*change)(ModelStep&)) const {
    ModelStep s = good_;
    change(s);
    return s;
  }
  // n = 3, m = 2, q = 2, S given.
  ModelStep good_ = [] {
    testing::TestRng rng(51);
    return RandomStep(rng, 3, 2, 2, true);
  }();
  VectorXd m0_ = VectorXd::Zero(3);
  MatrixXd P0_ = MatrixXd::Identity(3, 3);
};

TEST_F(InvalidKnownInput, WrongShapeOrNonFiniteG) {
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Model(With([](ModelStep& s) { s.G = MatrixXd::Ones(2, 2); }), m0_, P0_); },
                                      "G:", {"3"}));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Model(With([](ModelStep& s) { s.G(0, 0) = kNaN; }), m0_, P0_); }, "G:"));
  // A q that changes from step to step.
  EXPECT_TRUE(ThrowsErrorStartingWith(
      [&] {
        Model({good_, With([](ModelStep& s) { s.G = MatrixXd::Ones(3, 1), s.D = MatrixXd::Ones(2, 1); })}, m0_, P0_);
      },
      "step 2: G:", {"q = 2"}));
}

TEST_F(InvalidKnownInput, WrongShapeOrNonFiniteD) {
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Model(With([](ModelStep& s) { s.D = MatrixXd::Ones(3, 2); }), m0_, P0_); },
                                      "D:"));  // rows != m
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Model(With([](ModelStep& s) { s.D = MatrixXd::Ones(2, 3); }), m0_, P0_); },
                                      "D:"));  // columns != G's q
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Model(With([](ModelStep& s) { s.D(1, 0) = kNaN; }), m0_, P0_); }, "D:"));
}

TEST_F(InvalidKnownInput, WrongShapeOrNonFiniteS) {
  EXPECT_TRUE(
      ThrowsErrorStartingWith([&] { Model(With([](ModelStep& s) { s.S = MatrixXd::Zero(2, 3); }), m0_, P0_); }, "S:"));
  EXPECT_TRUE(
      ThrowsErrorStartingWith([&] { Model(With([](ModelStep& s) { s.S = MatrixXd::Zero(3, 3); }), m0_, P0_); }, "S:"));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Model(With([](ModelStep& s) { s.S(1, 1) = kNaN; }), m0_, P0_); }, "S:"));
}

TEST_F(InvalidKnownInput, JointCovarianceNotPositiveSemidefinite) {
  // Q and R alone are fine; [[Q, S], [S^T, R]] is not PSD.
  EXPECT_TRUE(
      ThrowsErrorStartingWith([&] { Model(With([](ModelStep& s) { s.S = 10.0 * MatrixXd::Ones(3, 2); }), m0_, P0_); },
                              "S (the joint covariance [[Q, S], [S^T, R]])"));
  // The limit case |S| = sqrt(Q R) of a scalar model is PSD and accepted.
  ModelStep edge = MakeStep(MatrixXd::Constant(1, 1, 0.5), MatrixXd::Ones(1, 1), MatrixXd::Constant(1, 1, 4.0),
                            MatrixXd::Ones(1, 1));
  edge.S = MatrixXd::Constant(1, 1, 2.0);
  EXPECT_NO_THROW(Model(edge, VectorXd::Zero(1), MatrixXd::Identity(1, 1)));
  edge.S(0, 0) = 2.01;
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Model(edge, VectorXd::Zero(1), MatrixXd::Identity(1, 1)); }, "S"));
}

TEST_F(InvalidKnownInput, WrongShapeOrNonFiniteKnownInputSeries) {
  const Model model(good_, m0_, P0_);
  const TimeSeries y = TimeSeries::Zero(5, 2);
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { RunFilter(model, y); }, "g:"));  // the model has an input: g required
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { RunFilter(model, y, TimeSeries::Zero(5, 3)); }, "g:"));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { RunFilter(model, y, TimeSeries::Zero(4, 2)); }, "g:"));
  TimeSeries g_nan = TimeSeries::Zero(5, 2);
  g_nan(2, 1) = kNaN;
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { RunFilter(model, y, g_nan); }, "g:"));
  const Model plain(MakeStep(good_.A, good_.C, good_.Q, good_.R), m0_, P0_);
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { RunFilter(plain, y, TimeSeries::Zero(5, 2)); }, "g:"));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Simulate(model, SimulationOptions{5, 1}); }, "g:"));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Simulate(model, TimeSeries::Zero(5, 1), SimulationOptions{5, 1}); }, "g:"));
}

// The single-step API (Predict / Update with g, the KalmanFilter class) against RunFilter on a time-varying
// model with G, D, S and missing values, in every form: the same code, so the same numbers to rounding.
TEST(SingleSteps, EqualRunFilterWithKnownInputCrossCovarianceAndMissingValues) {
  const Index n = 3, m = 2, q = 2;
  const int T = 8;
  testing::TestRng rng(61);
  std::vector<ModelStep> steps;
  for (int k = 0; k < T; ++k) steps.push_back(RandomStep(rng, n, m, q, true));
  const VectorXd m0 = rng.Gaussian(n, 1);
  const MatrixXd P0 = rng.Spd(n, 0.5);
  const Model model(steps, m0, P0);
  const TimeSeries g = rng.Gaussian(T, q);
  TimeSeries y = rng.Gaussian(T, m);
  y(2, 1) = kNaN;
  y.row(5).setConstant(kNaN);
  for (const NamedForm& f : kAll) {
    SCOPED_TRACE(f.name);
    FilterRunOptions o = RunOptions(f);
    o.store_covariances = true;
    const FilterRun run = RunFilter(model, y, g, o);
    Estimate e{m0, P0};
    KalmanFilter kf(model, o.filter);
    double log_likelihood = 0.0;
    for (int k = 1; k <= T; ++k) {
      const ModelStep& s = steps[static_cast<size_t>(k - 1)];
      const VectorXd gk = g.row(k - 1).transpose();
      const VectorXd yk = y.row(k - 1).transpose();
      const Estimate prior = Predict(e, s, gk, o.filter);
      EXPECT_MATRICES_NEAR(prior.x, run.x_pred.row(k).transpose(), 1e-12);
      EXPECT_MATRICES_NEAR(prior.P, run.P_pred[static_cast<size_t>(k)], 1e-12);
      const UpdateResult r = Update(prior, s, yk, gk, o.filter);
      e = r.estimate;
      log_likelihood += r.log_likelihood;
      EXPECT_MATRICES_NEAR(e.x, run.x_filt.row(k).transpose(), 1e-12);
      EXPECT_MATRICES_NEAR(e.P, run.P_filt[static_cast<size_t>(k)], 1e-12);
      EXPECT_NEAR(r.log_likelihood, run.log_likelihood_terms(k - 1), 1e-12);
      const UpdateResult c = kf.Step(yk, gk);
      EXPECT_MATRICES_NEAR(c.estimate.x, e.x, 1e-12);
      EXPECT_MATRICES_NEAR(c.estimate.P, e.P, 1e-12);
    }
    EXPECT_NEAR(log_likelihood, run.log_likelihood, 1e-12);
  }
}

TEST_F(InvalidKnownInput, SingleStepsNameG) {
  const Estimate e{m0_, P0_};
  const VectorXd y = VectorXd::Zero(2);
  const VectorXd g = VectorXd::Ones(2);
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Predict(e, good_); }, "g:", {"length 2", "none"}));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Update(e, good_, y); }, "g:"));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Predict(e, good_, VectorXd::Ones(3)); }, "g:", {"length 3"}));
  VectorXd g_nan = g;
  g_nan(1) = kNaN;
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Update(e, good_, y, g_nan); }, "g:"));
  const ModelStep plain = MakeStep(good_.A, good_.C, good_.Q, good_.R);
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Predict(e, plain, g); }, "g:", {"no known input"}));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Update(e, plain, y, g); }, "g:"));
  EXPECT_NO_THROW(Update(e, plain, y, VectorXd()));
  KalmanFilter kf(Model(good_, m0_, P0_));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { kf.Predict(); }, "g:"));
  EXPECT_EQ(kf.k(), 0);  // nothing changed
  kf.Predict(g);
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { kf.Update(y); }, "g:"));
  EXPECT_NO_THROW(kf.Update(y, g));
}

}  // namespace
}  // namespace kfx
