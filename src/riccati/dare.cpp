// The filter DARE (SolveFilterDare; API and equations: include/kfx/riccati.hpp).
//
// Filter DARE:  P = A P A^T + Q - A P C^T (C P C^T + R)^{-1} C P A^T
//                 = A P (I + G P)^{-1} A^T + Q,             G = C^T R^{-1} C.
// This is the control DARE X = Ã^T X (I + G X)^{-1} Ã + Q of the dual system Ã = A^T, B̃ = C^T
// (scipy.linalg.solve_discrete_are(A^T, C^T, Q, R) returns the same P), so both methods below are
// run on the dual problem:
//
//  - kDoubling: structure-preserving doubling (dare_doubling.cpp, with its references);
//  - kSchur: SLICOT SB02OD (riccati/slicot.cpp) with DICO = 'D' on (A^T, C^T).
//
// Either result then goes through Finalize(): symmetrize, gains, residual, refinement, the
// stability proof (Lyapunov certificate, certificate.cpp; the closed-loop eigenvalues by DGEEV
// and lambda_min(P) by DSYEVR only when it cannot decide or when asked for), acceptance. Failures
// are diagnosed with PBH rank tests (dare_diagnosis.cpp).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"
#include "riccati/dare_internal.hpp"
#include "riccati/slicot.hpp"

