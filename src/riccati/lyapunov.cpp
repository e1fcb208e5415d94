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
// A_j X_j A_j^T = (A_j L)(A_j L)^T (DPOTRF + DTRMM + DSYRK, 2.3 n^3 flops), else by UpdateWithCongruenceLower
// (DTRMM + DSYR2K, 3 n^3); both exactly symmetric. Each squaring is one GEMM (2 n^3): 4.3 n^3 a step. The remainder
// after step j is X - X_j = A_j X A_j^T, of norm <= |A_j|_F^2 |X|_F: the iteration stops as soon as |A_j|_F^2 <= eps
// (the increment would be below rounding), and skips the last squaring when |A_j|_F^4 <= eps (then
// |A_{j+1}|_F^2 <= eps). It gives up (returns false) when A_j does not contract fast enough to converge
// within the step budget (rho(A) above about 0.998, transient growth, or a slow power-law decay of |A^k| as
// for the damped wave of paper 000), and the result is accepted only if its residual is <= 1e-13 (2.3 n^3
// flops more). About 39 n^3 flops at rho = 0.95 (9 steps), all BLAS level 3, against SB03MD's ~30 n^3 flops
// of mostly BLAS-2 Schur reduction (issue 24). X is kept in its lower triangle (what DPOTRF and DSYRK read
// and write) and mirrored once at the end; the n x n buffers are allocated once.
constexpr int kSmithMaxSteps = 14;

/// lower(*out) += alpha A X A^T for symmetric X (lower triangle read): by the Cholesky factor when X is
/// positive definite and *try_pd, else by UpdateWithCongruenceLower (and *try_pd turns false: a non-PD X_j
/// stays so in the Smith iteration).
void AddCongruence(const ConstRef& A, const MatrixXd& X, double alpha, bool* try_pd, detail::CongruenceWork* work,
                   MatrixXd* out) {
  if (*try_pd && detail::AddCongruenceOfPdLower(A, X, alpha, work, out)) return;
  *try_pd = false;
  detail::UpdateWithCongruenceLower(A, X, alpha, 1.0, work, out);
}

/// lower(*X) += A X A^T as AddCongruence, but *A may be overwritten (by A L, the DTRMM done in place: no
/// copy of A). The Smith iteration squares A_j before it calls this.
void AddCongruenceConsuming(MatrixXd* A, bool* try_pd, detail::CongruenceWork* work, MatrixXd* X) {
  const Index n = A->rows();
  if (*try_pd && n >= 32) {
    const int nf = detail::FortranInt(n);
    work->L = *X;
    int info = 0;
    dpotrf_("L", &nf, work->L.data(), &nf, &info, 1);
    if (info == 0) {
      const double one = 1.0;
      dtrmm_("R", "L", "N", "N", &nf, &nf, &one, work->L.data(), &nf, A->data(), &nf);  // A <- A L
      dsyrk_("L", "N", &nf, &nf, &one, A->data(), &nf, &one, X->data(), &nf);           // X += (A L)(A L)^T
      return;
    }
  }
  *try_pd = false;
  detail::UpdateWithCongruenceLower(*A, *X, 1.0, 1.0, work, X);
}

/// The relative residual |X - Q - A X A^T|_F / max(|X|_F, tiny) (2.3 or 3 n^3 flops), X symmetric (lower
/// triangle read); *res is workspace.
double SteinResidualLower(const ConstRef& A, const ConstRef& Q, const MatrixXd& X, detail::CongruenceWork* work,
                          MatrixXd* res) {
  *res = X - Q;
  bool try_pd = true;
  AddCongruence(A, X, -1.0, &try_pd, work, res);
  return detail::LowerFrobeniusNorm(*res) / std::max(detail::LowerFrobeniusNorm(X), kTiny);
}

// The Schur route costs DGEES (about 25 n^3 flops at a rate well below DGEMM's: measured 60-180 n^3 DGEMM
// flops' worth at n = 200-1000) plus about 9 n^3 in products, a Smith step 4.3 n^3: under kAuto the
// iteration gives up as soon as it predicts more than kAutoSmithStepsLarge steps for n >= 1000, where DGEES
// runs closest to the DGEMM rate (N = 2000, rho(A) = 0.9975: 13 steps, 56 n^3, against about 45 n^3).
constexpr int kAutoSmithStepsLarge = 11;

