// The discrete Lyapunov (Stein) equation X = A X A^T + Q (SolveDiscreteLyapunov, include/kfx/riccati.hpp):
// SLICOT SB03MD (riccati/slicot.cpp, Barraud's method on the real Schur form) or the squared Smith
// iteration below.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"
#include "riccati/riccati_internal.hpp"
#include "riccati/slicot.hpp"

namespace kfx {

namespace {

using detail::ConstRef;
using detail::kTiny;
using Eigen::Index;
using Eigen::MatrixXd;

// The squared Smith iteration (Smith 1968):
//   X_0 = Q, A_0 = A;  X_{j+1} = X_j + A_j X_j A_j^T,  A_{j+1} = A_j^2,  so X_j = sum_{k < 2^j} A^k Q A^kT,
// 6 n^3 GEMM flops a step. Stops when the increment is below eps |X|_F; gives up (returns false)
// when A_j does not contract fast enough to converge within kSmithMaxSteps steps (rho(A) above about
// 0.998, or transient growth), and the result is accepted only if its residual is <= 1e-13
// (4 n^3 flops more). About 60 n^3 GEMM flops at rho = 0.95, against SB03MD's ~30 n^3 flops of
// mostly BLAS-2 Schur reduction: several times faster from n ~ 50 on.
constexpr int kSmithMaxSteps = 14;

bool SolveSteinSmith(const ConstRef& A, const ConstRef& Q, MatrixXd* X_out, double* relative_residual) {
  const Index n = A.rows();
  const double eps = std::numeric_limits<double>::epsilon();
  MatrixXd Aj = A, X = 0.5 * (Q + Q.transpose()), AX(n, n), T(n, n), A2(n, n);
  double log_a_prev = 0.0;
  for (int j = 0; j < kSmithMaxSteps; ++j) {
    AX.noalias() = Aj * X;
    T.noalias() = AX * Aj.transpose();
    X += T;
    if (!X.allFinite()) return false;
    const double x_norm = X.norm();
    if (T.norm() <= eps * x_norm) break;
    if (j + 1 == kSmithMaxSteps) return false;
    A2.noalias() = Aj * Aj;
    Aj.swap(A2);
    // ln |A_{2^j}| ~ ln c + 2^j ln rho: predict the step at which |A_j|^2 <= eps and give up early
    // if it lies beyond kSmithMaxSteps (or A_j stops contracting).
    const double log_a = std::log(Aj.norm());
    if (std::isinf(log_a) && log_a < 0.0) break;  // A_j = 0 (nilpotent A): X is exact
    if (!std::isfinite(log_a)) return false;
    if (j >= 2) {
      const double log_rho = (log_a - log_a_prev) / std::ldexp(1.0, j);
      if (!(log_rho < 0.0)) return false;
      const double log_c = log_a - std::ldexp(1.0, j + 1) * log_rho;
      const double needed = std::log2((0.5 * std::log(eps) - log_c) / log_rho);
      if (needed > kSmithMaxSteps + 1) return false;
    }
    log_a_prev = log_a;
  }
  detail::SymmetrizeInPlace(X);
  MatrixXd res = X - Q;
  AX.noalias() = A * X;
  res.noalias() -= AX * A.transpose();
  if (!(res.norm() <= 1e-13 * X.norm())) return false;
  *relative_residual = res.norm() / std::max(X.norm(), kTiny);
  X_out->swap(X);
  return true;
}

/// |X - A X A^T - Q|_F / max(|X|_F, tiny), by two GEMMs (4 n^3 flops).
double SteinResidual(const ConstRef& A, const ConstRef& Q, const MatrixXd& X) {
  const Index n = A.rows();
  MatrixXd res = X - Q;
  MatrixXd AX(n, n);
  AX.noalias() = A * X;
  res.noalias() -= AX * A.transpose();
  return res.norm() / std::max(X.norm(), kTiny);
}

/// The Schur method: SB03MD, with its failures and a singular equation mapped to the Summary.
void SolveBySchur(const ConstRef& A, const ConstRef& Q, LyapunovSolution* sol) {
  Summary& sum = sol->summary;
  const Index n = A.rows();
  sum.method = "schur";
  detail::Sb03mdResult sb = detail::SolveLyapunovSb03md(detail::TimeDomain::kDiscrete, A, Q);
  const int info = sb.info;
  sol->spectral_radius =
      sb.eigenvalues.size() > 0 ? sb.eigenvalues.cwiseAbs().maxCoeff() : detail::SpectralRadiusUnchecked(A);
  const std::string rho = " (spectral radius " + FormatNumber(sol->spectral_radius, 17) + ")";
  if (info > 0 && info <= n) {
    sum.termination = Termination::kFailed;
    sum.message = "the QR algorithm failed to compute the Schur form of A (SB03MD info " + std::to_string(info) + ")";
    return;
  }
  // SB03MD flags (almost) reciprocal pairs by info = n + 1, but misses a complex pair on the unit
  // circle (e.g. a rotation): rounding leaves a pivot of order eps and X of order 1e16. Hence our
  // own test of the eigenvalue products: singular if |1 - lambda_i lambda_j| <= 64 eps.
  double min_gap = std::numeric_limits<double>::infinity();
  if (info == 0) {
    for (Index i = 0; i < n; ++i)
      for (Index j = i; j < n; ++j) min_gap = std::min(min_gap, std::abs(1.0 - sb.eigenvalues(i) * sb.eigenvalues(j)));
  }
  if (info == n + 1 || min_gap <= 64 * std::numeric_limits<double>::epsilon()) {
    sum.termination = Termination::kSingular;
    sum.message =
        "the Stein equation X = A X A^T + Q is singular or nearly singular: A has eigenvalues with "
        "lambda_i lambda_j ~= 1" +
        rho;
    return;
  }
  sol->X = std::move(sb.X);
  if (!(sb.scale > 0.0)) {
    sum.termination = Termination::kFailed;
    sum.message = "SB03MD returned scale 0: the solution overflows" + rho;
    return;
  }
  sum.message = "SB03MD (Schur method)";
  if (sb.scale != 1.0) sum.message += "; solution divided by SB03MD's scale " + FormatNumber(sb.scale, 17);
  if (!sol->X.allFinite()) {
    sum.termination = Termination::kFailed;
    sum.message += "; the solution has non-finite entries";
    return;
  }
  sum.relative_residual = SteinResidual(A, Q, sol->X);
  sum.termination = Termination::kConverged;
}

}  // namespace

const char* ToString(LyapunovMethod method) {
  switch (method) {
    case LyapunovMethod::kAuto:
      return "auto";
    case LyapunovMethod::kSchur:
      return "schur";
    case LyapunovMethod::kSmith:
      return "smith";
  }
  return "unknown";
}

bool LyapunovOptions::IsValid(std::string* error) const {
  for (LyapunovMethod m : EnumValues<LyapunovMethod>::kAll) {
    if (method == m) return true;
  }
  if (error) *error = "method: expected kAuto, kSchur or kSmith";
  return false;
}

LyapunovSolution SolveDiscreteLyapunov(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                       const Eigen::Ref<const Eigen::MatrixXd>& Q, const LyapunovOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  RequireSquare("A", A);
  RequireFinite("A", A);
  const Index n = A.rows();
  RequireShape("Q", Q, n, n);
  RequireSymmetric("Q", Q);
  std::string why;
  if (!options.IsValid(&why)) throw Error("options: " + why);
  LyapunovSolution sol;
  Summary& sum = sol.summary;
  sum.computation = "discrete Lyapunov equation";
  if (n == 0) {
    sol.X.resize(0, 0);
    sol.spectral_radius = 0.0;
    sum.termination = Termination::kConverged;
    sum.relative_residual = 0.0;
    sum.method = options.method == LyapunovMethod::kSmith ? "smith" : "schur";
    sum.message = "empty state (n = 0)";
  } else if (options.method != LyapunovMethod::kSchur && SolveSteinSmith(A, Q, &sol.X, &sum.relative_residual)) {
    sum.termination = Termination::kConverged;
    sum.method = "smith";
    sum.message = "squared Smith iteration";
  } else if (options.method == LyapunovMethod::kSmith) {
    sum.termination = Termination::kNotConverged;
    sum.method = "smith";
    sum.message = "the squared Smith iteration did not reach a residual <= 1e-13 within " +
                  std::to_string(kSmithMaxSteps) + " steps (rho(A) too close to or above 1)";
  } else {
    SolveBySchur(A, Q, &sol);
  }
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return sol;
}

}  // namespace kfx