namespace kfx {
namespace detail {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;

/// A result is accepted (kConverged) only if its relative residual is at most this. Solutions of
/// well-posed problems reach 1e-15..1e-13; 1e-8 leaves room for ill-conditioned ones while
/// rejecting anything that is not a solution.
constexpr double kResidualAcceptance = 1e-8;
/// P counts as PSD when lambda_min(P) >= -kPsdTolerance * |P|_F (rounding of a PSD matrix with
/// zero eigenvalues gives about n * eps * |P|).
constexpr double kPsdTolerance = 1e-10;

/// The generalized Schur method: SLICOT SB02OD on the dual control problem (A^T, B = C^T, Q, R, L = 0).
DareCandidate SolveBySchur(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R) {
  DareCandidate out;
  out.method = DareMethod::kSchur;
  Sb02odResult sb = SolveFilterRiccatiSb02od(TimeDomain::kDiscrete, A, C, Q, R);
  out.message = sb.message;
  if (sb.info != 0) return out;
  out.P = std::move(sb.P);
  out.termination = Termination::kConverged;
  if (sb.rcond < 1e-10) {
    out.message += " (ill-conditioned: expect a loss of about " +
                   FormatNumber(-std::log10(std::max(sb.rcond, kTiny)), 2) + " digits)";
  }
  return out;
}

// Gains, residual, refinement, spectral radius and acceptance.

/// Everything derived from a candidate P. The residual uses A P A^T - A P C^T S^{-1} C P A^T
/// = A (P - K_f C P) A^T = A P_filt A^T, so Res(P) = P - A P_filt A^T - Q: the quantity defined in
/// the header, evaluated without the cancellation between its two large terms. The fixed-point
/// (Riccati) map is F(P) = A P_filt A^T + Q = P - Res(P).
/// With S = L L^T and Z = L^{-1} C P: K_f C P = Z^T Z, so P_filt = P - Z^T Z (DSYRK, exactly
/// symmetric) and K_f^T = L^{-T} Z, and A P_filt A^T by UpdateWithCongruence. About 5.5 n^3 flops
/// for m = n/2 (8 n^3 with general products); K_p = A K_f (2 n^2 m more)
/// only on request (AddPredictorGain), as the refinement's intermediate iterates do not need it.
struct Derived {
  bool s_ok = false;
  bool has_predictor_gain = false;
  MatrixXd P, P_filt, K_f, K_p, S, res;
  double residual = std::numeric_limits<double>::infinity();
  MatrixXd Z;           ///< workspace (m x n)
  CongruenceWork work;  ///< workspace of the congruence (n x n twice)
};

/// Lower triangle -> upper triangle.
void MirrorLower(MatrixXd* m) { m->triangularView<Eigen::StrictlyUpper>() = m->transpose(); }

/// Everything derived from the candidate in d->P (symmetrized here). The buffers of *d are reused when
/// their sizes match: the refinement alternates between two Derived (a fresh n x n buffer costs page
/// faults, measured 4 ms per 1.3 MB on the project's virtual machines, more than a GEMM at n = 400).
void Derive(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R, Derived* d) {
  d->s_ok = false;
  d->has_predictor_gain = false;
  d->residual = std::numeric_limits<double>::infinity();
  SymmetrizeInPlace(d->P);
  MatrixXd& Z = d->Z;
  Z.noalias() = C * d->P;  // m x n: C P
  d->S = R;
  d->S.noalias() += Z * C.transpose();
  SymmetrizeInPlace(d->S);
  Eigen::LLT<MatrixXd> s_llt(d->S);
  if (s_llt.info() != Eigen::Success || !d->S.allFinite()) return;
  d->s_ok = true;
  s_llt.matrixL().solveInPlace(Z);  // Z = L^{-1} C P
  d->P_filt = d->P;
  d->P_filt.selfadjointView<Eigen::Lower>().rankUpdate(Z.transpose(), -1.0);  // P - Z^T Z
  MirrorLower(&d->P_filt);
  s_llt.matrixU().solveInPlace(Z);  // L^{-T} L^{-1} C P = S^{-1} C P = K_f^T
  d->K_f = Z.transpose();
  d->res = d->P - Q;
  UpdateWithCongruenceLower(A, d->P_filt, -1.0, 1.0, &d->work, &d->res);  // P - Q - A P_filt A^T
  MirrorLower(&d->res);
  d->residual = d->res.norm() / std::max(d->P.norm(), kTiny);
  if (!std::isfinite(d->residual)) d->residual = std::numeric_limits<double>::infinity();
}

void AddPredictorGain(const ConstRef& A, Derived* d) {
  if (!d->s_ok || d->has_predictor_gain) return;
  d->K_p.noalias() = A * d->K_f;
  d->has_predictor_gain = true;
}

constexpr int kMaxFixedPointSteps = 4;
constexpr double kNewtonThreshold = 1e-13;
/// Refinement stops at this relative residual (32 eps = 7.1e-15). The attainable floor is a few
/// eps (measured 6e-16 at n = 50, 1.4e-15 at n = 400); the fixed-point steps from 32 eps down to it
/// gain less than a digit and cost ~5.5 n^3 flops each (one fixed-point step at n = 200 is ~4% of
/// the solve). SB02OD's residuals on the same systems are 1e-14..2e-14 at n = 200..400.
constexpr double kRefinementTarget = 32 * std::numeric_limits<double>::epsilon();

/// What Refine did, by kind of step (the Summary's message names them: the four-term step can be rejected when
/// rho(A_cl)^8 does not halve the residual, and the Stein step runs only when the others leave it above 1e-13).
struct RefinementSteps {
  int four_term = 0;    ///< NewtonApproximantStep, kept
  int fixed_point = 0;  ///< P <- F(P), kept
  int newton = 0;       ///< the Hewer step through a Stein equation (SB03MD), kept
  bool four_term_rejected = false;
  int Accepted() const { return four_term + fixed_point + newton; }
  /// The kinds that ran, e.g. "1 four-term Newton" or "a four-term Newton step not kept, 1 Stein-Newton" (for
  /// n < 32 the four-term step is never tried, so it is not named).
  std::string Describe() const {
    std::string s;
    auto add = [&s](const std::string& part) { s += (s.empty() ? "" : ", ") + part; };
    if (four_term > 0) add(std::to_string(four_term) + " four-term Newton");
    if (four_term_rejected) add("a four-term Newton step not kept");
    if (fixed_point > 0) add(std::to_string(fixed_point) + " fixed-point");
    if (newton > 0) add(std::to_string(newton) + " Stein-Newton");
    return s;
  }
};

/// next->P = d->P + E with E = sum_{k < 4} A_cl^k (-Res) A_cl^kT, A_cl = A - A K_f C: the Newton correction of
/// the refinement truncated to four terms (two Smith steps), in single precision. The fixed-point step is its
/// first term and contracts the error by about rho(A_cl)^2; four terms contract it by rho(A_cl)^8 (0.27 and
/// 0.005 on the benchmark systems, where the fixed point took 3-4 steps of ~8 n^3 of DGEMM time from a
/// doubling residual of 2-5e-13 down to the target, and this takes one: ~6 n^3 of DGEMM time, 12 n^3
/// single-precision flops, plus the step's Derive). Res is about 1e-13 |P|, so single precision (relative
/// 1e-7 of E) adds about 1e-20 |P|. The single-precision matrices live in pooled n x n double buffers (no
/// page faults).
void NewtonApproximantStep(const ConstRef& A, const ConstRef& C, const Derived& d, MatrixPool* pool, Derived* next) {
  using MapF = Eigen::Map<Eigen::MatrixXf>;
  const Index n = A.rows(), m = C.rows();
  const int nf = FortranInt(n), mf = FortranInt(m);
  MatrixXd b1 = pool->Take(n, n), b2 = pool->Take(n, n), b3 = pool->Take(n, n);
  float* f1 = reinterpret_cast<float*>(b1.data());  // 2 n^2 floats each
  float* f2 = reinterpret_cast<float*>(b2.data());
  float* f3 = reinterpret_cast<float*>(b3.data());
  MapF acl(f1, n, n), t(f1 + n * n, n, n), r(f2, n, n), a2(f2 + n * n, n, n), kf(f3, n, m), p(f3 + n * n, n, m);
  acl = A.cast<float>();
  kf = d.K_f.cast<float>();
  const Eigen::MatrixXf c = C.cast<float>();  // m x n (m <= n: a small temporary)
  const float one = 1.0f, zero = 0.0f, minus = -1.0f;
  sgemm_("N", "N", &nf, &mf, &nf, &one, acl.data(), &nf, kf.data(), &nf, &zero, p.data(), &nf);  // A K_f
  const int ldc = std::max(1, mf);
  sgemm_("N", "N", &nf, &nf, &mf, &minus, p.data(), &nf, c.data(), &ldc, &one, acl.data(), &nf);  // A_cl
  r = -d.res.cast<float>();
  sgemm_("N", "N", &nf, &nf, &nf, &one, acl.data(), &nf, r.data(), &nf, &zero, t.data(), &nf);     // A r
  sgemm_("N", "N", &nf, &nf, &nf, &one, acl.data(), &nf, acl.data(), &nf, &zero, a2.data(), &nf);  // A_cl^2
  sgemm_("N", "T", &nf, &nf, &nf, &one, t.data(), &nf, acl.data(), &nf, &one, r.data(), &nf);      // r + A r A^T
  sgemm_("N", "N", &nf, &nf, &nf, &one, a2.data(), &nf, r.data(), &nf, &zero, t.data(), &nf);      // A^2 r
  sgemm_("N", "T", &nf, &nf, &nf, &one, t.data(), &nf, a2.data(), &nf, &one, r.data(), &nf);       // + A^2 r A^2T
  next->P = d.P + r.cast<double>();
  for (MatrixXd* b : {&b1, &b2, &b3}) pool->Give(std::move(*b));
}

/// Refinement of an accepted solution (DareOptions::refine). The Riccati map contracts errors like
/// E -> A_cl E A_cl^T (A_cl = A - K_p C), so one fixed-point step P <- F(P) divides the residual by
/// about rho(A_cl)^{-2}: doubling's accumulated rounding (relative residual ~1e-13 at n = 200..400,
/// vs ~1e-15 attainable) is removed in 2-3 steps of ~5.5 n^3 flops each (a doubling step is ~16 n^3),
/// until the residual is <= kRefinementTarget; for n >= 32 the first step is NewtonApproximantStep instead (four
/// terms of the Newton correction, usually the only step needed; also m <= n). A step is kept only if it at least
/// halves the residual. If rho(A_cl) is close to 1 the fixed point stalls; then one Newton (Hewer/Kleinman) step solves
/// the Stein equation
///   E = A_cl E A_cl^T + (F(P) - P),   P <- P + E
/// (the Newton step for F(P) - P = 0, since F'(P)[E] = A_cl E A_cl^T; G.A. Hewer, IEEE TAC 16
/// (1971) 382-384), about 25 n^3 flops with SB03MD, kept only if it lowers the residual.
RefinementSteps Refine(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R, Derived* d,
                       Derived* next, MatrixPool* pool) {
  RefinementSteps done;
  for (int step = 0; step < kMaxFixedPointSteps && d->residual > kRefinementTarget; ++step) {
    const bool four_terms = step == 0 && A.rows() >= 32 && C.rows() <= A.rows();  // (m <= n: K_f fits)
    if (four_terms) {
      NewtonApproximantStep(A, C, *d, pool, next);
    } else {
      next->P = d->P - d->res;
    }
    Derive(A, C, Q, R, next);
    if (!next->s_ok || !(next->residual <= 0.5 * d->residual)) {
      if (four_terms) {  // not kept: the fixed-point steps from the same P
        done.four_term_rejected = true;
        continue;
      }
      break;
    }
    std::swap(*d, *next);
    ++(four_terms ? done.four_term : done.fixed_point);
  }
  if (d->residual > kNewtonThreshold) {
    AddPredictorGain(A, d);
    MatrixXd closed_loop = A;
    closed_loop.noalias() -= d->K_p * C;
    const MatrixXd minus_res = -d->res;  // F(P) - P
    const Sb03mdResult stein = SolveLyapunovSb03md(TimeDomain::kDiscrete, closed_loop, minus_res);
    const double rho = stein.info == 0 ? stein.eigenvalues.cwiseAbs().maxCoeff() : 1.0;
    if (stein.info == 0 && rho < 1.0 && stein.X.allFinite()) {
      next->P = d->P + stein.X;
      Derive(A, C, Q, R, next);
      if (next->s_ok && next->residual < d->residual) {
        std::swap(*d, *next);
        ++done.newton;
      }
    }
  }
  return done;
}

DareSolution Finalize(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R, DareCandidate cand,
                      const DareOptions& options, MatrixPool* pool) {
  DareSolution sol;
  Summary& sum = sol.summary;
  sol.method_used = cand.method;
  sum.iterations = cand.iterations;
  sum.termination = cand.termination;
  sum.message = cand.message;
  sum.relative_residual = std::numeric_limits<double>::infinity();
  sol.closed_loop_spectral_radius = std::numeric_limits<double>::quiet_NaN();
  sol.min_eigenvalue = std::numeric_limits<double>::quiet_NaN();
  if (cand.P.size() == 0 && A.rows() > 0) {
    if (sum.termination == Termination::kConverged) sum.termination = Termination::kFailed;
    return sol;
  }
  if (!cand.P.allFinite()) {
    sol.P_pred = std::move(cand.P);
    sum.termination = Termination::kFailed;
    sum.message += "; the result has non-finite entries";
    return sol;
  }
  const Index n = A.rows();
  const auto seat = [pool, n](Derived* x) {
    x->P_filt = pool->Take(n, n);
    x->res = pool->Take(n, n);
    x->work.L = pool->Take(n, n);
    x->work.B = pool->Take(n, n);
  };
  Derived d, spare;
  seat(&d);
  d.P = std::move(cand.P);
  Derive(A, C, Q, R, &d);
  if (d.s_ok && options.refine && sum.termination == Termination::kConverged) {
    const double before = d.residual;
    seat(&spare);
    spare.P = pool->Take(n, n);
    const RefinementSteps done = Refine(A, C, Q, R, &d, &spare, pool);
    sol.refinement_steps = done.Accepted();
    if (sol.refinement_steps > 0 || done.four_term_rejected) {
      sum.message += "; refined in " + std::to_string(sol.refinement_steps) + " steps (" + done.Describe() +
                     "; relative residual " + FormatNumber(before) + " -> " + FormatNumber(d.residual) + ")";
    }
  }
  for (MatrixXd* m : {&spare.P, &spare.P_filt, &spare.res, &spare.work.L, &spare.work.B, &d.work.L, &d.work.B}) {
    pool->Give(std::move(*m));
  }
  sol.P_pred = std::move(d.P);
  sol.innovation_cov = std::move(d.S);
  if (!d.s_ok) {
    sol.min_eigenvalue = MinEigenvalue(sol.P_pred);
    sol.eigenvalues_exact = true;
    sum.termination = Termination::kFailed;
    sum.message += "; innovation covariance S = C P C^T + R is not positive definite (Cholesky failed)";
    return sol;
  }
  AddPredictorGain(A, &d);
  sol.P_filt = std::move(d.P_filt);
  sol.filter_gain = std::move(d.K_f);
  sol.predictor_gain = std::move(d.K_p);
  sum.relative_residual = d.residual;
  pool->Give(std::move(d.res));
  MatrixXd closed_loop = pool->Take(n, n);
  closed_loop = A;
  closed_loop.noalias() -= sol.predictor_gain * C;

  // Stability: the Lyapunov certificate with F = A - K_p C, X = P (P - F P F^T = Q + K_p R K_p^T;
  // see CertifyUnchecked), robust to the rounding of forming F: |fl(A - K_p C) - (A - K_p C)|
  // <= gamma_{m+1} (|A| + |K_p| |C|) entrywise. Its bounds are reported unless exact eigenvalues are
  // asked for; DGEEV and DSYEVR run only when it cannot decide (or gives no bound below 1 - margin).
  const double md = static_cast<double>(C.rows());
  const double e = 2 * (md + 2) * kUnitRoundoff * (A.norm() + sol.predictor_gain.norm() * C.norm());
  const auto [stable, psd] =
      JudgeStabilizing(closed_loop, e, options.exact_eigenvalues, options.stability_margin, kPsdTolerance, &sol, pool);
  const bool residual_ok = sum.relative_residual <= kResidualAcceptance;
  if (sum.termination == Termination::kConverged) {
    if (!residual_ok) {
      sum.termination = Termination::kFailed;
      sum.message += "; relative residual " + FormatNumber(sum.relative_residual) + " > " +
                     FormatNumber(kResidualAcceptance) + " (inaccurate solution)";
    } else if (!stable || !psd) {
      sum.termination = Termination::kNotStabilizing;
      if (!stable) {
        sum.message += "; not stabilizing: rho(A - K_p C) = " + FormatNumber(sol.closed_loop_spectral_radius, 17) +
                       " >= 1 - stability_margin";
      }
      if (!psd) sum.message += "; P is not PSD: lambda_min(P) = " + FormatNumber(sol.min_eigenvalue);
    }
  }
  return sol;
}

bool Usable(const DareSolution& s) { return s.P_pred.size() > 0 && std::isfinite(s.summary.relative_residual); }

/// The Summary's names and the details that FullReport lists.
void Describe(DareSolution* sol) {
  Summary& s = sol->summary;
  s.computation = "filter DARE";
  s.method = ToString(sol->method_used);
  s.SetDetail("fell back to Schur", sol->fell_back ? "yes" : "no");
  s.SetDetail("refinement steps", std::to_string(sol->refinement_steps));
  const std::string bound = sol->eigenvalues_exact ? "" : " (Lyapunov bound)";
  s.SetDetail("rho(A - K_p C)",
              (sol->eigenvalues_exact ? "" : "<= ") + FormatNumber(sol->closed_loop_spectral_radius, 10) + bound);
  s.SetDetail("min eigenvalue of P", (sol->eigenvalues_exact ? "" : ">= ") + FormatNumber(sol->min_eigenvalue) + bound);
  s.SetDetail("stability proven by", sol->lyapunov_certified ? "Lyapunov certificate" : "eigenvalues (DGEEV)");
}

}  // namespace
}  // namespace detail