/// The step (counted as j in SolveSteinSmith) at which |A_j|_F^2 <= eps is predicted, from log |A_j|_F = log_a
/// and its drops over the last two squarings. Exponential decay c rho^k doubles the drop with every squaring.
/// With `power_law` (kAuto for n >= 1000), an early drop that shrinks instead (a power-law transient,
/// |A^k| ~ k^-p: paper 000's damped wave at N = 2000, whose rho(A) = 0.9975 shows only after k ~ 400; its
/// drops are 2.2, 1.0, 0.7, 0.6, ...) is extrapolated as constant: there the Smith iteration ran its 11
/// steps, about as long as the whole Schur route, before giving up. Small random matrices have irregular
/// early drops, and at n < 1000 a Smith step is cheap against DGEES: the rule is kept to the large case.
double PredictSmithSteps(int j, double log_a, double drop, double drop_prev, bool power_law) {
  const double target = 0.5 * std::log(std::numeric_limits<double>::epsilon());
  if (power_law && j <= 3 && drop_prev > 0.0 && drop < drop_prev) return j + 1 + (log_a - target) / drop;
  // ln |A_{2^i}| ~ ln c + 2^i ln rho with ln rho = -drop / 2^j (A_{j+1} = A_j^2).
  const double log_rho = -drop / std::ldexp(1.0, j);
  const double log_c = log_a - std::ldexp(1.0, j + 1) * log_rho;
  return std::log2((target - log_c) / log_rho);
}

// The single-precision tail. After step j has added D_j = W W^T (W = A_j L_j) to X, the rest is
//   X - X_{j+1} = sum_{m >= 1} A_j^m D_j A_j^mT = T_1 + T_2 + ...,   T_m = V_m V_m^T,  V_m = A_j V_{m-1},  V_0 = W
// (from X = X_j + A_j X A_j^T), with |T_m|_F <= tr(T_m) <= a2^m tr(D_j), a2 = |A_j|_F^2 >= |A_j|_2^2. The
// tail adds T_1 + T_2 computed in single precision (two SGEMMs and one SSYRK: about 3.3 n^3 of DGEMM time,
// against 5-5.3 for the squaring and the double-precision step it replaces) when, with
// b = eps / 4 |X_{j+1}|_F,
//   (a) its rounding is below b: kTailRounding u_s a2 tr(D_j) <= b, u_s = 2^-24 (a single-precision GEMM or
//       SYRK of these sizes errs by about u_s |V|_F^2; measured 0.4-0.9 u_s tr(T_1) at n = 200-400);
//   (b) the terms left out are below b: sum_{m >= 3} tr(T_m) <= a2^3 tr(D_j) / (1 - a2) <= b.
// At rho(A) = 0.95 (n = 200, 400) it replaces the ninth and last step; measured (a) 0.07-0.16 / 4 of b.
constexpr double kTailRounding = 4.0;
constexpr double kTailMaxA2 = 1e-3;  // a2 above this: (a) and (b) cannot hold for any useful D_j

bool TailFits(double a2, double trace_d, double x_norm) {
  const double b = 0.25 * std::numeric_limits<double>::epsilon() * x_norm;
  const double us = std::ldexp(1.0, -24);
  return kTailRounding * us * a2 * trace_d <= b && a2 * a2 * a2 * trace_d <= (1.0 - a2) * b;
}

/// lower(*X) += T_1 + T_2 of the tail above in single precision, from A_j (*Aj) and W = A_j L_j (*W). Allocates
/// nothing: a fresh buffer costs page faults (up to 14 us a page on the project's virtual machines, measured
/// +4 ms per solve at n = 200 with four fresh single-precision buffers, more than the tail saves). The
/// single-precision matrices live in n x n double buffers that are free at this point: *L (A_j and W in
/// single precision), *spare (V = [V_1, V_2], n x 2n) and, once A_j has been converted, *Aj (T).
void AddSinglePrecisionTail(MatrixXd* Aj, const MatrixXd& W, MatrixXd* L, MatrixXd* spare, MatrixXd* X) {
  using MapF = Eigen::Map<Eigen::MatrixXf>;
  const Index n = Aj->rows();
  const int nf = detail::FortranInt(n), n2 = detail::FortranInt(2 * n);
  float* l = reinterpret_cast<float*>(L->data());  // 2 n^2 floats
  MapF a(l, n, n), w(l + n * n, n, n), v(reinterpret_cast<float*>(spare->data()), n, 2 * n);
  a = Aj->cast<float>();
  w = W.cast<float>();
  const float one = 1.0f, zero = 0.0f;
  sgemm_("N", "N", &nf, &nf, &nf, &one, a.data(), &nf, w.data(), &nf, &zero, v.data(), &nf);          // V_1 = A_j W
  sgemm_("N", "N", &nf, &nf, &nf, &one, a.data(), &nf, v.data(), &nf, &zero, v.data() + n * n, &nf);  // V_2 = A_j V_1
  MapF t(reinterpret_cast<float*>(Aj->data()), n, n);
  ssyrk_("L", "N", &nf, &n2, &one, v.data(), &nf, &zero, t.data(), &nf);  // lower(T) = V_1 V_1^T + V_2 V_2^T
  X->triangularView<Eigen::Lower>() += t.cast<double>();
}

