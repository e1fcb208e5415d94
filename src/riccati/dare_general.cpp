// The filter DARE with a cross term S and a descriptor E (SolveFilterDare's 6-matrix overload; the
// equation, gains and methods: include/kfx/riccati.hpp).
//
//  - kDoubling: E^{-1} and the decorrelation A^ = A~ - S~ R^{-1} C, Q^ = Q~ - S~ R^{-1} S~^T turn the
//    problem into a standard filter DARE with the same solution P (expand (A P C^T + S) W^{-1} (.)^T
//    with W = C P C^T + R; e.g. B.D.O. Anderson, J.B. Moore, Optimal Filtering (1979), sec. 5.5); the
//    standard SolveFilterDare (doubling with its own SB02OD fallback, refinement and certificate) solves
//    it. Its closed loop A^ - A^ K_f C equals E^{-1} (A - K_p C) in exact arithmetic, so its stability
//    proof is reused.
//  - kSchur: SLICOT SG02AD on the original (A, E, C, Q, R, S), then the certificate on
//    F = E^{-1} (A - K_p C) and P here.
// The reported gains and residual are always those of the original problem.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"
#include "riccati/dare_internal.hpp"
#include "riccati/riccati_internal.hpp"
#include "riccati/slicot_generalized.hpp"

namespace kfx {
namespace detail {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;

double Rcond1(const MatrixXd& E) {
  if (E.size() == 0) return 1.0;
  const Eigen::PartialPivLU<MatrixXd> lu(E);
  return lu.rcond();
}

}  // namespace

GeneralProblem ValidateGeneralProblem(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R,
                                      const ConstRef& S, const ConstRef& E, bool require_psd) {
  GeneralProblem p;
  RequireSquare("A", A);
  RequireFinite("A", A);
  p.n = A.rows();
  RequireShape("C", C, -1, p.n);
  RequireFinite("C", C);
  p.m = C.rows();
  RequireShape("Q", Q, p.n, p.n);
  RequireShape("R", R, p.m, p.m);
  if (require_psd) {
    RequirePositiveSemidefinite("Q", Q);
    RequirePositiveDefinite("R", R);
  } else {
    RequireFinite("Q", Q);
    RequireFinite("R", R);
  }
  p.has_s = !(S.rows() == 0 && S.cols() == 0);  // 0 x 0: no cross term
  if (p.has_s) {
    RequireShape("S", S, p.n, p.m);
    RequireFinite("S", S);
    p.S = S;
  } else {
    p.S = MatrixXd::Zero(p.n, p.m);
  }
  if (p.has_s && require_psd && p.n > 0 && p.m > 0) {
    MatrixXd joint(p.n + p.m, p.n + p.m);
    joint << 0.5 * (Q + Q.transpose()), S, S.transpose(), 0.5 * (R + R.transpose());
    RequirePositiveSemidefinite("S (the joint covariance [[Q, S], [S^T, R]])", joint);
  }
  p.has_e = !(E.rows() == 0 && E.cols() == 0);  // 0 x 0: E = I
  if (p.has_e) {
    RequireShape("E", E, p.n, p.n);
    RequireFinite("E", E);
    p.E = E;
    p.e_rcond = Rcond1(p.E);
    const double eps = std::numeric_limits<double>::epsilon();
    if (!(p.e_rcond >= static_cast<double>(std::max<Index>(p.n, 1)) * eps)) {
      throw Error("E: expected a nonsingular matrix, got reciprocal condition number " + FormatNumber(p.e_rcond));
    }
  } else {
    p.E = MatrixXd::Identity(p.n, p.n);
  }
  return p;
}

}  // namespace detail

