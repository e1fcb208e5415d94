// The Lyapunov certificate of discrete-time stability (CertifyStability, include/kfx/riccati.hpp), used by
// the DARE to prove that its solution is the stabilizing one.
//
// Derivation with references: docs/riccati.md.
//
// Lemma (Lyapunov). X = X^T > 0 and M = X - F X F^T > s I with s >= 0. For an eigenvalue lambda of F
// with left eigenvector v (v^* F = lambda v^*, |v| = 1): v^* M v = (1 - |lambda|^2) v^* X v, with
// v^* X v > 0 and v^* M v > s, so |lambda|^2 < 1 - s / v^* X v <= 1 - s / lambda_max(X) (< 1 for
// s = 0). And X = M + F X F^T >= M, so lambda_min(X) > s.
// For the filter DARE with F = A - K_p C and X = P the identity is P = F P F^T + Q + K_p R K_p^T
// (the Joseph form of P_filt), so M = Q + K_p R K_p^T: M >= Q, and the certificate succeeds whenever
// Q > 0 by a margin above the rounding bounds below, however close rho(F) is to 1.
//
// Definiteness in floating point (Demmel 1989; Higham, Accuracy and Stability of Numerical
// Algorithms, 2nd ed., Thm 10.5): if the Cholesky factorization completes on H~ = fl(H - sigma I),
// then L L^T = H~ + D with |D| <= gamma_{n+1} |L| |L^T| entrywise, so
//   |D|_2 <= |D|_F <= gamma_{n+1} |L|_F^2 = gamma_{n+1} tr(H~ + D) <= gamma_{n+1} / (1 - gamma_{n+1}) tr(H~),
// tr(H~) <= (1 + u) tr(H) when all pivots were positive, and forming the shifted diagonal adds at
// most u max |h_ii - sigma|. Hence lambda_min(H) >= sigma - c(H) with
//   c(H) = 2 (n + 2) u tr+(H) + n^2 2^-1022     (tr+ = sum |h_ii|; the last term covers underflow),
// i.e. DPOTRF completing on fl(H - (t + c(H)) I) proves lambda_min(H) > t.
// The computed M~ = fl(X - fl(fl(F X) F^T)): a GEMM satisfies |fl(AB) - AB| <= gamma_n |A| |B| in any
// summation order, so with T1 = fl(F X)
//   |M~ - M|_F <= gamma_n (|F|_F^2 |X|_F + |T1|_F |F|_F) + u / (1 - u) |M~|_F,
// and the symmetric matrix built from M~'s lower triangle (what DPOTRF reads) is within sqrt(2) times
// that of M in the 2-norm. delta = 2 (n + 2) u (|F|_F^2 |X|_F + |T1|_F |F|_F + |M~|_F) bounds it (the
// slack covers sqrt(2) gamma_n / (n u) and the rounding of the norms). Certifying every F' with
// |F' - F|_2 <= e adds (2 e |F|_F + e^2) |X|_F (F' X F'^T - F X F^T = E X F^T + F X E^T + E X E^T).
// Steps: DPOTRF on X - c(X) I (X > 0); DPOTRF on M~ - (delta + c(M~)) I (M > 0: rho(F) < 1); a few
// inverse-iteration steps with that factor estimate mu ~ lambda_min(M~) - delta - c(M~), and DPOTRF on
// M~ - (s + delta + c(M~)) I with s = mu / 2 (then mu / 16) certifies lambda_min(M) > s, giving the
// bound rho(F)^2 < 1 - s / x_max with x_max = min(|X|_F, |X|_1) >= lambda_max(X).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "base/lapack_fortran.hpp"
#include "kfx/riccati.hpp"
#include "kfx/validation.hpp"
#include "riccati/riccati_internal.hpp"

