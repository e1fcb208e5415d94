// The discrete Lyapunov (Stein) equation X = A X A^T + Q (SolveDiscreteLyapunov, include/kfx/riccati.hpp):
// the real Schur form and the recursive blocked Bartels-Stewart solve (riccati/schur_stein.cpp) or the
// squared Smith iteration below.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "base/lapack_fortran.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"
#include "riccati/riccati_internal.hpp"
#include "riccati/schur_stein.hpp"

namespace kfx {

namespace {

using detail::ConstRef;
using detail::kTiny;
using Eigen::Index;
using Eigen::MatrixXd;

// The squared Smith iteration (Smith 1968):
//   X_0 = Q, A_0 = A;  X_{j+1} = X_j + A_j X_j A_j^T,  A_{j+1} = A_j^2,  so X_j = sum_{k < 2^j} A^k Q A^kT.
// Each increment is a symmetric congruence: while X_j is positive definite (Q > 0) by its Cholesky factor,
// A_j X_j A_j^T = (A_j L)(A_j L)^T (DPOTRF + DTRMM + DSYRK, 2.3 n^3 flops), else by UpdateWithCongruence
// (DTRMM + DSYR2K, 3 n^3); both exactly symmetric. Each squaring is one GEMM (2 n^3): 4.3 n^3 a step. The remainder
// after step j is X - X_j = A_j X A_j^T, of norm <= |A_j|_F^2 |X|_F: the iteration stops as soon as |A_j|_F^2 <= eps
// (the increment would be below rounding), and skips the last squaring when |A_j|_F^4 <= eps (then
// |A_{j+1}|_F^2 <= eps). It gives up (returns false) when A_j does not contract fast enough to converge
// within kSmithMaxSteps steps (rho(A) above about 0.998, or transient growth), and the result is
// accepted only if its residual is <= 1e-13 (2.3 n^3 flops more). About 43 n^3 flops at rho = 0.95, all
// BLAS level 3, against SB03MD's ~30 n^3 flops of mostly BLAS-2 Schur reduction (issue 24).
constexpr int kSmithMaxSteps = 14;

/// *out += alpha A X A^T for X = L L^T positive definite (DPOTRF n^3/3, DTRMM n^3, DSYRK n^3; the lower
/// triangle is computed and mirrored). Returns false, with *out unchanged, when n < 32 (Eigen's products are
/// faster there) or X is not numerically positive definite; the caller then uses UpdateWithCongruence.
bool AddCongruenceOfPd(const ConstRef& A, const MatrixXd& X, double alpha, MatrixXd* out) {
  const Index n = A.rows();
  if (n < 32) return false;
  const int nf = detail::FortranInt(n);
  MatrixXd L = X;
  int info = 0;
  dpotrf_("L", &nf, L.data(), &nf, &info, 1);
  if (info != 0) return false;
  MatrixXd W = A;
  const double one = 1.0;
  dtrmm_("R", "L", "N", "N", &nf, &nf, &one, L.data(), &nf, W.data(), &nf);   // W = A L
  dsyrk_("L", "N", &nf, &nf, &alpha, W.data(), &nf, &one, out->data(), &nf);  // out += alpha W W^T (lower)
  out->triangularView<Eigen::StrictlyUpper>() = out->transpose();
  return true;
}

/// *out += alpha A X A^T for symmetric X: by the Cholesky factor when X is positive definite and *try_pd,
/// else by UpdateWithCongruence (and *try_pd turns false: a non-PD X_j stays so in the Smith iteration).
void AddCongruence(const ConstRef& A, const MatrixXd& X, double alpha, bool* try_pd, MatrixXd* out) {
  if (*try_pd && AddCongruenceOfPd(A, X, alpha, out)) return;
  *try_pd = false;
  detail::UpdateWithCongruence(A, X, alpha, 1.0, out);
}

/// *res = X - Q - A X A^T (2.3 or 3 n^3 flops); returns |res|_F / max(|X|_F, tiny).
double SteinResidualInto(const ConstRef& A, const ConstRef& Q, const MatrixXd& X, MatrixXd* res) {
  *res = X - Q;
  bool try_pd = true;
  AddCongruence(A, X, -1.0, &try_pd, res);
  return res->norm() / std::max(X.norm(), kTiny);
}

// The Schur route costs DGEES (about 25 n^3 flops at a rate well below DGEMM's: measured 60-180 n^3 DGEMM
// flops' worth at n = 200-1000) plus about 9 n^3 in products, a Smith step 4.3 n^3: under kAuto the
// iteration gives up as soon as it predicts more than kAutoSmithStepsLarge steps for n >= 1000, where DGEES
// runs closest to the DGEMM rate (N = 2000, rho(A) = 0.9975: 13 steps, 56 n^3, against about 45 n^3).
constexpr int kAutoSmithStepsLarge = 11;

bool SolveSteinSmith(const ConstRef& A, const ConstRef& Q, int max_predicted_steps, MatrixXd* X_out,
                     double* relative_residual) {
  const Index n = A.rows();
  const double eps = std::numeric_limits<double>::epsilon();
  MatrixXd Aj = A, X = 0.5 * (Q + Q.transpose()), A2(n, n);
  double log_a_prev = 0.0;
  bool try_pd = true;
  for (int j = 0; j < kSmithMaxSteps; ++j) {
    const double a2 = Aj.squaredNorm();
    if (!std::isfinite(a2)) return false;
    if (a2 <= eps) break;                    // X_j is X to rounding
    AddCongruence(Aj, X, 1.0, &try_pd, &X);  // X += A_j X A_j^T (X is copied/factored before it is written)
    if (!X.allFinite()) return false;
    if (a2 * a2 <= eps) break;  // |A_{j+1}|_F^2 <= |A_j|_F^4 <= eps: no further increment
    if (j + 1 == std::min(kSmithMaxSteps, max_predicted_steps)) return false;  // budget spent
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
      if (needed > max_predicted_steps + 1) return false;
    }
    log_a_prev = log_a;
  }
  MatrixXd res(n, n);
  const double r = SteinResidualInto(A, Q, X, &res);
  if (!(r <= 1e-13)) return false;
  *relative_residual = r;
  X_out->swap(X);
  return true;
}

/// |X - A X A^T - Q|_F / max(|X|_F, tiny) (3 n^3 flops).
double SteinResidual(const ConstRef& A, const ConstRef& Q, const MatrixXd& X) {
  MatrixXd res(A.rows(), A.rows());
  return SteinResidualInto(A, Q, X, &res);
}

/// The Schur method: the real Schur form (LAPACK DGEES) and the recursive blocked Bartels-Stewart solve
/// (schur_stein.hpp), with a failed QR and a singular equation mapped to the Summary.
void SolveBySchur(const ConstRef& A, const ConstRef& Q, LyapunovSolution* sol) {
  Summary& sum = sol->summary;
  const Index n = A.rows();
  sum.method = "schur";
  const detail::RealSchur schur = detail::ComputeRealSchur(A);
  if (!schur.ok()) {
    sol->spectral_radius = std::numeric_limits<double>::quiet_NaN();
    sum.termination = Termination::kFailed;
    sum.message =
        "the QR algorithm failed to compute the Schur form of A (DGEES info " + std::to_string(schur.info) + ")";
    return;
  }
  sol->spectral_radius = schur.SpectralRadius();
  const std::string rho = " (spectral radius " + FormatNumber(sol->spectral_radius, 17) + ")";
  // Singular if |1 - lambda_i lambda_j| <= 64 eps for a pair of eigenvalues (a reciprocal pair, or a
  // complex pair on the unit circle, whose product is 1).
  double min_gap = std::numeric_limits<double>::infinity();
  for (Index i = 0; i < n; ++i)
    for (Index j = i; j < n; ++j)
      min_gap = std::min(min_gap, std::abs(1.0 - schur.eigenvalues(i) * schur.eigenvalues(j)));
  const bool pivots_ok =
      min_gap > 64 * std::numeric_limits<double>::epsilon() && detail::SolveLyapunovBySchur(schur, Q, &sol->X);
  if (!pivots_ok) {
    sum.termination = Termination::kSingular;
    sum.message =
        "the Stein equation X = A X A^T + Q is singular or nearly singular: A has eigenvalues with "
        "lambda_i lambda_j ~= 1" +
        rho;
    return;
  }
  sum.message = "real Schur form (DGEES) and the recursive blocked Bartels-Stewart solve";
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
  } else if (options.method != LyapunovMethod::kSchur &&
             SolveSteinSmith(
                 A, Q, options.method == LyapunovMethod::kAuto && n >= 1000 ? kAutoSmithStepsLarge : kSmithMaxSteps,
                 &sol.X, &sum.relative_residual)) {
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
