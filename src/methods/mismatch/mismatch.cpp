// Filters built on a wrong model (paper 002): the exact true error by 002's recursions (15)-(19),
// time-varying and stationary, error ranges, and the search of an error box. The bounds of
// Theorems 1-6 are in src/methods/mismatch/mismatch_bounds.cpp. API and equations: include/kfx/mismatch.hpp.
#include "kfx/mismatch.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <sstream>

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
  const DareSolution dare = SolveFilterDare(design.A, design.C, design.Q, design.R);
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
  const MatrixXd A = design.A - detail::OrZeros(errors.A, n, n);
  const MatrixXd C = design.C - detail::OrZeros(errors.C, m, n);
  MatrixXd R = design.R - detail::OrZeros(errors.R, m, m);
  Symmetrize(R);
  MatrixXd W = noise_cov - detail::OrZeros(errors.Q, p, p);
  Symmetrize(W);
  ModelStep truth = design.B.size() > 0 ? MakeStepWithNoiseInput(A, design.B, W, C, R) : MakeStep(A, C, W, R);
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
  return e;
}

// ---- exact true error --------------------------------------------------------------------------

bool MismatchOptions::IsValid(std::string* error) const {
  if (filter_gain.size() > 0 && !filter_gain.allFinite()) {
    if (error) *error = "filter_gain: expected finite entries";
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
  const MatrixXd dA = AM - A;
  const MatrixXd dC = design.C - truth.C;
  const MatrixXd L = MatrixXd::Identity(n, n) - K * design.C;  // (18)
  const MatrixXd F = L * AM;                                   // the filter's transition
  const MatrixXd dCp = L * dA - K * dC * AM + K * dC * dA;     // (19)
  const MatrixXd LK = L + K * dC;                              // = I - K C
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
  // (17): U = A U A^T + G Q G^T.
  if (!detail::SolveStein(A, truth.Q, "(17)", &out.U, &sum)) return finish();
  Symmetrize(out.U);
  // (16): V = A V F^T + A U dC'^T - G Q G^T (L + K dC)^T, i.e. V + (-A) V F^T = rhs.
  const MatrixXd rhs_v = A * out.U * dCp.transpose() - truth.Q * LK.transpose();
  const int info = SolveSylvesterSb04qd(-A, F.transpose(), rhs_v, &out.V);
  if (info != 0) {
    sum.termination = Termination::kFailed;
    sum.message = "Sylvester equation (16) (SLICOT SB04QD) failed, info = " + std::to_string(info);
    return finish();
  }
  // (15): P = F P F^T + W.
  MatrixXd W = dCp * out.V * F.transpose();
  W += W.transpose().eval();
  W += dCp * out.U * dCp.transpose() + LK * truth.Q * LK.transpose() + K * truth.R * K.transpose();
  Symmetrize(W);
  if (!detail::SolveStein(F, W, "(15)", &out.P, &sum)) return finish();
  Symmetrize(out.P);
  out.trace = out.P.trace();
  sum.relative_residual = std::max({RelativeResidual(out.U, A * out.U * A.transpose() + truth.Q),
                                    RelativeResidual(out.V, A * out.V * F.transpose() + rhs_v),
                                    RelativeResidual(out.P, F * out.P * F.transpose() + W)});
  sum.termination = Termination::kConverged;
  sum.message = "rho(A) = " + std::to_string(out.true_spectral_radius) +
                ", rho(L A_M) = " + std::to_string(out.filter_spectral_radius);
  return finish();
}

MismatchSequence MismatchedCovarianceSequence(const Model& design, const Model& truth,
                                              const MismatchSequenceOptions& options) {
  const int steps = options.steps;
  if (steps < 0) throw Error("options.steps: expected >= 0, got " + std::to_string(steps));
  if (design.state_dim() != truth.state_dim() || design.meas_dim() != truth.meas_dim()) {
    throw Error("truth: expected the design's dimensions (n = " + std::to_string(design.state_dim()) +
                ", m = " + std::to_string(design.meas_dim()) + ")");
  }
  const int T = design.ResolveSteps(steps, "options.steps");
  truth.ResolveSteps(T, "options.steps");
  const Index n = design.state_dim();
  const KalmanSchedule schedule = ComputeKalmanSchedule(design, KalmanScheduleOptions{T});
  MismatchSequence out;
  const VectorXd& mt = truth.m0();
  const VectorXd& mm = design.m0();
  MatrixXd U = truth.P0() + mt * mt.transpose();
  MatrixXd V = mt * mm.transpose() - U;  // E[x_0 (m_M - x_0)^T]
  const VectorXd d = mm - mt;
  MatrixXd P = truth.P0() + d * d.transpose();
  out.P.push_back(P);
  out.V.push_back(V);
  out.U.push_back(U);
  out.filter_gain.emplace_back();
  out.trace.resize(T + 1);
  out.trace(0) = P.trace();
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
                  LK * st->Q * LK.transpose() + K * st->R * K.transpose();
    Symmetrize(Pn);
    MatrixXd Vn = st->A * V * F.transpose() + st->A * U * dCp.transpose() - st->Q * LK.transpose();
    MatrixXd Un = st->A * U * st->A.transpose() + st->Q;
    Symmetrize(Un);
    P = std::move(Pn);
    V = std::move(Vn);
    U = std::move(Un);
    out.P.push_back(P);
    out.V.push_back(V);
    out.U.push_back(U);
    out.filter_gain.push_back(K);
    out.trace(k) = P.trace();
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
}

ErrorNorms ErrorNormsFromRanges(const ErrorRanges& ranges) {
  ErrorNorms e;
  // stableNorm: the plain sqrt(sum of squares) overflows from entries of about 1e154 on, and a
  // range of 1e308 is valid (docs/robustness.md, class 12).
  e.A = ranges.A.stableNorm();
  e.C = ranges.C.stableNorm();
  e.Q = ranges.Q.stableNorm();
  e.R = ranges.R.stableNorm();
  e.A_diagonal_abs_sum = ranges.A.size() > 0 ? ranges.A.diagonal().cwiseAbs().sum() : 0.0;
  return e;
}

ErrorNorms ErrorNormsOf(const ModelingErrors& errors) {
  return ErrorNormsFromRanges({errors.A, errors.C, errors.Q, errors.R});
}

// ---- error box search --------------------------------------------------------------------------

bool ErrorBoxSearchOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (max_corner_dimensions < 0 || max_corner_dimensions > 24)
    return fail("max_corner_dimensions: expected 0..24, got " + std::to_string(max_corner_dimensions));
  if (random_corners < 1) return fail("random_corners: expected >= 1, got " + std::to_string(random_corners));
  if (!(step_tolerance > 0.0 && step_tolerance < 1.0))
    return fail("step_tolerance: expected in (0, 1), got " + std::to_string(step_tolerance));
  if (max_evaluations < 1) return fail("max_evaluations: expected >= 1, got " + std::to_string(max_evaluations));
  return true;
}