namespace {

using detail::ConstRef;
using Problem = detail::GeneralProblem;
using Eigen::Index;
using Eigen::MatrixXd;

constexpr double kResidualAcceptance = 1e-8;  // as SolveFilterDare
constexpr double kPsdTolerance = 1e-10;       // as SolveFilterDare
/// kAuto transforms with E^{-1} only when rcond_1(E) is at least this (at most ~8 digits lost to E).
constexpr double kTransformRcond = 1e-8;

/// Residual of the original equation at a symmetric P; also the gains (when W = C P C^T + R is PD).
struct Original {
  bool w_ok = false;
  MatrixXd W, K_f, K_p, P_filt;
  double residual = std::numeric_limits<double>::infinity();
};

Original Evaluate(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R, const Problem& p,
                  const MatrixXd& P) {
  Original o;
  const MatrixXd PCt = P * C.transpose();
  o.W = R;
  o.W.noalias() += C * PCt;
  detail::SymmetrizeInPlace(o.W);
  MatrixXd cross = p.S;  // A P C^T + S
  cross.noalias() += A * PCt;
  MatrixXd EPEt = p.E * P * p.E.transpose();
  MatrixXd res = Q - EPEt;
  res.noalias() += A * P * A.transpose();
  const Eigen::LLT<MatrixXd> llt(o.W);
  if (llt.info() == Eigen::Success && o.W.allFinite()) {
    o.w_ok = true;
    o.K_f = llt.solve(PCt.transpose()).transpose();
    o.K_p = llt.solve(cross.transpose()).transpose();
    o.P_filt = P;
    o.P_filt.noalias() -= o.K_f * PCt.transpose();
    detail::SymmetrizeInPlace(o.P_filt);
    res.noalias() -= o.K_p * cross.transpose();
  } else {
    const Eigen::FullPivLU<MatrixXd> lu(o.W);
    if (!lu.isInvertible()) return o;
    res.noalias() -= cross * lu.solve(cross.transpose());
  }
  o.residual = res.norm() / std::max(EPEt.norm(), detail::kTiny);
  if (!std::isfinite(o.residual)) o.residual = std::numeric_limits<double>::infinity();
  return o;
}

/// The standard problem of the kDoubling method (E^{-1}, then decorrelation).
struct Transformed {
  MatrixXd A_hat, Q_hat;
};

Transformed Transform(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R, const Problem& p) {
  Transformed t;
  MatrixXd At = A, Qt = Q, St = p.S;
  if (p.has_e) {
    const Eigen::PartialPivLU<MatrixXd> lu(p.E);
    At = lu.solve(A);
    St = lu.solve(p.S);
    const MatrixXd EinvQ = lu.solve(Q);
    Qt = lu.solve(EinvQ.transpose());  // E^{-1} Q E^{-T}
  }
  detail::SymmetrizeInPlace(Qt);
  t.A_hat = std::move(At);
  t.Q_hat = std::move(Qt);
  if (p.has_s && p.m > 0) {
    const Eigen::LLT<MatrixXd> r_llt(0.5 * (R + R.transpose()));
    const MatrixXd RinvSt = r_llt.solve(St.transpose());  // m x n: R^{-1} S~^T
    t.A_hat.noalias() -= RinvSt.transpose() * C;
    t.Q_hat.noalias() -= St * RinvSt;
    detail::SymmetrizeInPlace(t.Q_hat);
  }
  return t;
}

/// Copies the original problem's gains and residual into sol and applies the acceptance rules to an
/// otherwise successful solve.
void SetOriginal(const Original& o, DareSolution* sol) {
  Summary& sum = sol->summary;
  sol->innovation_cov = o.W;
  if (!o.w_ok) {
    if (sum.ok()) sum.termination = Termination::kFailed;
    sum.message += "; W = C P C^T + R is not positive definite";
    return;
  }
  sol->filter_gain = o.K_f;
  sol->predictor_gain = o.K_p;
  sol->P_filt = o.P_filt;
  sum.relative_residual = o.residual;
  if (sum.ok() && !(o.residual <= kResidualAcceptance)) {
    sum.termination = Termination::kFailed;
    sum.message += "; relative residual of the original equation " + FormatNumber(o.residual) + " > " +
                   FormatNumber(kResidualAcceptance);
  }
}

/// kSchur: SG02AD, then the stability proof on F = E^{-1} (A - K_p C) and P.
DareSolution SolveBySg02ad(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R, const Problem& p,
                           const DareOptions& options) {
  DareSolution sol;
  sol.method_used = DareMethod::kSchur;
  Summary& sum = sol.summary;
  sum.relative_residual = std::numeric_limits<double>::infinity();
  sol.closed_loop_spectral_radius = std::numeric_limits<double>::quiet_NaN();
  sol.min_eigenvalue = std::numeric_limits<double>::quiet_NaN();
  detail::Sg02adResult sg = detail::SolveFilterDareSg02ad(A, p.E, C, Q, R, p.S);
  sum.message = sg.message;
  if (sg.info != 0 || !sg.P.allFinite()) {
    sum.termination = Termination::kFailed;
    if (sg.info == 0) sum.message += "; the result has non-finite entries";
    return sol;
  }
  sol.P_pred = std::move(sg.P);
  detail::SymmetrizeInPlace(sol.P_pred);
  sum.termination = Termination::kConverged;
  SetOriginal(Evaluate(A, C, Q, R, p, sol.P_pred), &sol);
  if (sol.predictor_gain.size() != p.n * p.m) return sol;
  MatrixXd F = A;
  F.noalias() -= sol.predictor_gain * C;
  double e =
      2 * (static_cast<double>(p.m) + 2) * detail::kUnitRoundoff * (A.norm() + sol.predictor_gain.norm() * C.norm());
  if (p.has_e) {
    // F = E^{-1} (A - K_p C). |E^{-1}|_2 <= sqrt(n) |E^{-1}|_1 = sqrt(n) / (rcond_1 |E|_1), and the LU
    // solve adds about n u cond(E) |F|; rcond_1 is an estimate (within a factor of a few), hence the
    // margin of 10: a bound with a safety factor, not a proof, for E != I.
    F = Eigen::PartialPivLU<MatrixXd>(p.E).solve(F);
    const double norm1 = p.E.cwiseAbs().colwise().sum().maxCoeff();
    const double nd = static_cast<double>(p.n);
    e = 10.0 * (e * std::sqrt(nd) / (p.e_rcond * norm1) + 4.0 * nd * detail::kUnitRoundoff / p.e_rcond * F.norm());
  }
  const auto [stable, psd] =
      detail::JudgeStabilizing(F, e, options.exact_eigenvalues, options.stability_margin, kPsdTolerance, &sol);
  if (sum.ok() && (!stable || !psd)) {
    sum.termination = Termination::kNotStabilizing;
    if (!stable) {
      sum.message +=
          "; not stabilizing: rho(E^{-1} (A - K_p C)) = " + FormatNumber(sol.closed_loop_spectral_radius, 17) +
          " >= 1 - stability_margin";
    }
    if (!psd) sum.message += "; P is not PSD: lambda_min(P) = " + FormatNumber(sol.min_eigenvalue);
  }
  return sol;
}

/// kDoubling: the standard SolveFilterDare on the transformed problem; gains and residual of the original.
DareSolution SolveByTransform(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R,
                              const Problem& p, const DareOptions& options) {
  const Transformed t = Transform(A, C, Q, R, p);
  DareSolution sol;
  try {
    sol = SolveFilterDare(t.A_hat, C, t.Q_hat, R, options);
  } catch (const Error& e) {  // e.g. Q^ indefinite by more than rounding
    sol.summary.termination = Termination::kFailed;
    sol.summary.relative_residual = std::numeric_limits<double>::infinity();
    sol.summary.message = std::string("transformed problem rejected: ") + e.what();
    return sol;
  }
  // n = 0: the standard solver's empty solution is the original's too (no S, E or residual to
  // evaluate; Evaluate would solve with empty right-hand sides, an Eigen block of a null pointer).
  if (p.n == 0 || sol.P_pred.size() != p.n * p.n || !sol.P_pred.allFinite()) return sol;
  SetOriginal(Evaluate(A, C, Q, R, p, sol.P_pred), &sol);
  return sol;
}

std::string TransformText(const Problem& p) {
  std::string s;
  if (p.has_e) s += "E^{-1} applied (rcond_1(E) = " + FormatNumber(p.e_rcond) + ")";
  if (p.has_s) s += std::string(s.empty() ? "" : "; ") + "S removed (A - S R^{-1} C, Q - S R^{-1} S^T)";
  return s.empty() ? "none (S = 0, E = I)" : s;
}

}  // namespace

