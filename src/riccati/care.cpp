// The filter CARE with a cross term S and a descriptor E (SolveFilterCare; the equation, the gain and
// the acceptance rules: include/kfx/riccati.hpp). SLICOT SB02OD (DICO = 'C', L = S) on the dual problem,
// after E^{-1} when E is given; then Newton (Kleinman) refinement and the closed-loop eigenvalues.
// The residual and the gain reported are those of the original (descriptor) equation.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "kfx/error.hpp"
#include "kfx/riccati.hpp"
#include "riccati/dare_internal.hpp"
#include "riccati/riccati_internal.hpp"
#include "riccati/slicot.hpp"

namespace kfx {
namespace {

using detail::ConstRef;
using Eigen::MatrixXd;

constexpr double kResidualAcceptance = 1e-8;  // as SolveFilterDare

/// The standard CARE A P + P A^T + Q - (P C^T + S) R^{-1} (C P + S^T) = 0 with E^{-1} applied
/// (A~ = E^{-1} A, Q~ = E^{-1} Q E^{-T}, S~ = E^{-1} S): the same P.
struct StandardCare {
  MatrixXd A, Q, S;
  Eigen::LLT<MatrixXd> r_llt;
};

StandardCare Standardize(const ConstRef& A, const ConstRef& Q, const ConstRef& R, const detail::GeneralProblem& p) {
  StandardCare c;
  c.A = A;
  c.Q = Q;
  c.S = p.S;
  if (p.has_e) {
    const Eigen::PartialPivLU<MatrixXd> lu(p.E);
    c.A = lu.solve(c.A);
    c.S = lu.solve(c.S);
    const MatrixXd EinvQ = lu.solve(c.Q);
    c.Q = lu.solve(EinvQ.transpose());  // E^{-1} Q E^{-T}
  }
  detail::SymmetrizeInPlace(c.Q);
  c.r_llt.compute(0.5 * (R + R.transpose()));
  return c;
}

/// (P C^T + S) R^{-1} and the residual A P + P A^T + Q - K R K^T of the standard CARE.
MatrixXd StandardGain(const StandardCare& c, const ConstRef& C, const MatrixXd& P) {
  MatrixXd cross = c.S;  // P C^T + S
  cross.noalias() += P * C.transpose();
  return c.r_llt.solve(cross.transpose()).transpose();
}

MatrixXd StandardResidual(const StandardCare& c, const ConstRef& C, const ConstRef& R, const MatrixXd& P) {
  const MatrixXd K = StandardGain(c, C, P);
  MatrixXd AP = c.A * P;
  MatrixXd res = c.Q + AP + AP.transpose();
  res.noalias() -= K * (R * K.transpose());
  return res;
}

/// Newton (Kleinman) refinement: (A~ - K~ C) dP + dP (A~ - K~ C)^T + res(P) = 0, a continuous Lyapunov
/// equation (SLICOT SB03MD); at most two steps, each kept only if it lowers the residual.
int Refine(const StandardCare& c, const ConstRef& C, const ConstRef& R, MatrixXd* P) {
  int steps = 0;
  for (int it = 0; it < 2; ++it) {
    const MatrixXd res = StandardResidual(c, C, R, *P);
    MatrixXd acl = c.A;
    acl.noalias() -= StandardGain(c, C, *P) * C;
    const detail::Sb03mdResult dP = detail::SolveLyapunovSb03md(detail::TimeDomain::kContinuous, acl, res);
    if (dP.info != 0 || !(dP.scale > 0.0) || !dP.X.allFinite()) break;
    MatrixXd P1 = *P + dP.X;
    detail::SymmetrizeInPlace(P1);
    if (!(StandardResidual(c, C, R, P1).norm() < res.norm())) break;
    *P = std::move(P1);
    ++steps;
  }
  return steps;
}

/// The original equation's gain K = (E P C^T + S) R^{-1} and relative residual (riccati.hpp).
double OriginalResidual(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R,
                        const detail::GeneralProblem& p, const StandardCare& c, const MatrixXd& P, MatrixXd* K) {
  const MatrixXd EP = p.has_e ? MatrixXd(p.E * P) : P;
  MatrixXd cross = p.S;  // E P C^T + S
  cross.noalias() += EP * C.transpose();
  *K = c.r_llt.solve(cross.transpose()).transpose();
  const MatrixXd APEt = A * EP.transpose();
  const MatrixXd KRKt = *K * (R * K->transpose());
  const MatrixXd res = APEt + APEt.transpose() + Q - KRKt;
  const double scale = std::max(2.0 * APEt.norm() + Q.norm() + KRKt.norm(), detail::kTiny);
  const double r = res.norm() / scale;
  return std::isfinite(r) ? r : std::numeric_limits<double>::infinity();
}

}  // namespace

CareSolution SolveFilterCare(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                             const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                             const Eigen::Ref<const Eigen::MatrixXd>& S, const Eigen::Ref<const Eigen::MatrixXd>& E) {
  const auto start = std::chrono::steady_clock::now();
  const detail::GeneralProblem p = detail::ValidateGeneralProblem(A, C, Q, R, S, E, /*require_psd=*/true);
  CareSolution out;
  Summary& sum = out.summary;
  sum.computation = p.has_s || p.has_e ? "filter CARE (cross term S, descriptor E)" : "filter CARE";
  sum.method = "schur";
  auto finish = [&]() -> CareSolution {
    if (p.has_e) sum.SetDetail("transformation", "E^{-1} applied (rcond_1(E) = " + FormatNumber(p.e_rcond) + ")");
    sum.SetDetail("refinement steps", std::to_string(out.refinement_steps));
    sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return std::move(out);
  };
  if (p.n == 0) {
    out.P = MatrixXd(0, 0);
    out.gain = MatrixXd(0, p.m);
    sum.termination = Termination::kConverged;
    sum.relative_residual = 0.0;
    sum.message = "n = 0";
    return finish();
  }
  const StandardCare c = Standardize(A, Q, R, p);
  const MatrixXd* cross = p.has_s ? &c.S : nullptr;
  detail::Sb02odResult sb = detail::SolveFilterRiccatiSb02od(detail::TimeDomain::kContinuous, c.A, C, c.Q, R, cross);
  sum.message = sb.message;
  if (sb.info != 0 || !sb.P.allFinite()) {
    // 5: no stable deflating subspace of dimension n; 6: U11 singular (e.g. an unstable mode that is neither
    // seen nor driven): no stabilizing solution either way.
    const bool no_stabilizing = sb.info == 5 || sb.info == 6;
    sum.termination = no_stabilizing ? Termination::kNotStabilizing : Termination::kFailed;
    if (no_stabilizing) sum.message += " (not detectable or not stabilizable)";
    if (sb.info == 0) sum.message += "; the result has non-finite entries";
    sum.relative_residual = std::numeric_limits<double>::infinity();
    return finish();
  }
  out.P = std::move(sb.P);
  detail::SymmetrizeInPlace(out.P);
  out.refinement_steps = Refine(c, C, R, &out.P);
  sum.relative_residual = OriginalResidual(A, C, Q, R, p, c, out.P, &out.gain);
  MatrixXd acl = c.A;  // E^{-1} (A - K C) = A~ - K~ C
  acl.noalias() -= StandardGain(c, C, out.P) * C;
  Eigen::VectorXcd eig;
  if (!detail::Eigenvalues(acl, &eig)) {
    sum.termination = Termination::kFailed;
    sum.message += "; the eigenvalues of the closed loop could not be computed (QR failed)";
    return finish();
  }
  out.closed_loop_max_real = eig.real().maxCoeff();
  if (!(out.closed_loop_max_real < 0.0)) {
    sum.termination = Termination::kNotStabilizing;
    sum.message +=
        "; closed loop not stable (max Re lambda(E^{-1} (A - K C)) = " + FormatNumber(out.closed_loop_max_real) + ")";
  } else if (!(sum.relative_residual <= kResidualAcceptance)) {
    sum.termination = Termination::kFailed;
    sum.message +=
        "; relative residual " + FormatNumber(sum.relative_residual) + " > " + FormatNumber(kResidualAcceptance);
  } else {
    sum.termination = Termination::kConverged;
  }
  return finish();
}

}  // namespace kfx