namespace {

struct FreeEntry {
  int which;  // 0 A, 1 C, 2 Q, 3 R
  Index i, j;
  double range;
};

std::vector<FreeEntry> FreeEntries(const ErrorRanges& r) {
  std::vector<FreeEntry> out;
  const MatrixXd* mats[4] = {&r.A, &r.C, &r.Q, &r.R};
  for (int w = 0; w < 4; ++w) {
    const MatrixXd& m = *mats[w];
    for (Index j = 0; j < m.cols(); ++j)
      for (Index i = 0; i < m.rows(); ++i) {
        if (w >= 2 && i > j) continue;  // symmetric: (i, j) and (j, i) move together
        if (m(i, j) > 0.0) out.push_back({w, i, j, m(i, j)});
      }
  }
  return out;
}

ModelingErrors ErrorsAt(const ModelStep& design, const std::vector<FreeEntry>& free, const VectorXd& theta) {
  MatrixXd G, noise_cov;
  detail::NoiseInputOf(design, &G, &noise_cov);
  const Index n = design.A.rows(), m = design.C.rows(), p = noise_cov.rows();
  ModelingErrors e;
  e.A = MatrixXd::Zero(n, n);
  e.C = MatrixXd::Zero(m, n);
  e.Q = MatrixXd::Zero(p, p);
  e.R = MatrixXd::Zero(m, m);
  MatrixXd* mats[4] = {&e.A, &e.C, &e.Q, &e.R};
  for (size_t k = 0; k < free.size(); ++k) {
    const FreeEntry& f = free[k];
    (*mats[f.which])(f.i, f.j) = theta(static_cast<Index>(k));
    if (f.which >= 2) (*mats[f.which])(f.j, f.i) = theta(static_cast<Index>(k));
  }
  return e;
}

using Objective = std::function<bool(const ModelingErrors&, double*, ModelStep*)>;

// Maximizes sign * value over the box: corners, then a compass search from the best corner and
// from the centre.
ErrorBoxExtreme SearchExtreme(const ModelStep& design, const std::vector<FreeEntry>& free, const Objective& f,
                              double sign, const ErrorBoxSearchOptions& opt) {
  ErrorBoxExtreme best;
  const Index d = static_cast<Index>(free.size());
  VectorXd range(d);
  for (Index k = 0; k < d; ++k) range(k) = free[static_cast<size_t>(k)].range;
  VectorXd best_theta = VectorXd::Zero(d);
  auto eval = [&](const VectorXd& theta, double* value) {
    if (best.evaluations >= opt.max_evaluations) return false;
    ++best.evaluations;
    ModelStep truth;
    const ModelingErrors e = ErrorsAt(design, free, theta);
    if (!f(e, value, &truth)) {
      ++best.skipped;
      return false;
    }
    if (!best.found || sign * *value > sign * best.value) {
      best.found = true;
      best.value = *value;
      best.errors = e;
      best.truth = truth;
      best_theta = theta;
    }
    return true;
  };
  // Corners.
  double v = 0.0;
  if (d == 0) {
    eval(VectorXd::Zero(0), &v);
  } else if (d <= opt.max_corner_dimensions) {
    const long count = 1L << d;
    for (long c = 0; c < count && best.evaluations < opt.max_evaluations; ++c) {
      VectorXd theta(d);
      for (Index k = 0; k < d; ++k) theta(k) = ((c >> k) & 1) ? range(k) : -range(k);
      ++best.corners;
      eval(theta, &v);
    }
  } else {
    std::mt19937_64 gen(1);
    for (int c = 0; c < opt.random_corners && best.evaluations < opt.max_evaluations; ++c) {
      VectorXd theta(d);
      for (Index k = 0; k < d; ++k) theta(k) = (gen() & 1) ? range(k) : -range(k);
      ++best.corners;
      eval(theta, &v);
    }
  }
  const double corner_value = best.value;
  const bool corner_found = best.found;
  if (opt.refine && d > 0) {
    std::vector<VectorXd> starts;
    if (best.found) starts.push_back(best_theta);
    starts.push_back(VectorXd::Zero(d));
    for (const VectorXd& start : starts) {
      VectorXd theta = start;
      double cur = 0.0;
      if (!eval(theta, &cur)) continue;
      VectorXd step = 0.5 * range;
      while (best.evaluations < opt.max_evaluations && (step.array() / range.array()).maxCoeff() > opt.step_tolerance) {
        bool improved = false;
        for (Index k = 0; k < d && !improved; ++k) {
          for (double s : {1.0, -1.0}) {
            VectorXd trial = theta;
            trial(k) = std::clamp(theta(k) + s * step(k), -range(k), range(k));
            if (trial(k) == theta(k)) continue;
            double val = 0.0;
            if (eval(trial, &val) && sign * val > sign * cur + 1e-15 * std::abs(cur)) {
              theta = trial;
              cur = val;
              improved = true;
              break;
            }
          }
        }
        if (!improved) step *= 0.5;
      }
    }
  }
  if (best.found) {
    best.at_corner = true;
    for (Index k = 0; k < d; ++k) best.at_corner = best.at_corner && std::abs(best_theta(k)) == range(k);
    best.refinement_gain = corner_found ? sign * (best.value - corner_value) : 0.0;
  }
  return best;
}

}  // namespace