namespace kfx {
namespace detail {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;

/// c(H) above: DPOTRF completing on fl(H - (t + c(H)) I) proves lambda_min(H) > t.
double CholeskySlack(const MatrixXd& h) {
  const double n = static_cast<double>(h.rows());
  return 2 * (n + 2) * kUnitRoundoff * h.diagonal().cwiseAbs().sum() + n * n * std::numeric_limits<double>::min();
}

/// DPOTRF on fl(H - shift I), H = *h (lower triangle read; *h is overwritten). True if the
/// factorization completed with finite pivots (OpenBLAS's DPOTRF does not flag a NaN pivot itself).
bool CholeskyCompletes(MatrixXd* h, double shift) {
  const int n = FortranInt(h->rows());
  if (n == 0) return true;
  h->diagonal().array() -= shift;
  int info = 0;
  dpotrf_("L", &n, h->data(), &n, &info, 1);
  KFX_ASSERT(info >= 0);
  return info == 0 && h->diagonal().allFinite();
}

}  // namespace

StabilityCertificate CertifyUnchecked(const ConstRef& F, const ConstRef& X, double perturbation, MatrixPool* pool) {
  MatrixPool local;
  if (pool == nullptr) pool = &local;
  const auto start = std::chrono::steady_clock::now();
  StabilityCertificate cert;
  cert.summary.computation = "stability certificate";
  cert.summary.method = "Lyapunov certificate";
  cert.summary.termination = Termination::kUndecided;
  const auto done = [&cert, start](Termination termination, std::string message) {
    cert.summary.termination = termination;
    cert.summary.message = std::move(message);
    cert.summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return cert;
  };
  const Index n = F.rows();
  if (n == 0) {
    cert.spectral_radius_bound = 0.0;
    cert.min_eigenvalue_bound = std::numeric_limits<double>::infinity();
    return done(Termination::kConverged, "empty matrix");
  }
  const double u = kUnitRoundoff, nd = static_cast<double>(n);
  // H, T1, M from the pool and back to it on every return (Keep).
  struct Keep {
    MatrixPool* pool;
    MatrixXd H, T1, M;
    ~Keep() {
      pool->Give(std::move(H));
      pool->Give(std::move(T1));
      pool->Give(std::move(M));
    }
  } keep{pool, pool->Take(n, n), pool->Take(n, n), pool->Take(n, n)};
  MatrixXd& H = keep.H;
  H = X;
  if (!CholeskyCompletes(&H, CholeskySlack(H))) {
    return done(Termination::kUndecided,
                "X is not certified positive definite (Cholesky factorization of X - c I failed)");
  }
  MatrixXd& T1 = keep.T1;
  T1.noalias() = F * X;
  MatrixXd& M = keep.M;
  M = X;
  // Only M's lower triangle (what DPOTRF reads) is formed: GEMMs of its blocks, the same bound per entry.
  LowerOfSymmetricProduct(T1, F.transpose(), -1.0, true, &M);
  const double f_norm = F.norm(), x_norm = X.norm();
  double delta = 2 * (nd + 2) * u * (f_norm * f_norm * x_norm + T1.norm() * f_norm + LowerFrobeniusNorm(M));
  if (perturbation > 0) delta += (2 * perturbation * f_norm + perturbation * perturbation) * x_norm * (1 + 4 * u);
  if (!M.allFinite() || !std::isfinite(delta)) return done(Termination::kUndecided, "X - F X F^T overflows");
  const double c_m = CholeskySlack(M);
  H = M;
  if (!CholeskyCompletes(&H, delta + c_m)) {
    return done(Termination::kUndecided,
                "X - F X F^T is not certified positive definite (Cholesky factorization of M - (delta + c) I "
                "failed, delta = " +
                    FormatNumber(delta) + ")");
  }
  cert.spectral_radius_bound = 1.0;
  cert.min_eigenvalue_bound = 0.0;
  std::string proven = "rho(F) < 1 proven";
  // Inverse iteration with the factor: mu = 1 / |H~^{-1} x|, |x| = 1, estimates lambda_min(H~) from above.
  Eigen::VectorXd x(n);
  for (Index i = 0; i < n; ++i) x(i) = (i % 2 == 0 ? 1.0 : -1.0) * (1.0 + static_cast<double>(i % 7) / 7.0);
  double mu = 0.0;
  for (int it = 0; it < 8; ++it) {
    x /= x.norm();
    H.triangularView<Eigen::Lower>().solveInPlace(x);
    H.triangularView<Eigen::Lower>().transpose().solveInPlace(x);
    const double y_norm = x.norm();
    if (!(y_norm > 0) || !std::isfinite(y_norm)) break;
    mu = 1.0 / y_norm;
  }
  const double x_max = std::min(x_norm, X.cwiseAbs().colwise().sum().maxCoeff()) * (1 + 4 * (nd + 2) * u);
  for (const double fraction : {0.5, 0.0625}) {
    const double s = fraction * mu;
    if (!(s > 0) || !(x_max > 0)) break;
    H = M;
    if (CholeskyCompletes(&H, s + delta + c_m)) {
      // rho^2 < 1 - s / x_max <= fl(1 - fl(s / x_max)) + 2u; sqrt and the sum add one rounding each.
      const double rho_sq = std::max(0.0, 1.0 - s / x_max);
      cert.spectral_radius_bound = std::min(1.0, std::sqrt(rho_sq + 4 * u) * (1 + 2 * u));
      cert.min_eigenvalue_bound = s;
      proven = "rho(F) <= " + FormatNumber(cert.spectral_radius_bound, 6) + " and lambda_min(X) >= " + FormatNumber(s) +
               " proven";
      break;
    }
  }
  return done(Termination::kConverged, proven);
}

StabilizingVerdict JudgeStabilizing(const ConstRef& F, double perturbation, bool exact_eigenvalues,
                                    double stability_margin, double psd_tolerance, DareSolution* sol,
                                    MatrixPool* pool) {
  StabilizingVerdict v;
  sol->eigenvalues_exact = true;  // until the certificate's bounds are taken
  sol->lyapunov_certified = false;
  if (!exact_eigenvalues) {
    const StabilityCertificate cert = CertifyUnchecked(F, sol->P_pred, perturbation, pool);
    // Proven: P > 0 and rho(F) < 1 - margin (for margin 0 the bare certificate suffices).
    sol->lyapunov_certified =
        cert.certified() && (stability_margin == 0.0 || cert.spectral_radius_bound < 1.0 - stability_margin);
    v.stable = v.psd = sol->lyapunov_certified;
    if (sol->lyapunov_certified && cert.spectral_radius_bound < 1.0 && cert.min_eigenvalue_bound > 0.0) {
      sol->closed_loop_spectral_radius = cert.spectral_radius_bound;
      sol->min_eigenvalue = cert.min_eigenvalue_bound;
      sol->eigenvalues_exact = false;
    }
  }
  if (sol->eigenvalues_exact) {  // asked for, not proven, or proven without a bound below 1 to report
    sol->closed_loop_spectral_radius = SpectralRadiusUnchecked(F);
    sol->min_eigenvalue = MinEigenvalue(sol->P_pred);
    if (!sol->lyapunov_certified) {
      v.stable = sol->closed_loop_spectral_radius < 1.0 - stability_margin;
      v.psd = sol->min_eigenvalue >= -psd_tolerance * std::max(sol->P_pred.norm(), kTiny);
    }
  }
  return v;
}

}  // namespace detail

StabilityCertificate CertifyStability(const Eigen::Ref<const Eigen::MatrixXd>& F,
                                      const Eigen::Ref<const Eigen::MatrixXd>& X, double perturbation) {
  RequireSquare("F", F);
  RequireFinite("F", F);
  RequireShape("X", X, F.rows(), F.rows());
  RequireFinite("X", X);
  if (!(perturbation >= 0.0 && std::isfinite(perturbation))) {
    throw Error("perturbation: expected a finite value >= 0, got " + FormatNumber(perturbation));
  }
  Eigen::MatrixXd Xs = X;
  detail::SymmetrizeInPlace(Xs);
  return detail::CertifyUnchecked(F, Xs, perturbation);
}

}  // namespace kfx