using Eigen::Index;
using Eigen::MatrixXd;

const char* ToString(DareMethod method) {
  switch (method) {
    case DareMethod::kAuto:
      return "auto";
    case DareMethod::kDoubling:
      return "doubling";
    case DareMethod::kSchur:
      return "schur";
  }
  return "unknown";
}

bool DareOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& what) {
    if (error) *error = what;
    return false;
  };
  if (method != DareMethod::kAuto && method != DareMethod::kDoubling && method != DareMethod::kSchur) {
    return fail("method: expected kAuto, kDoubling or kSchur");
  }
  if (max_iterations < 1 || max_iterations > 200) {
    return fail("max_iterations: expected a value in [1, 200], got " + std::to_string(max_iterations));
  }
  if (!(tolerance > 0.0 && tolerance <= 1e-2)) {
    return fail("tolerance: expected a value in (0, 1e-2], got " + FormatNumber(tolerance));
  }
  if (!(stability_margin >= 0.0 && stability_margin < 1.0)) {
    return fail("stability_margin: expected a value in [0, 1), got " + FormatNumber(stability_margin));
  }
  return true;
}

DareSolution SolveFilterDare(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                             const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                             const DareOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  RequireSquare("A", A);
  RequireFinite("A", A);
  const Index n = A.rows();
  RequireShape("C", C, -1, n);
  RequireFinite("C", C);
  const Index m = C.rows();
  RequireShape("Q", Q, n, n);
  RequirePositiveSemidefinite("Q", Q);
  RequireShape("R", R, m, m);
  RequirePositiveDefinite("R", R);
  std::string why;
  if (!options.IsValid(&why)) throw Error("options: " + why);

  DareSolution sol;
  detail::MatrixPool pool;  // n x n buffers shared by the doubling, the refinement and the certificate
  if (n == 0) {
    sol.P_pred.resize(0, 0);
    sol.P_filt.resize(0, 0);
    sol.filter_gain.resize(0, m);
    sol.predictor_gain.resize(0, m);
    sol.innovation_cov = R;
    sol.summary.termination = Termination::kConverged;
    sol.summary.relative_residual = 0.0;
    sol.method_used = options.method == DareMethod::kSchur ? DareMethod::kSchur : DareMethod::kDoubling;
    sol.summary.message = "empty state (n = 0)";
    sol.eigenvalues_exact = true;  // rho and lambda_min of empty matrices: 0 by convention
  } else if (options.method == DareMethod::kDoubling) {
    sol = detail::Finalize(A, C, Q, R, detail::SolveDareByDoubling(A, C, Q, R, options, &pool), options, &pool);
  } else if (options.method == DareMethod::kSchur) {
    sol = detail::Finalize(A, C, Q, R, detail::SolveBySchur(A, C, Q, R), options, &pool);
  } else {
    sol = detail::Finalize(A, C, Q, R, detail::SolveDareByDoubling(A, C, Q, R, options, &pool), options, &pool);
    if (!sol.summary.ok()) {
      const int doubling_steps = sol.summary.iterations;
      const std::string doubling_message = sol.summary.message;
      DareSolution schur = detail::Finalize(A, C, Q, R, detail::SolveBySchur(A, C, Q, R), options, &pool);
      // Keep Schur if it succeeded, or if both failed and Schur has the smaller residual.
      const bool take_schur =
          schur.summary.ok() || (detail::Usable(schur) && (!detail::Usable(sol) || schur.summary.relative_residual <
                                                                                       sol.summary.relative_residual));
      if (take_schur) {
        schur.summary.message = "doubling: " + doubling_message + "; fell back to Schur: " + schur.summary.message;
        sol = std::move(schur);
      } else {
        sol.summary.message += "; Schur fallback not better: " + schur.summary.message;
      }
      sol.fell_back = true;
      sol.summary.iterations = doubling_steps;
    }
  }
  if (!sol.summary.ok()) {
    const detail::DareDiagnosis diag = detail::DiagnoseDare(A, C, Q);
    if (diag.found) {
      sol.summary.termination = diag.termination;
      sol.summary.message = diag.message + "; " + sol.summary.message;
    }
  }
  detail::Describe(&sol);
  sol.summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return sol;
}