ErrorBoxSearch SearchErrorBox(const ModelStep& design, const ErrorRanges& ranges, const MismatchOptions& options,
                              const ErrorBoxSearchOptions& search) {
  std::string why;
  if (!search.IsValid(&why)) throw Error("search." + why);
  if (!options.IsValid(&why)) throw Error("options." + why);
  ValidateErrorRanges(design, ranges);
  const auto start = std::chrono::steady_clock::now();
  MismatchOptions fixed = options;
  ErrorBoxSearch out;
  out.summary.method = "corners, then compass search";
  if (!detail::ResolveFilterGain(design, options, &fixed.filter_gain, &out.summary)) {
    detail::FinishSummary("error-box search", start, &out.summary);
    return out;
  }
  const std::vector<FreeEntry> free = FreeEntries(ranges);
  out.free_entries = static_cast<int>(free.size());
  const Objective true_error = [&](const ModelingErrors& e, double* value, ModelStep* truth) {
    try {
      *truth = ApplyModelingErrors(design, e);
    } catch (const Error&) {
      return false;
    }
    const StationaryMismatch s = StationaryMismatchedCovariance(design, *truth, fixed);
    if (!s.summary.ok() || !std::isfinite(s.trace)) return false;
    *value = s.trace;
    return true;
  };
  const Objective optimal_error = [&](const ModelingErrors& e, double* value, ModelStep* truth) {
    try {
      *truth = ApplyModelingErrors(design, e);
    } catch (const Error&) {
      return false;
    }
    const DareSolution dare = SolveFilterDare(truth->A, truth->C, truth->Q, truth->R);
    if (!dare.summary.ok()) return false;
    *value = dare.P_filt.trace();
    return std::isfinite(*value);
  };
  out.least_upper = SearchExtreme(design, free, true_error, 1.0, search);
  out.greatest_lower = SearchExtreme(design, free, optimal_error, -1.0, search);
  out.summary.termination = Termination::kConverged;
  out.summary.iterations = out.least_upper.evaluations + out.greatest_lower.evaluations;
  detail::FinishSummary("error-box search", start, &out.summary);
  return out;
}

}  // namespace kfx