/// The squared Smith iteration (the comments above). True with *X_out, *relative_residual and *how (its
/// steps, and whether the single-precision tail ended it) when it converged to a residual <= 1e-13.
bool SolveSteinSmith(const ConstRef& A, const ConstRef& Q, int max_predicted_steps, bool power_law, MatrixXd* X_out,
                     double* relative_residual, std::string* how) {
  const Index n = A.rows();
  const double eps = std::numeric_limits<double>::epsilon();
  MatrixXd Aj = A, X = 0.5 * (Q + Q.transpose()), A2(n, n);
  detail::CongruenceWork work{MatrixXd(n, n), MatrixXd(n, n)};
  double a2 = Aj.squaredNorm(), log_a = 0.5 * std::log(a2), drop_prev = 0.0;
  bool try_pd = true, tail = false;
  int steps = 0;
  for (int j = 0; j < kSmithMaxSteps; ++j) {
    if (!std::isfinite(a2)) return false;
    if (a2 <= eps) break;              // X_j is X to rounding
    const bool last = a2 * a2 <= eps;  // |A_{j+1}|_F^2 <= |A_j|_F^4 <= eps: no further increment
    if (!last && j + 1 == std::min(kSmithMaxSteps, max_predicted_steps)) return false;  // budget spent
    ++steps;
    if (!last && try_pd && n >= 32 && a2 <= kTailMaxA2) {
      // X += A_j X A_j^T keeping A_j and W = A_j L (work.B): the tail may replace the rest.
      if (detail::AddCongruenceOfPdLower(Aj, X, 1.0, &work, &X)) {
        if (!X.diagonal().allFinite()) return false;
        if (TailFits(a2, work.B.squaredNorm(), detail::LowerFrobeniusNorm(X))) {
          AddSinglePrecisionTail(&Aj, work.B, &work.L, &A2, &X);
          tail = true;
          break;
        }
      } else {
        try_pd = false;
        detail::UpdateWithCongruenceLower(Aj, X, 1.0, 1.0, &work, &X);
        if (!X.allFinite()) return false;
      }
      A2.noalias() = Aj * Aj;
    } else {
      if (!last) A2.noalias() = Aj * Aj;                // A_{j+1}
      AddCongruenceConsuming(&Aj, &try_pd, &work, &X);  // X += A_j X A_j^T (X is copied/factored before it is written)
      // A PD X_j is a sum of PSD terms: |x_ik| <= sqrt(x_ii x_kk), so a finite diagonal means a finite X_j.
      if (!(try_pd ? X.diagonal().allFinite() : X.allFinite())) return false;
      if (last) break;
    }
    Aj.swap(A2);
    a2 = Aj.squaredNorm();
    if (a2 == 0.0) break;  // A_j = 0 (nilpotent A): X is exact
    const double log_a_next = 0.5 * std::log(a2);
    if (!std::isfinite(log_a_next)) return false;
    const double drop = log_a - log_a_next;
    log_a = log_a_next;
    // Predict the step at which |A_j|^2 <= eps and give up early if it lies beyond the budget (or A_j
    // stops contracting).
    if (j >= 2 || (power_law && j == 1)) {
      if (!(drop > 0.0)) return false;
      if (PredictSmithSteps(j, log_a, drop, drop_prev, power_law) > max_predicted_steps + 1) return false;
    }
    drop_prev = drop;
  }
  MatrixXd& res = A2;  // workspace
  const double r = SteinResidualLower(A, Q, X, &work, &res);
  if (!(r <= 1e-13)) return false;
  X.triangularView<Eigen::StrictlyUpper>() = X.transpose();
  *relative_residual = r;
  *how = "squared Smith iteration, " + std::to_string(steps) + " steps" +
         (tail ? " and the last two terms of the rest in single precision" : "");
  X_out->swap(X);
  return true;
}

/// |X - A X A^T - Q|_F / max(|X|_F, tiny) (3 n^3 flops).
double SteinResidual(const ConstRef& A, const ConstRef& Q, const MatrixXd& X) {
  const Index n = A.rows();
  MatrixXd res(n, n);
  detail::CongruenceWork work;
  return SteinResidualLower(A, Q, X, &work, &res);
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
  const bool large_auto = options.method == LyapunovMethod::kAuto && n >= 1000;
  if (n == 0) {
    sol.X.resize(0, 0);
    sol.spectral_radius = 0.0;
    sum.termination = Termination::kConverged;
    sum.relative_residual = 0.0;
    sum.method = options.method == LyapunovMethod::kSmith ? "smith" : "schur";
    sum.message = "empty state (n = 0)";
  } else if (options.method != LyapunovMethod::kSchur &&
             SolveSteinSmith(A, Q, large_auto ? kAutoSmithStepsLarge : kSmithMaxSteps, large_auto, &sol.X,
                             &sum.relative_residual, &sum.message)) {
    sum.termination = Termination::kConverged;
    sum.method = "smith";
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
