// Filters built on a wrong model (paper 002): the exact true error by 002's recursions (15)-(19),
// time-varying and stationary, with the truth's S and a known input (issue 22), and error ranges. The bounds
// of Theorems 1-6 are in mismatch_bounds.cpp, the error-box search in mismatch_search.cpp. API and
// equations: include/kfx/mismatch.hpp.
#include "kfx/mismatch.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/riccati.hpp"
#include "kfx/validation.hpp"
#include "methods/mismatch/mismatch_internal.hpp"

extern "C" {
/// SLICOT SB04QD: the discrete-time Sylvester equation X + A X B = C (N x N A, M x M B, N x M C
/// overwritten by X) by the Hessenberg-Schur method. iwork: 4N; ldwork >= max(1, 2N^2 + 9N, 5M, N + M).
/// info: 0 ok, 1..M QR of B failed, > M a singular system (some a_i b_j = -1). Conventions as in
/// src/base/lapack_fortran.hpp (gfortran, by reference, column-major).
void sb04qd_(const int* n, const int* m, double* a, const int* lda, double* b, const int* ldb, double* c,
             const int* ldc, double* z, const int* ldz, int* iwork, double* dwork, const int* ldwork, int* info);
}

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace detail {

double SpectralNorm(const Eigen::Ref<const MatrixXd>& m) {
  if (m.size() == 0) return 0.0;
  return Eigen::JacobiSVD<MatrixXd>(m).singularValues()(0);
}

void NoiseInputOf(const ModelStep& step, MatrixXd* G, MatrixXd* noise_cov) {
  if (step.B.size() > 0) {
    *G = step.B;
    *noise_cov = step.U;
  } else {
    *G = MatrixXd::Identity(step.A.rows(), step.A.rows());
    *noise_cov = step.Q;
  }
}

void ValidateDesignStep(const ModelStep& step, const std::string& label) {
  RequireSquare(label + "A", step.A);
  ValidateStep(step, step.A.rows(), step.C.rows(), label);
}

bool ResolveFilterGain(const ModelStep& design, const MismatchOptions& options, MatrixXd* gain, Summary* summary) {
  if (options.filter_gain.size() > 0) {
    RequireShape("options.filter_gain", options.filter_gain, design.A.rows(), design.C.rows());
    RequireFinite("options.filter_gain", options.filter_gain);
    *gain = options.filter_gain;
    return true;
  }
  // With the design's S, the steady-state gain of its correlated filter (SteadyStateDare); without S that is
  // SolveFilterDare(A, C, Q, R), 002's filter.
  const DareSolution dare = SteadyStateDare(design);
  if (!dare.summary.ok()) {
    AdoptOutcome(dare.summary, summary);
    summary->message = "design " + summary->message;
    return false;
  }
  *gain = dare.filter_gain;
  return true;
}

bool SolveStein(const MatrixXd& A, const MatrixXd& Q, const std::string& what, MatrixXd* X, Summary* summary) {
  LyapunovSolution sol = SolveDiscreteLyapunov(A, Q);
  if (!sol.summary.ok()) {
    AdoptOutcome(sol.summary, summary);
    summary->message = what + ": " + summary->message;
    return false;
  }
  *X = std::move(sol.X);
  return true;
}

void FinishSummary(const char* computation, std::chrono::steady_clock::time_point start, Summary* summary) {
  summary->computation = computation;
  summary->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

MatrixXd OrZeros(const MatrixXd& e, Index rows, Index cols) { return e.size() == 0 ? MatrixXd::Zero(rows, cols) : e; }

}  // namespace detail

namespace {

constexpr double kTiny = std::numeric_limits<double>::min();

double RelativeResidual(const MatrixXd& lhs, const MatrixXd& rhs) {
  return (lhs - rhs).norm() / std::max(lhs.norm(), kTiny);
}

/// X + a X b = c by SLICOT SB04QD; returns info (0 ok).
int SolveSylvesterSb04qd(const MatrixXd& a, const MatrixXd& b, const MatrixXd& c, MatrixXd* x) {
  const int n = static_cast<int>(a.rows()), m = static_cast<int>(b.rows());
  MatrixXd aw = a, bw = b;
  *x = c;
  MatrixXd z(std::max(m, 1), std::max(m, 1));
  std::vector<int> iwork(static_cast<size_t>(std::max(1, 4 * n)));
  const int ldwork = std::max({1, 2 * n * n + 9 * n, 5 * m, n + m}) + 64 * (n + m);
  std::vector<double> dwork(static_cast<size_t>(ldwork));
  const int lda = std::max(1, n), ldb = std::max(1, m), ldz = std::max(1, m);
  int info = 0;
  sb04qd_(&n, &m, aw.data(), &lda, bw.data(), &ldb, x->data(), &lda, z.data(), &ldz, iwork.data(), dwork.data(),
          &ldwork, &info);
  return info;
}

void CheckSameDimensions(const ModelStep& design, const ModelStep& truth) {
  if (truth.A.rows() != design.A.rows() || truth.C.rows() != design.C.rows()) {
    throw Error("truth: expected the design's dimensions (n = " + std::to_string(design.A.rows()) +
                ", m = " + std::to_string(design.C.rows()) + "), got n = " + std::to_string(truth.A.rows()) +
                ", m = " + std::to_string(truth.C.rows()));
  }
}

// G g and D g of a step (zeros where it has no G, D), for a g that has been checked against the step.
struct InputEffect {
  VectorXd state, measurement;
};
InputEffect EffectOf(const ModelStep& s, const Eigen::Ref<const VectorXd>& g) {
  InputEffect e{VectorXd::Zero(s.A.rows()), VectorXd::Zero(s.C.rows())};
  if (s.G.size() > 0) e.state.noalias() = s.G * g;
  if (s.D.size() > 0) e.measurement.noalias() = s.D * g;
  return e;
}

// The error's input term b = L G_M g - (L + K dC) G_t g + K (D_t - D_M) g (kfx/mismatch.hpp).
VectorXd InputTerm(const MatrixXd& L, const MatrixXd& LK, const MatrixXd& K, const InputEffect& design,
                   const InputEffect& truth) {
  VectorXd b = L * design.state - LK * truth.state;
  b.noalias() += K * (truth.measurement - design.measurement);
  return b;
}

// The constant input of the stationary analysis: of length q when design or truth has G or D, none otherwise.
void RequireStationaryInput(const ModelStep& design, const ModelStep& truth, const VectorXd& g) {
  if (!design.has_known_input() && !truth.has_known_input()) {
    if (g.size() > 0) {
      throw Error("options.input: expected none (neither design nor truth has G or D), got length " +
                  std::to_string(g.size()));
    }
    return;
  }
  for (const ModelStep* s : {&design, &truth}) {
    if (s->has_known_input() && g.size() != s->input_dim()) {
      throw Error("options.input: expected the constant known input g of length " + std::to_string(s->input_dim()) +
                  " (the " + (s == &design ? "design" : "truth") + "'s G, D), got " +
                  (g.size() == 0 ? std::string("none") : "length " + std::to_string(g.size())));
    }
  }
}

// -(L + K dC) S_t K^T and its transpose: the truth's cross-covariance in the error's noise (zero without S).
MatrixXd CrossNoiseTerm(const MatrixXd& LK, const MatrixXd& K, const ModelStep& truth) {
  if (!truth.has_cross_covariance()) return MatrixXd::Zero(LK.rows(), LK.rows());
  MatrixXd H = LK * truth.S * K.transpose();
  return -(H + H.transpose());
}

}  // namespace

// ---- errors ------------------------------------------------------------------------------------

ModelStep ApplyModelingErrors(const ModelStep& design, const ModelingErrors& errors) {
  detail::ValidateDesignStep(design, "design: ");
  const Index n = design.A.rows(), m = design.C.rows();
  MatrixXd G, noise_cov;
  detail::NoiseInputOf(design, &G, &noise_cov);
  const Index p = noise_cov.rows();
  auto check = [](const std::string& name, const MatrixXd& e, Index r, Index c, bool symmetric) {
    if (e.size() == 0) return;
    RequireShape(name, e, r, c);
    RequireFinite(name, e);
    if (symmetric) RequireSymmetric(name, e);
  };
  check("errors.A", errors.A, n, n, false);
  check("errors.C", errors.C, m, n, false);
  check("errors.Q", errors.Q, p, p, true);
  check("errors.R", errors.R, m, m, true);
  check("errors.S", errors.S, n, m, false);
  const MatrixXd A = design.A - detail::OrZeros(errors.A, n, n);
  const MatrixXd C = design.C - detail::OrZeros(errors.C, m, n);
  MatrixXd R = design.R - detail::OrZeros(errors.R, m, m);
  Symmetrize(R);
  MatrixXd W = noise_cov - detail::OrZeros(errors.Q, p, p);
  Symmetrize(W);
  ModelStep truth = design.B.size() > 0 ? MakeStepWithNoiseInput(A, design.B, W, C, R) : MakeStep(A, C, W, R);
  if (design.has_cross_covariance() || errors.S.size() > 0) {
    truth.S = detail::OrZeros(design.S, n, m) - detail::OrZeros(errors.S, n, m);
  }
  truth.G = design.G;
  truth.D = design.D;
  try {
    ValidateStep(truth, n, m, "");
  } catch (const Error& e) {
    throw Error(std::string("errors: the true step (design minus errors) is invalid: ") + e.what());
  }
  return truth;
}

ModelingErrors ModelingErrorsBetween(const ModelStep& design, const ModelStep& truth) {
  detail::ValidateDesignStep(design, "design: ");
  detail::ValidateDesignStep(truth, "truth: ");
  CheckSameDimensions(design, truth);
  ModelingErrors e;
  e.A = design.A - truth.A;
  e.C = design.C - truth.C;
  e.R = design.R - truth.R;
  if (design.B.size() > 0 || truth.B.size() > 0) {
    if (design.B.size() == 0 || truth.B.size() == 0 || design.B.cols() != truth.B.cols() ||
        (design.B - truth.B).cwiseAbs().maxCoeff() > 0.0) {
      throw Error("truth: expected the design's noise input B (002's G is common to model and truth)");
    }
    e.Q = design.U - truth.U;
  } else {
    e.Q = design.Q - truth.Q;
  }
  if (design.has_cross_covariance() || truth.has_cross_covariance()) {
    const Index n = design.A.rows(), m = design.C.rows();
    e.S = detail::OrZeros(design.S, n, m) - detail::OrZeros(truth.S, n, m);
  }
  return e;
}

// ---- exact true error --------------------------------------------------------------------------

bool MismatchOptions::IsValid(std::string* error) const {
  if (filter_gain.size() > 0 && !filter_gain.allFinite()) {
    if (error) *error = "filter_gain: expected finite entries";
    return false;
  }
  if (input.size() > 0 && !input.allFinite()) {
    if (error) *error = "input: expected finite entries (a known input has no missing values)";
    return false;
  }
  return true;
}

StationaryMismatch StationaryMismatchedCovariance(const ModelStep& design, const ModelStep& truth,
                                                  const MismatchOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  detail::ValidateDesignStep(design, "design: ");
  detail::ValidateDesignStep(truth, "truth: ");
  CheckSameDimensions(design, truth);
  RequireStationaryInput(design, truth, options.input);
  const Index n = design.A.rows();
  StationaryMismatch out;
  Summary& sum = out.summary;
  sum.method = "Lyapunov (17), Sylvester (16), Lyapunov (15)";
  const auto finish = [&]() {
    detail::FinishSummary("stationary mismatched covariance", start, &sum);
    return std::move(out);
  };
  if (!detail::ResolveFilterGain(design, options, &out.filter_gain, &sum)) return finish();
  const MatrixXd& K = out.filter_gain;
  const MatrixXd& A = truth.A;
  const MatrixXd& AM = design.A;
  const MatrixXd I = MatrixXd::Identity(n, n);
  const MatrixXd dA = AM - A;
  const MatrixXd dC = design.C - truth.C;
  const MatrixXd L = I - K * design.C;                      // (18)
  const MatrixXd F = L * AM;                                // the filter's transition
  const MatrixXd dCp = L * dA - K * dC * AM + K * dC * dA;  // (19)
  const MatrixXd LK = L + K * dC;                           // = I - K C
  out.true_spectral_radius = SpectralRadius(A);
  out.filter_spectral_radius = SpectralRadius(F);
  if (out.true_spectral_radius >= 1.0) {
    sum.termination = Termination::kUnstable;
    sum.message = "the true system is unstable: rho(A) = " + std::to_string(out.true_spectral_radius) +
                  " >= 1, no stationary U (17)";
    return finish();
  }
  if (out.filter_spectral_radius >= 1.0) {
    sum.termination = Termination::kUnstable;
    sum.message =
        "the filter is unstable: rho(L A_M) = " + std::to_string(out.filter_spectral_radius) + " >= 1, its error grows";
    return finish();
  }
  // (17): U = A U A^T + G Q G^T (central moments first; the means are added at the end).
  if (!detail::SolveStein(A, truth.Q, "(17)", &out.U, &sum)) return finish();
  Symmetrize(out.U);
  // (16): V = A V F^T + A U dC'^T - G Q G^T (L + K dC)^T (+ S_t K^T), i.e. V + (-A) V F^T = rhs.
  MatrixXd rhs_v = A * out.U * dCp.transpose() - truth.Q * LK.transpose();
  if (truth.has_cross_covariance()) rhs_v.noalias() += truth.S * K.transpose();
  const int info = SolveSylvesterSb04qd(-A, F.transpose(), rhs_v, &out.V);
  if (info != 0) {
    sum.termination = Termination::kFailed;
    sum.message = "Sylvester equation (16) (SLICOT SB04QD) failed, info = " + std::to_string(info);
    return finish();
  }
  // (15): P = F P F^T + W (+ the S terms).
  MatrixXd W = dCp * out.V * F.transpose();
  W += W.transpose().eval();
  W += dCp * out.U * dCp.transpose() + LK * truth.Q * LK.transpose() + K * truth.R * K.transpose() +
       CrossNoiseTerm(LK, K, truth);
  Symmetrize(W);
  if (!detail::SolveStein(F, W, "(15)", &out.P, &sum)) return finish();
  Symmetrize(out.P);
  sum.relative_residual = std::max({RelativeResidual(out.U, A * out.U * A.transpose() + truth.Q),
                                    RelativeResidual(out.V, A * out.V * F.transpose() + rhs_v),
                                    RelativeResidual(out.P, F * out.P * F.transpose() + W)});
  // The means of a constant input: E[x] = A E[x] + G_t g, E[x~] = F E[x~] + dC' E[x] + b.
  out.state_mean = VectorXd::Zero(n);
  out.error_mean = VectorXd::Zero(n);
  if (options.input.size() > 0) {
    const InputEffect ed = EffectOf(design, options.input), et = EffectOf(truth, options.input);
    out.state_mean = (I - A).partialPivLu().solve(et.state);
    out.error_mean = (I - F).partialPivLu().solve(dCp * out.state_mean + InputTerm(L, LK, K, ed, et));
    out.P.noalias() += out.error_mean * out.error_mean.transpose();
    out.V.noalias() += out.state_mean * out.error_mean.transpose();
    out.U.noalias() += out.state_mean * out.state_mean.transpose();
  }
  out.trace = out.P.trace();
  sum.termination = Termination::kConverged;
  sum.message = "rho(A) = " + std::to_string(out.true_spectral_radius) +
                ", rho(L A_M) = " + std::to_string(out.filter_spectral_radius);
  return finish();
}

MismatchSequence MismatchedCovarianceSequence(const Model& design, const Model& truth,
                                              const MismatchSequenceOptions& options) {
  return MismatchedCovarianceSequence(design, truth, TimeSeries(0, 0), options);
}

MismatchSequence MismatchedCovarianceSequence(const Model& design, const Model& truth, const TimeSeries& g,
                                              const MismatchSequenceOptions& options) {
  const int steps = options.steps;
  if (steps < 0) throw Error("options.steps: expected >= 0, got " + std::to_string(steps));
  if (design.state_dim() != truth.state_dim() || design.meas_dim() != truth.meas_dim()) {
    throw Error("truth: expected the design's dimensions (n = " + std::to_string(design.state_dim()) +
                ", m = " + std::to_string(design.meas_dim()) + ")");
  }
  const int T = design.ResolveSteps(steps, "options.steps");
  truth.ResolveSteps(T, "options.steps");
  // g: for every model with G or D (the same q), none when neither has them.
  if (truth.input_dim() > 0 || design.input_dim() == 0) RequireKnownInput(truth, g, T);
  if (design.input_dim() > 0) RequireKnownInput(design, g, T);
  const Index n = design.state_dim();
  const KalmanSchedule schedule = ComputeKalmanSchedule(design, KalmanScheduleOptions{T});
  MismatchSequence out;
  // Central moments and means (kfx/mismatch.hpp); out.P = Pc + mu mu^T etc. With x^_0 = m_M:
  // Uc_0 = P0_t, Vc_0 = Cov(x_0, m_M - x_0) = -P0_t, Pc_0 = P0_t, E[x_0] = m_t, E[x~_0] = m_M - m_t.
  MatrixXd U = truth.P0(), V = -truth.P0(), P = truth.P0();
  VectorXd mx = truth.m0(), mu = design.m0() - truth.m0();
  out.trace.resize(T + 1);
  out.error_mean.resize(T + 1, n);
  out.state_mean.resize(T + 1, n);
  const auto record = [&](int k, MatrixXd K) {
    out.P.push_back(P + mu * mu.transpose());
    out.V.push_back(V + mx * mu.transpose());
    out.U.push_back(U + mx * mx.transpose());
    out.filter_gain.push_back(std::move(K));
    out.trace(k) = out.P.back().trace();
    out.error_mean.row(k) = mu.transpose();
    out.state_mean.row(k) = mx.transpose();
  };
  record(0, MatrixXd());
  const MatrixXd I = MatrixXd::Identity(n, n);
  for (int k = 1; k <= T; ++k) {
    const StepPtr sm = design.step(k);
    const StepPtr st = truth.step(k);
    const MatrixXd& K = schedule.filter_gain[static_cast<size_t>(k)];  // K_M(k+1) of 002's (10)
    const MatrixXd dA = sm->A - st->A;
    const MatrixXd dC = sm->C - st->C;
    const MatrixXd L = I - K * sm->C;
    const MatrixXd F = L * sm->A;
    const MatrixXd dCp = L * dA - K * dC * sm->A + K * dC * dA;
    const MatrixXd LK = L + K * dC;
    MatrixXd cross = dCp * V * F.transpose();
    MatrixXd Pn = F * P * F.transpose() + cross + cross.transpose() + dCp * U * dCp.transpose() +
                  LK * st->Q * LK.transpose() + K * st->R * K.transpose() + CrossNoiseTerm(LK, K, *st);
    Symmetrize(Pn);
    MatrixXd Vn = st->A * V * F.transpose() + st->A * U * dCp.transpose() - st->Q * LK.transpose();
    if (st->has_cross_covariance()) Vn.noalias() += st->S * K.transpose();
    MatrixXd Un = st->A * U * st->A.transpose() + st->Q;
    Symmetrize(Un);
    VectorXd mun = F * mu + dCp * mx;
    VectorXd mxn = st->A * mx;
    if (g.cols() > 0) {
      const VectorXd gk = g.row(k - 1).transpose();
      const InputEffect ed = EffectOf(*sm, gk), et = EffectOf(*st, gk);
      mun += InputTerm(L, LK, K, ed, et);
      mxn += et.state;
    }
    P = std::move(Pn);
    V = std::move(Vn);
    U = std::move(Un);
    mu = std::move(mun);
    mx = std::move(mxn);
    record(k, K);
  }
  return out;
}

// ---- ranges ------------------------------------------------------------------------------------

namespace {
bool AllZero(const MatrixXd& m) { return m.size() == 0 || m.cwiseAbs().maxCoeff() == 0.0; }
}  // namespace

bool ErrorRanges::PlantExact() const { return AllZero(A) && AllZero(C); }
bool ErrorRanges::NoiseExact() const { return AllZero(Q) && AllZero(R); }

void ValidateErrorRanges(const ModelStep& design, const ErrorRanges& ranges) {
  detail::ValidateDesignStep(design, "design: ");
  MatrixXd G, noise_cov;
  detail::NoiseInputOf(design, &G, &noise_cov);
  const Index n = design.A.rows(), m = design.C.rows(), p = noise_cov.rows();
  auto check = [](const std::string& name, const MatrixXd& r, Index rows, Index cols, bool symmetric) {
    if (r.size() == 0) return;
    RequireShape(name, r, rows, cols);
    RequireFinite(name, r);
    if (r.minCoeff() < 0.0) {
      throw Error(name + ": expected non-negative half-widths |Delta_ij| <= range_ij, got " +
                  std::to_string(r.minCoeff()));
    }
    if (symmetric) RequireSymmetric(name, r, 0.0);
  };
  check("ranges.A", ranges.A, n, n, false);
  check("ranges.C", ranges.C, m, n, false);
  check("ranges.Q", ranges.Q, p, p, true);
  check("ranges.R", ranges.R, m, m, true);
  check("ranges.S", ranges.S, n, m, false);
}

ErrorNorms ErrorNormsFromRanges(const ErrorRanges& ranges) {
  ErrorNorms e;
  // stableNorm: the plain sqrt(sum of squares) overflows from entries of about 1e154 on, and a
  // range of 1e308 is valid (docs/robustness.md, class 12).
  e.A = ranges.A.stableNorm();
  e.C = ranges.C.stableNorm();
  e.Q = ranges.Q.stableNorm();
  e.R = ranges.R.stableNorm();
  e.S = ranges.S.stableNorm();
  e.A_diagonal_abs_sum = ranges.A.size() > 0 ? ranges.A.diagonal().cwiseAbs().sum() : 0.0;
  return e;
}

ErrorNorms ErrorNormsOf(const ModelingErrors& errors) {
  ErrorRanges r{errors.A, errors.C, errors.Q, errors.R, errors.S};
  return ErrorNormsFromRanges(r);
}

}  // namespace kfx