double FilterDareResidual(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                          const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                          const Eigen::Ref<const Eigen::MatrixXd>& P) {
  RequireSquare("A", A);
  RequireFinite("A", A);
  const Index n = A.rows();
  RequireShape("C", C, -1, n);
  RequireFinite("C", C);
  RequireShape("Q", Q, n, n);
  RequireFinite("Q", Q);
  RequireShape("R", R, C.rows(), C.rows());
  RequireFinite("R", R);
  RequireShape("P", P, n, n);
  RequireSymmetric("P", P);  // then evaluated at 0.5 (P + P^T), like the solver's own results
  if (n == 0) return 0.0;
  // Derive needs S = C P C^T + R PD (Cholesky); for an indefinite candidate P fall back to a full-pivot LU.
  detail::Derived d;
  d.P = P;
  detail::Derive(A, C, Q, R, &d);
  if (d.s_ok) return d.residual;
  MatrixXd Ps = P;
  detail::SymmetrizeInPlace(Ps);
  const MatrixXd CP = C * Ps;
  MatrixXd S = R;
  S.noalias() += CP * C.transpose();
  const Eigen::FullPivLU<MatrixXd> lu(S);
  if (!lu.isInvertible()) return std::numeric_limits<double>::infinity();
  MatrixXd Pf = Ps;
  Pf.noalias() -= CP.transpose() * lu.solve(CP);
  MatrixXd res = Ps - Q;
  res.noalias() -= A * Pf * A.transpose();
  return res.norm() / std::max(Ps.norm(), detail::kTiny);
}

}  // namespace kfx