DareSolution SolveFilterDare(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                             const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                             const Eigen::Ref<const Eigen::MatrixXd>& S, const Eigen::Ref<const Eigen::MatrixXd>& E,
                             const DareOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const Problem p = detail::ValidateGeneralProblem(A, C, Q, R, S, E, /*require_psd=*/true);
  std::string why;
  if (!options.IsValid(&why)) throw Error("options: " + why);
  DareSolution sol;
  const bool transformable = p.e_rcond >= kTransformRcond;
  if (p.n == 0 || options.method == DareMethod::kDoubling || (options.method == DareMethod::kAuto && transformable)) {
    sol = SolveByTransform(A, C, Q, R, p, options);
    if (options.method == DareMethod::kAuto && !sol.summary.ok()) {
      const std::string first = sol.summary.message;
      DareSolution schur = SolveBySg02ad(A, C, Q, R, p, options);
      if (schur.summary.ok() || !(sol.summary.relative_residual <= schur.summary.relative_residual)) {
        schur.summary.message = "transformed: " + first + "; fell back to SG02AD: " + schur.summary.message;
        sol = std::move(schur);
      } else {
        sol.summary.message += "; SG02AD fallback not better: " + schur.summary.message;
      }
      sol.fell_back = true;
    }
  } else {
    sol = SolveBySg02ad(A, C, Q, R, p, options);
    sol.fell_back = options.method == DareMethod::kAuto;
    if (sol.fell_back) sol.summary.message = "E ill-conditioned for the transformation; " + sol.summary.message;
  }
  Summary& s = sol.summary;
  s.computation = "filter DARE (cross term S, descriptor E)";
  s.method = ToString(sol.method_used);
  s.SetDetail("transformation", sol.method_used == DareMethod::kSchur ? "none (SG02AD)" : TransformText(p));
  s.SetDetail("fell back to Schur", sol.fell_back ? "yes" : "no");
  s.SetDetail("rho(E^{-1} (A - K_p C))", (sol.eigenvalues_exact ? "" : "<= ") +
                                             FormatNumber(sol.closed_loop_spectral_radius, 10) +
                                             (sol.eigenvalues_exact ? "" : " (Lyapunov bound)"));
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return sol;
}

double FilterDareResidual(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                          const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                          const Eigen::Ref<const Eigen::MatrixXd>& S, const Eigen::Ref<const Eigen::MatrixXd>& E,
                          const Eigen::Ref<const Eigen::MatrixXd>& P) {
  const Problem p = detail::ValidateGeneralProblem(A, C, Q, R, S, E, /*require_psd=*/false);
  RequireShape("P", P, p.n, p.n);
  RequireSymmetric("P", P);
  if (p.n == 0) return 0.0;
  MatrixXd Ps = P;
  detail::SymmetrizeInPlace(Ps);
  return Evaluate(A, C, Q, R, p, Ps).residual;
}

}  // namespace kfx
