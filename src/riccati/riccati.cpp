// Riccati and Lyapunov solvers (API and equations: include/kfx/riccati.hpp).
//
// Filter DARE:  P = A P A^T + Q - A P C^T (C P C^T + R)^{-1} C P A^T
//                 = A P (I + G P)^{-1} A^T + Q,             G = C^T R^{-1} C.
// This is the control DARE X = Ã^T X (I + G X)^{-1} Ã + Q of the dual system Ã = A^T, B̃ = C^T
// (scipy.linalg.solve_discrete_are(A^T, C^T, Q, R) returns the same P), so both methods below are
// run on the dual problem:
//
//  - kDoubling: structure-preserving doubling algorithm, E.K.-W. Chu, H.-Y. Fan, W.-W. Lin,
//    "A structure-preserving doubling algorithm for continuous-time algebraic Riccati equations",
//    Linear Algebra Appl. 396 (2005) 55-80, and its discrete-time form for
//    X = Ã^T X (I + G X)^{-1} Ã + H (E.K.-W. Chu, H.-Y. Fan, W.-W. Lin, C.-S. Wang,
//    "Structure-preserving algorithms for periodic discrete-time algebraic Riccati equations",
//    Int. J. Control 77 (2004); convergence: W.-W. Lin, S.-F. Xu, SIAM J. Matrix Anal. Appl. 28
//    (2006) 26-39):
//        A_0 = Ã = A^T,  G_0 = C^T R^{-1} C,  H_0 = Q,   W_k = I + G_k H_k,
//        A_{k+1} = A_k W_k^{-1} A_k,
//        G_{k+1} = G_k + A_k W_k^{-1} G_k A_k^T,
//        H_{k+1} = H_k + A_k^T H_k W_k^{-1} A_k,
//    H_k -> P quadratically when (A, C) is detectable and (A, Q^{1/2}) has no unreachable mode on
//    the unit circle (A_k = O(rho(A - K_p C)^{2^k})); linearly in the critical case. H_k is the
//    Riccati iterate after 2^k steps started at P = 0, so it converges to the smallest PSD
//    solution; that is the stabilizing one unless (A, Q^{1/2}) has unreachable modes outside the
//    unit circle (e.g. Q = 0 with unstable A), which is why kAuto falls back to the Schur method.
//  - kSchur: SLICOT SB02OD (generalized Schur / QZ on the extended symplectic pencil,
//    P. Van Dooren, SIAM J. Sci. Stat. Comput. 2 (1981) 121-135) with DICO = 'D' on (A^T, C^T).
//
// Either result then goes through Finalize(): symmetrize, gains, residual, refinement, the
// stability proof (Lyapunov certificate, CertifyUnchecked; the closed-loop eigenvalues by DGEEV
// and lambda_min(P) by DSYEVR only when it cannot decide or when asked for), acceptance. Failures
// are diagnosed with PBH rank tests (Diagnose).
#include "kfx/riccati.hpp"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

#include "base/lapack_fortran.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using ConstRef = Eigen::Ref<const Eigen::MatrixXd>;

/// "tiny" in the relative residuals: the smallest normal double.
constexpr double kTiny = std::numeric_limits<double>::min();
/// A result is accepted (kConverged) only if its relative residual is at most this. Solutions of
/// well-posed problems reach 1e-15..1e-13; 1e-8 leaves room for ill-conditioned ones while
/// rejecting anything that is not a solution.
constexpr double kResidualAcceptance = 1e-8;
/// P counts as PSD when lambda_min(P) >= -kPsdTolerance * |P|_F (rounding of a PSD matrix with
/// zero eigenvalues gives about n * eps * |P|).
constexpr double kPsdTolerance = 1e-10;
/// PBH rank tests: [A - lambda I; C] (or [A - lambda I, Q^{1/2}]) is rank deficient when its
/// smallest singular value is <= kPbhRankTolerance * its largest one. About sqrt(eps): a defective
/// eigenvalue is computed with an error of order sqrt(eps) |A|, which the test must tolerate.
constexpr double kPbhRankTolerance = 1e-7;
/// Eigenvalues with ||lambda| - 1| <= kUnitCircleBand count as on the unit circle, those with
/// |lambda| >= 1 - kUnitCircleBand as not asymptotically stable (PBH tests).
constexpr double kUnitCircleBand = 1e-6;
/// Doubling is declared divergent when |H_k|_F or |G_k|_F exceeds this factor times its start.
constexpr double kDivergenceGrowth = 1e100;

int FortranInt(Index n) {
  KFX_ASSERT(n >= 0 && n <= static_cast<Index>(INT_MAX));
  return static_cast<int>(n);
}

std::string FormatDouble(double v, int precision = 3) {
  std::ostringstream os;
  os.precision(precision);
  os << v;
  return os.str();
}

/// In-place 0.5 (M + M^T) without a temporary.
void SymmetrizeInPlace(MatrixXd& m) {
  const Index n = m.rows();
  for (Index j = 0; j < n; ++j) {
    for (Index i = 0; i < j; ++i) {
      const double v = 0.5 * (m(i, j) + m(j, i));
      m(i, j) = v;
      m(j, i) = v;
    }
  }
}

/// *out = beta * *out + alpha * A S A^T for symmetric S (only S's lower triangle is read), in 3 n^3
/// flops instead of two GEMMs' 4 n^3: with S = L + L^T (L the lower triangle of S, diagonal halved)
/// and B = A L (DTRMM, n^3), A S A^T = B A^T + A B^T (DSYR2K, 2 n^3, lower triangle; mirrored).
/// The same device as AddCongruence in src/kalman_filter.cpp. Below n = 32, Eigen's products.
void UpdateWithCongruence(const ConstRef& A, const MatrixXd& S, double alpha, double beta, MatrixXd* out) {
  const Index n = A.rows();
  if (n < 32) {
    const MatrixXd AS = A * S.selfadjointView<Eigen::Lower>();
    if (beta == 0.0) out->setZero(n, n);
    if (beta != 1.0 && beta != 0.0) *out *= beta;
    out->noalias() += alpha * (AS * A.transpose());
    SymmetrizeInPlace(*out);
    return;
  }
  const int nf = FortranInt(n), lda = FortranInt(A.outerStride());
  MatrixXd L = S;
  L.diagonal() *= 0.5;
  MatrixXd B = A;
  const double one = 1.0;
  dtrmm_("R", "L", "N", "N", &nf, &nf, &one, L.data(), &nf, B.data(), &nf);
  dsyr2k_("L", "N", &nf, &nf, &alpha, B.data(), &nf, A.data(), &lda, &beta, out->data(), &nf);
  out->triangularView<Eigen::StrictlyUpper>() = out->transpose();
}

/// Eigenvalues of a general real matrix by LAPACK DGEEV (eigenvalues only). About 4x faster than
/// Eigen::EigenSolver at n = 400 (blocked Hessenberg reduction). Returns false if QR failed.
bool Eigenvalues(const ConstRef& a_in, Eigen::VectorXcd* eig) {
  const int n = FortranInt(a_in.rows());
  eig->resize(n);
  if (n == 0) return true;
  MatrixXd a = a_in;
  std::vector<double> wr(n), wi(n);
  double dummy = 0.0, work_query = 0.0;
  int lwork = -1, info = 0, one = 1;
  dgeev_("N", "N", &n, a.data(), &n, wr.data(), wi.data(), &dummy, &one, &dummy, &one, &work_query, &lwork, &info, 1,
         1);
  lwork = std::max(static_cast<int>(work_query), 3 * n);
  std::vector<double> work(static_cast<std::size_t>(lwork));
  dgeev_("N", "N", &n, a.data(), &n, wr.data(), wi.data(), &dummy, &one, &dummy, &one, work.data(), &lwork, &info, 1,
         1);
  KFX_ASSERT(info >= 0);
  if (info != 0) return false;
  for (int i = 0; i < n; ++i) (*eig)(i) = std::complex<double>(wr[i], wi[i]);
  return true;
}

double SpectralRadiusUnchecked(const ConstRef& a) {
  if (a.rows() == 0) return 0.0;
  Eigen::VectorXcd eig;
  if (!Eigenvalues(a, &eig)) return std::numeric_limits<double>::quiet_NaN();
  return eig.cwiseAbs().maxCoeff();
}

/// Smallest eigenvalue of a symmetric matrix (LAPACK DSYEVR, range 'I', il = iu = 1).
double MinEigenvalue(const MatrixXd& p) {
  const int n = FortranInt(p.rows());
  if (n == 0) return 0.0;
  MatrixXd a = p;
  const double vl = 0.0, vu = 0.0, abstol = 0.0;
  const int il = 1;
  int found = 0, info = 0, lwork = -1, liwork = -1, iwork_query = 0, one = 1;
  double w_query = 0.0, z_dummy = 0.0;
  std::vector<double> w(n);
  std::vector<int> isuppz(2 * static_cast<std::size_t>(n));
  dsyevr_("N", "I", "U", &n, a.data(), &n, &vl, &vu, &il, &il, &abstol, &found, w.data(), &z_dummy, &one, isuppz.data(),
          &w_query, &lwork, &iwork_query, &liwork, &info, 1, 1, 1);
  lwork = std::max(static_cast<int>(w_query), 26 * n);
  liwork = std::max(iwork_query, 10 * n);
  std::vector<double> work(static_cast<std::size_t>(lwork));
  std::vector<int> iwork(static_cast<std::size_t>(liwork));
  dsyevr_("N", "I", "U", &n, a.data(), &n, &vl, &vu, &il, &il, &abstol, &found, w.data(), &z_dummy, &one, isuppz.data(),
          work.data(), &lwork, iwork.data(), &liwork, &info, 1, 1, 1);
  KFX_ASSERT(info >= 0);
  if (info != 0 || found < 1) return std::numeric_limits<double>::quiet_NaN();
  return w[0];
}

// ------------------------------------------------------------------------------------------------
// Lyapunov stability certificate (CertifyStability; derivation with references in docs/riccati.md).
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

constexpr double kUnitRoundoff = 0.5 * std::numeric_limits<double>::epsilon();

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

/// CertifyStability on validated input (F, X square of the same size, finite, X exactly symmetric).
StabilityCertificate CertifyUnchecked(const ConstRef& F, const ConstRef& X, double perturbation) {
  StabilityCertificate cert;
  const Index n = F.rows();
  if (n == 0) {
    cert.certified = true;
    cert.spectral_radius_bound = 0.0;
    cert.min_eigenvalue_bound = std::numeric_limits<double>::infinity();
    cert.message = "empty matrix";
    return cert;
  }
  const double u = kUnitRoundoff, nd = static_cast<double>(n);
  MatrixXd H = X;
  if (!CholeskyCompletes(&H, CholeskySlack(H))) {
    cert.message = "X is not certified positive definite (Cholesky factorization of X - c I failed)";
    return cert;
  }
  MatrixXd T1(n, n);
  T1.noalias() = F * X;
  MatrixXd M = X;
  M.noalias() -= T1 * F.transpose();
  const double f_norm = F.norm(), x_norm = X.norm();
  double delta = 2 * (nd + 2) * u * (f_norm * f_norm * x_norm + T1.norm() * f_norm + M.norm());
  if (perturbation > 0) delta += (2 * perturbation * f_norm + perturbation * perturbation) * x_norm * (1 + 4 * u);
  if (!M.allFinite() || !std::isfinite(delta)) {
    cert.message = "X - F X F^T overflows";
    return cert;
  }
  const double c_m = CholeskySlack(M);
  H = M;
  if (!CholeskyCompletes(&H, delta + c_m)) {
    cert.message =
        "X - F X F^T is not certified positive definite (Cholesky factorization of M - (delta + c) I "
        "failed, delta = " +
        FormatDouble(delta) + ")";
    return cert;
  }
  cert.certified = true;
  cert.spectral_radius_bound = 1.0;
  cert.min_eigenvalue_bound = 0.0;
  cert.message = "rho(F) < 1 proven";
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
      cert.message = "rho(F) <= " + FormatDouble(cert.spectral_radius_bound, 6) +
                     " and lambda_min(X) >= " + FormatDouble(s) + " proven";
      break;
    }
  }
  return cert;
}

/// What a method hands to Finalize.
struct Candidate {
  MatrixXd P;                               ///< empty if the method produced nothing usable.
  DareStatus status = DareStatus::kFailed;  ///< kConverged if the method itself succeeded.
  std::string message;
  DareMethod method = DareMethod::kDoubling;
  int iterations = 0;
};

// ------------------------------------------------------------------------------------------------
// Structure-preserving doubling (see the file comment). Per step, with one LU of W_k:
//   Y1 = W_k^{-1} A_k                                   (DGETRF 2/3 n^3, DGETRS 2 n^3)
//   D   = A_k^T (H_k Y1)         = H_{k+1} - H_k        (2 GEMMs)
// and, unless H_{k+1} passed the stopping test (then they are not needed),
//   Y2 = W_k^{-1} G_k                                   (DGETRS 2 n^3)
//   G  += A_k Y2 A_k^T                                  (DTRMM + DSYR2K, 3 n^3; UpdateWithCongruence)
//   A_{k+1} = A_k Y1                                    (1 GEMM)
// plus W_k = I + G_k H_k (1 GEMM): about 15.7 n^3 flops per step (8.7 n^3 for the last), all in
// BLAS 3. H_k W_k^{-1} and
// W_k^{-1} G_k are symmetric in exact arithmetic, H and G are re-symmetrized after each step.
// The increment D is formed explicitly, so the stopping test |D|_F <= tol |H_{k+1}|_F has no
// cancellation floor.
Candidate SolveByDoubling(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R,
                          const DareOptions& options) {
  Candidate out;
  out.method = DareMethod::kDoubling;
  const Index n = A.rows();
  const int nf = FortranInt(n);

  // G_0 = C^T R^{-1} C = Z^T Z with Z = L^{-1} C, R = L L^T (validated PD, so LLT succeeds).
  Eigen::LLT<MatrixXd> r_llt(R);
  if (r_llt.info() != Eigen::Success) {
    out.message = "doubling: Cholesky factorization of R failed";
    return out;
  }
  MatrixXd Z = C;
  r_llt.matrixL().solveInPlace(Z);
  MatrixXd G(n, n);
  G.noalias() = Z.transpose() * Z;
  MatrixXd H = Q;
  SymmetrizeInPlace(H);
  MatrixXd Ak = A.transpose();

  MatrixXd W(n, n), Y1(n, n), Y2(n, n), T(n, n), D(n, n);
  std::vector<int> ipiv(static_cast<std::size_t>(std::max<Index>(n, 1)));
  const double h_start = std::max(H.norm(), kTiny);
  const double g_start = std::max(G.norm(), kTiny);

  double last_change = std::numeric_limits<double>::infinity();
  for (int k = 1; k <= options.max_iterations; ++k) {
    W.noalias() = G * H;
    W.diagonal().array() += 1.0;
    int info = 0;
    dgetrf_(&nf, &nf, W.data(), &nf, ipiv.data(), &info);
    KFX_ASSERT(info >= 0);
    if (info > 0) {
      out.iterations = k;
      out.P = H;
      out.message = "doubling: W = I + G_k H_k is singular at step " + std::to_string(k) + " (DGETRF info " +
                    std::to_string(info) + ")";
      return out;
    }
    Y1 = Ak;  // W_k^{-1} A_k
    dgetrs_("N", &nf, &nf, W.data(), &nf, ipiv.data(), Y1.data(), &nf, &info, 1);
    KFX_ASSERT(info == 0);
    T.noalias() = H * Y1;
    D.noalias() = Ak.transpose() * T;
    H += D;
    SymmetrizeInPlace(H);
    const double change = D.norm();
    const double h_norm = H.norm();
    out.iterations = k;
    if (!std::isfinite(change) || !std::isfinite(h_norm) || h_norm > kDivergenceGrowth * h_start) {
      out.message = "doubling diverged at step " + std::to_string(k) + " (|H_k|_F = " + FormatDouble(h_norm) + ")";
      out.P.resize(0, 0);  // nothing usable
      return out;
    }
    last_change = change / std::max(h_norm, kTiny);
    if (change <= options.tolerance * h_norm) {  // converged: G_{k+1}, A_{k+1} are not needed
      out.P = std::move(H);
      out.status = DareStatus::kConverged;
      out.message =
          "doubling converged in " + std::to_string(k) + " steps (relative change " + FormatDouble(last_change) + ")";
      return out;
    }
    Y2 = G;  // W_k^{-1} G_k (symmetric in exact arithmetic), with the same LU factors
    dgetrs_("N", &nf, &nf, W.data(), &nf, ipiv.data(), Y2.data(), &nf, &info, 1);
    KFX_ASSERT(info == 0);
    UpdateWithCongruence(Ak, Y2, 1.0, 1.0, &G);  // G += A_k Y2 A_k^T (exactly symmetric)
    T.noalias() = Ak * Y1;
    Ak.swap(T);
    const double g_norm = G.norm();
    if (!std::isfinite(g_norm) || g_norm > kDivergenceGrowth * g_start) {
      out.message = "doubling diverged at step " + std::to_string(k) + " (|G_k|_F = " + FormatDouble(g_norm) + ")";
      out.P.resize(0, 0);
      return out;
    }
  }
  out.P = std::move(H);
  out.status = DareStatus::kNotConverged;
  out.message = "doubling: no convergence in " + std::to_string(options.max_iterations) +
                " steps (last relative change " + FormatDouble(last_change) + " > tolerance " +
                FormatDouble(options.tolerance) + ")";
  return out;
}

// ------------------------------------------------------------------------------------------------
// Generalized Schur method: SLICOT SB02OD on the dual control problem (A^T, B = C^T, Q, R, L = 0).
std::vector<double> ColumnMajorCopy(const ConstRef& m, int ld) {
  std::vector<double> buf(static_cast<std::size_t>(ld) * static_cast<std::size_t>(std::max<Index>(m.cols(), 1)), 0.0);
  for (Index j = 0; j < m.cols(); ++j)
    for (Index i = 0; i < m.rows(); ++i) buf[static_cast<std::size_t>(j) * ld + i] = m(i, j);
  return buf;
}

const char* Sb02odInfoText(int info) {
  switch (info) {
    case 1:
      return "the extended matrix pencil is singular";
    case 2:
      return "the QZ algorithm failed";
    case 3:
      return "reordering of the generalized eigenvalues failed";
    case 4:
      return "after reordering, rounding moved eigenvalues across the unit circle";
    case 5:
      return "the stable deflating subspace does not have dimension n (eigenvalues on or near the unit circle)";
    case 6:
      return "U11 is singular (rcond < eps): no stabilizing solution can be formed";
    default:
      return "unknown error";
  }
}

Candidate SolveBySchur(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R) {
  Candidate out;
  out.method = DareMethod::kSchur;
  const int n = FortranInt(A.rows());
  const int m = FortranInt(C.rows());
  const int p = 0;  // not referenced with FACT = 'N'
  const int ld_n = std::max(1, n);
  const int ld_m = std::max(1, m);
  const int ld_st = std::max(1, 2 * n + m);
  const int ld_u = std::max(1, 2 * n);
  const int ld_l = 1;

  const MatrixXd At = A.transpose();
  const MatrixXd Ct = C.transpose();
  std::vector<double> a = ColumnMajorCopy(At, ld_n);
  std::vector<double> b = ColumnMajorCopy(Ct, ld_n);
  std::vector<double> q = ColumnMajorCopy(Q, ld_n);
  std::vector<double> r = ColumnMajorCopy(R, ld_m);
  std::vector<double> l(1, 0.0);
  std::vector<double> x(static_cast<std::size_t>(ld_n) * std::max(1, n));
  const std::size_t two_n = static_cast<std::size_t>(std::max(1, 2 * n));
  std::vector<double> alfar(two_n), alfai(two_n), beta(two_n);
  std::vector<double> s(static_cast<std::size_t>(ld_st) * static_cast<std::size_t>(ld_st));
  std::vector<double> t(static_cast<std::size_t>(ld_st) * two_n);
  std::vector<double> u(static_cast<std::size_t>(ld_u) * two_n);
  std::vector<int> iwork(static_cast<std::size_t>(std::max({1, m, 2 * n})));
  std::vector<kfx_fortran_logical> bwork(two_n);
  // Minimum workspace of SB02OD plus room for the blocked QZ (DGGES) and reordering.
  const int ldwork = std::max({14 * n + 23, 16 * n, 2 * n + m, 3 * m}) + 64 * (2 * n + m);
  std::vector<double> dwork(static_cast<std::size_t>(ldwork));
  double rcond = 0.0;
  const double tol = 0.0;  // SB02OD default (machine epsilon) for the pencil compression
  int info = 0;
  sb02od_("D", "B", "N", "U", "Z", "S", &n, &m, &p, a.data(), &ld_n, b.data(), &ld_n, q.data(), &ld_n, r.data(), &ld_m,
          l.data(), &ld_l, &rcond, x.data(), &ld_n, alfar.data(), alfai.data(), beta.data(), s.data(), &ld_st, t.data(),
          &ld_st, u.data(), &ld_u, &tol, iwork.data(), dwork.data(), &ldwork, bwork.data(), &info, 1, 1, 1, 1, 1, 1);
  KFX_ASSERT(info >= 0);  // a negative info is an argument error: a bug here
  if (info != 0) {
    out.message = std::string("SB02OD failed (info ") + std::to_string(info) + "): " + Sb02odInfoText(info);
    return out;
  }
  out.P = Eigen::Map<const MatrixXd, 0, Eigen::OuterStride<>>(x.data(), n, n, Eigen::OuterStride<>(ld_n));
  out.status = DareStatus::kConverged;
  out.message = "SB02OD: rcond(U11) = " + FormatDouble(rcond);
  if (rcond < 1e-10)
    out.message += " (ill-conditioned: expect a loss of about " + FormatDouble(-std::log10(std::max(rcond, kTiny)), 2) +
                   " digits)";
  return out;
}

// ------------------------------------------------------------------------------------------------
// Stein equation X = A X A^T + Q by SLICOT SB03MD (Barraud 1977: real Schur form A = U S U^T, then a
// back substitution on S^T Xbar S - Xbar = Cbar). SB03MD solves op(A)^T X op(A) - X = scale * C;
// with TRANA = 'T' (op(A) = A^T) and C = -Q this is A X A^T - X = -scale Q, so X_true = X / scale
// (SB03MD picks scale <= 1 to avoid overflow). Returns SB03MD's info (0, 1..n: QR failed,
// n + 1: eigenvalues with lambda_i lambda_j ~= 1, perturbed values used); *rho = rho(A) from the
// Schur form when available, and the eigenvalues of A in *eig if eig is not null.
int SolveSteinSb03md(const ConstRef& A, const ConstRef& Q, MatrixXd* X, double* scale_out, double* rho,
                     Eigen::VectorXcd* eig = nullptr) {
  const int nf = FortranInt(A.rows());
  MatrixXd a = A;
  MatrixXd u(nf, nf);
  *X = -0.5 * (Q + Q.transpose());
  std::vector<double> wr(static_cast<std::size_t>(nf)), wi(static_cast<std::size_t>(nf));
  std::vector<int> iwork(1);
  // Minimum for JOB = 'X' is max(n^2, 3n) (2n^2 + 2n in older releases); the extra 64 n lets
  // DGEES use its blocked code.
  const int ldwork = std::max(2 * nf * nf + 3 * nf, 1) + 64 * nf;
  std::vector<double> dwork(static_cast<std::size_t>(ldwork));
  double scale = 1.0, sep = 0.0, ferr = 0.0;
  int info = 0;
  const int ld = std::max(1, nf);
  sb03md_("D", "X", "N", "T", &nf, a.data(), &ld, u.data(), &ld, X->data(), &ld, &scale, &sep, &ferr, wr.data(),
          wi.data(), iwork.data(), dwork.data(), &ldwork, &info, 1, 1, 1, 1);
  KFX_ASSERT(info >= 0);  // a negative info is an argument error: a bug here
  *rho = 0.0;
  if (info == 0 || info == nf + 1) {
    for (int i = 0; i < nf; ++i) *rho = std::max(*rho, std::hypot(wr[i], wi[i]));
    if (eig) {
      eig->resize(nf);
      for (int i = 0; i < nf; ++i) (*eig)(i) = std::complex<double>(wr[i], wi[i]);
    }
  } else {
    *rho = SpectralRadiusUnchecked(A);
  }
  *scale_out = scale;
  if (info == 0 && scale > 0.0 && scale != 1.0) *X /= scale;
  if (info == 0) SymmetrizeInPlace(*X);
  return info;
}

// ------------------------------------------------------------------------------------------------
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
};

/// Lower triangle -> upper triangle.
void MirrorLower(MatrixXd* m) { m->triangularView<Eigen::StrictlyUpper>() = m->transpose(); }

Derived Derive(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R, const ConstRef& P_in) {
  Derived d;
  d.P = P_in;
  SymmetrizeInPlace(d.P);
  MatrixXd Z = C * d.P;  // m x n: C P
  d.S = R;
  d.S.noalias() += Z * C.transpose();
  SymmetrizeInPlace(d.S);
  Eigen::LLT<MatrixXd> s_llt(d.S);
  if (s_llt.info() != Eigen::Success || !d.S.allFinite()) return d;
  d.s_ok = true;
  s_llt.matrixL().solveInPlace(Z);  // Z = L^{-1} C P
  d.P_filt = d.P;
  d.P_filt.selfadjointView<Eigen::Lower>().rankUpdate(Z.transpose(), -1.0);  // P - Z^T Z
  MirrorLower(&d.P_filt);
  s_llt.matrixU().solveInPlace(Z);  // L^{-T} L^{-1} C P = S^{-1} C P = K_f^T
  d.K_f = Z.transpose();
  d.res = d.P - Q;
  UpdateWithCongruence(A, d.P_filt, -1.0, 1.0, &d.res);  // P - Q - A P_filt A^T
  d.residual = d.res.norm() / std::max(d.P.norm(), kTiny);
  if (!std::isfinite(d.residual)) d.residual = std::numeric_limits<double>::infinity();
  return d;
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

/// Refinement of an accepted solution (DareOptions::refine). The Riccati map contracts errors like
/// E -> A_cl E A_cl^T (A_cl = A - K_p C), so one fixed-point step P <- F(P) divides the residual by
/// about rho(A_cl)^{-2}: doubling's accumulated rounding (relative residual ~1e-13 at n = 200..400,
/// vs ~1e-15 attainable) is removed in 2-3 steps of ~5.5 n^3 flops each (a doubling step is ~16 n^3),
/// until the residual is <= kRefinementTarget. A step is kept only if it at least halves the residual. If rho(A_cl) is
/// close to 1 the fixed point stalls; then one Newton (Hewer/Kleinman) step solves the Stein equation
///   E = A_cl E A_cl^T + (F(P) - P),   P <- P + E
/// (the Newton step for F(P) - P = 0, since F'(P)[E] = A_cl E A_cl^T; G.A. Hewer, IEEE TAC 16
/// (1971) 382-384), about 25 n^3 flops with SB03MD, kept only if it lowers the residual.
int Refine(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R, Derived* d) {
  int accepted = 0;
  for (int step = 0; step < kMaxFixedPointSteps && d->residual > kRefinementTarget; ++step) {
    Derived next = Derive(A, C, Q, R, d->P - d->res);
    if (!next.s_ok || !(next.residual <= 0.5 * d->residual)) break;
    *d = std::move(next);
    ++accepted;
  }
  if (d->residual > kNewtonThreshold) {
    AddPredictorGain(A, d);
    MatrixXd closed_loop = A;
    closed_loop.noalias() -= d->K_p * C;
    MatrixXd E;
    double scale = 1.0, rho = 0.0;
    const MatrixXd minus_res = -d->res;  // F(P) - P
    const int info = SolveSteinSb03md(closed_loop, minus_res, &E, &scale, &rho);
    if (info == 0 && rho < 1.0 && E.allFinite()) {
      Derived next = Derive(A, C, Q, R, d->P + E);
      if (next.s_ok && next.residual < d->residual) {
        *d = std::move(next);
        ++accepted;
      }
    }
  }
  return accepted;
}

DareSolution Finalize(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R, Candidate cand,
                      const DareOptions& options) {
  DareSolution sol;
  DareSummary& sum = sol.summary;
  sum.method_used = cand.method;
  sum.iterations = cand.iterations;
  sum.status = cand.status;
  sum.message = cand.message;
  sum.relative_residual = std::numeric_limits<double>::infinity();
  sum.closed_loop_spectral_radius = std::numeric_limits<double>::quiet_NaN();
  sum.min_eigenvalue = std::numeric_limits<double>::quiet_NaN();
  if (cand.P.size() == 0 && A.rows() > 0) {
    if (sum.status == DareStatus::kConverged) sum.status = DareStatus::kFailed;
    return sol;
  }
  if (!cand.P.allFinite()) {
    sol.P_pred = std::move(cand.P);
    sum.status = DareStatus::kFailed;
    sum.message += "; the result has non-finite entries";
    return sol;
  }
  Derived d = Derive(A, C, Q, R, cand.P);
  if (d.s_ok && options.refine && sum.status == DareStatus::kConverged) {
    const double before = d.residual;
    sum.refinement_steps = Refine(A, C, Q, R, &d);
    if (sum.refinement_steps > 0) {
      sum.message += "; refined in " + std::to_string(sum.refinement_steps) + " steps (relative residual " +
                     FormatDouble(before) + " -> " + FormatDouble(d.residual) + ")";
    }
  }
  sol.P_pred = std::move(d.P);
  sol.innovation_cov = std::move(d.S);
  if (!d.s_ok) {
    sum.min_eigenvalue = MinEigenvalue(sol.P_pred);
    sum.eigenvalues_exact = true;
    sum.status = DareStatus::kFailed;
    sum.message += "; innovation covariance S = C P C^T + R is not positive definite (Cholesky failed)";
    return sol;
  }
  AddPredictorGain(A, &d);
  sol.P_filt = std::move(d.P_filt);
  sol.filter_gain = std::move(d.K_f);
  sol.predictor_gain = std::move(d.K_p);
  sum.relative_residual = d.residual;
  MatrixXd closed_loop = A;
  closed_loop.noalias() -= sol.predictor_gain * C;

  // Stability: the Lyapunov certificate with F = A - K_p C, X = P (P - F P F^T = Q + K_p R K_p^T;
  // see CertifyUnchecked), robust to the rounding of forming F: |fl(A - K_p C) - (A - K_p C)|
  // <= gamma_{m+1} (|A| + |K_p| |C|) entrywise. Its bounds are reported unless exact eigenvalues are
  // asked for; DGEEV and DSYEVR run only when it cannot decide (or gives no bound below 1 - margin).
  bool stable = false, psd = false;
  sum.eigenvalues_exact = true;  // until the certificate's bounds are taken
  if (!options.exact_eigenvalues) {
    const double md = static_cast<double>(C.rows());
    const double e = 2 * (md + 2) * kUnitRoundoff * (A.norm() + sol.predictor_gain.norm() * C.norm());
    const StabilityCertificate cert = CertifyUnchecked(closed_loop, sol.P_pred, e);
    // Proven: P > 0 and rho(F) < 1 - margin (for margin 0 the bare certificate suffices).
    sum.lyapunov_certified = cert.certified && (options.stability_margin == 0.0 ||
                                                cert.spectral_radius_bound < 1.0 - options.stability_margin);
    stable = psd = sum.lyapunov_certified;
    if (sum.lyapunov_certified && cert.spectral_radius_bound < 1.0 && cert.min_eigenvalue_bound > 0.0) {
      sum.closed_loop_spectral_radius = cert.spectral_radius_bound;
      sum.min_eigenvalue = cert.min_eigenvalue_bound;
      sum.eigenvalues_exact = false;
    }
  }
  if (sum.eigenvalues_exact) {  // asked for, not proven, or proven without a bound below 1 to report
    sum.closed_loop_spectral_radius = SpectralRadiusUnchecked(closed_loop);
    sum.min_eigenvalue = MinEigenvalue(sol.P_pred);
    sum.eigenvalues_exact = true;
    if (!sum.lyapunov_certified) {
      stable = sum.closed_loop_spectral_radius < 1.0 - options.stability_margin;
      psd = sum.min_eigenvalue >= -kPsdTolerance * std::max(sol.P_pred.norm(), kTiny);
    }
  }
  const bool residual_ok = sum.relative_residual <= kResidualAcceptance;
  if (sum.status == DareStatus::kConverged) {
    if (!residual_ok) {
      sum.status = DareStatus::kFailed;
      sum.message += "; relative residual " + FormatDouble(sum.relative_residual) + " > " +
                     FormatDouble(kResidualAcceptance) + " (inaccurate solution)";
    } else if (!stable || !psd) {
      sum.status = DareStatus::kNotStabilizing;
      if (!stable) {
        sum.message += "; not stabilizing: rho(A - K_p C) = " + FormatDouble(sum.closed_loop_spectral_radius, 17) +
                       " >= 1 - stability_margin";
      }
      if (!psd) sum.message += "; P is not PSD: lambda_min(P) = " + FormatDouble(sum.min_eigenvalue);
    }
  }
  return sol;
}

// ------------------------------------------------------------------------------------------------
// PBH diagnosis (Hautus tests), run only when no acceptable solution was found:
//   (A, C) detectable        <=> rank [A - lambda I; C]        = n for every |lambda| >= 1,
//   no unreachable mode of (A, Q^{1/2}) on the unit circle
//                            <=> rank [A - lambda I, Q^{1/2}]  = n for every |lambda| = 1.
// These two conditions (with R > 0) are necessary and sufficient for a unique stabilizing PSD
// solution of the filter DARE (e.g. Lancaster & Rodman, Algebraic Riccati Equations, 1995, Ch. 13;
// Chan, Goodwin, Sin, IEEE TAC 29 (1984) 110-118). Rank by SVD with kPbhRankTolerance. Each test is
// one complex SVD: O(k n^3) for k distinct eigenvalues tested (complex-conjugate pairs once).
struct Diagnosis {
  bool found = false;
  DareStatus status = DareStatus::kFailed;
  std::string message;
};

bool RankDeficient(const Eigen::MatrixXcd& m, double* sigma_min, double* sigma_max) {
  Eigen::BDCSVD<Eigen::MatrixXcd> svd(m);  // singular values only
  const Eigen::VectorXd& sv = svd.singularValues();
  const Index n = std::min(m.rows(), m.cols());
  *sigma_max = sv.size() > 0 ? sv(0) : 0.0;
  *sigma_min = sv.size() > 0 ? sv(n - 1) : 0.0;
  return *sigma_min <= kPbhRankTolerance * std::max(*sigma_max, kTiny);
}

std::string ComplexString(std::complex<double> z) {
  std::ostringstream os;
  os.precision(6);
  os << z.real() << (z.imag() < 0 ? " - " : " + ") << std::abs(z.imag()) << "i";
  return os.str();
}

Diagnosis Diagnose(const ConstRef& A, const ConstRef& C, const ConstRef& Q) {
  Diagnosis diag;
  const Index n = A.rows(), m = C.rows();
  Eigen::VectorXcd eig;
  if (n == 0 || !Eigenvalues(A, &eig)) return diag;
  // Distinct eigenvalues (clusters within 1e-8 |lambda| merged), upper half plane only.
  std::vector<std::complex<double>> distinct;
  for (Index i = 0; i < n; ++i) {
    const std::complex<double> z = eig(i);
    if (z.imag() < 0) continue;
    bool seen = false;
    for (const auto& w : distinct) seen = seen || std::abs(w - z) <= 1e-8 * std::max(1.0, std::abs(z));
    if (!seen) distinct.push_back(z);
  }
  const Eigen::MatrixXcd Ac = A.cast<std::complex<double>>();
  // Detectability.
  Eigen::MatrixXcd stacked(n + m, n);
  stacked.bottomRows(m) = C.cast<std::complex<double>>();
  for (const auto& z : distinct) {
    if (std::abs(z) < 1.0 - kUnitCircleBand) continue;
    stacked.topRows(n) = Ac;
    stacked.topRows(n).diagonal().array() -= z;
    double smin = 0, smax = 0;
    if (RankDeficient(stacked, &smin, &smax)) {
      diag.found = true;
      diag.status = DareStatus::kNotDetectable;
      diag.message = "(A, C) is not detectable: the mode lambda = " + ComplexString(z) +
                     " (|lambda| = " + FormatDouble(std::abs(z), 6) +
                     ") is unobservable (sigma_min([A - lambda I; C]) = " + FormatDouble(smin) +
                     " <= " + FormatDouble(kPbhRankTolerance) + " * " + FormatDouble(smax) + ")";
      return diag;
    }
  }
  // Unreachable modes of (A, Q^{1/2}) on the unit circle.
  bool any_on_circle = false;
  for (const auto& z : distinct) any_on_circle = any_on_circle || std::abs(std::abs(z) - 1.0) <= kUnitCircleBand;
  if (!any_on_circle) return diag;
  Eigen::SelfAdjointEigenSolver<MatrixXd> q_eig(0.5 * (Q + Q.transpose()));
  const Eigen::VectorXd sqrt_vals = q_eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  const MatrixXd q_half = q_eig.eigenvectors() * sqrt_vals.asDiagonal() * q_eig.eigenvectors().transpose();
  Eigen::MatrixXcd side(n, 2 * n);
  side.rightCols(n) = q_half.cast<std::complex<double>>();
  for (const auto& z : distinct) {
    if (std::abs(std::abs(z) - 1.0) > kUnitCircleBand) continue;
    side.leftCols(n) = Ac;
    side.leftCols(n).diagonal().array() -= z;
    double smin = 0, smax = 0;
    if (RankDeficient(side, &smin, &smax)) {
      diag.found = true;
      diag.status = DareStatus::kNotStabilizable;
      diag.message = "(A, Q^{1/2}) is not stabilizable on the unit circle: the mode lambda = " + ComplexString(z) +
                     " (|lambda| = " + FormatDouble(std::abs(z), 6) +
                     ") receives no process noise (sigma_min([A - lambda I, Q^{1/2}]) = " + FormatDouble(smin) +
                     " <= " + FormatDouble(kPbhRankTolerance) + " * " + FormatDouble(smax) + ")";
      return diag;
    }
  }
  return diag;
}

bool Usable(const DareSolution& s) { return s.P_pred.size() > 0 && std::isfinite(s.summary.relative_residual); }

}  // namespace

// ------------------------------------------------------------------------------------------------

const char* ToString(DareStatus status) {
  switch (status) {
    case DareStatus::kConverged:
      return "converged";
    case DareStatus::kNotConverged:
      return "not_converged";
    case DareStatus::kNotStabilizing:
      return "not_stabilizing";
    case DareStatus::kNotDetectable:
      return "not_detectable";
    case DareStatus::kNotStabilizable:
      return "not_stabilizable";
    case DareStatus::kFailed:
      return "failed";
  }
  return "unknown";
}

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
    return fail("tolerance: expected a value in (0, 1e-2], got " + FormatDouble(tolerance));
  }
  if (!(stability_margin >= 0.0 && stability_margin < 1.0)) {
    return fail("stability_margin: expected a value in [0, 1), got " + FormatDouble(stability_margin));
  }
  return true;
}

std::string DareSummary::BriefReport() const {
  std::ostringstream os;
  os << "DARE: " << ToString(status) << ", method " << ToString(method_used) << (fell_back ? " (fallback)" : "") << ", "
     << iterations << " doubling steps, relative residual " << FormatDouble(relative_residual) << ", rho(A - K_p C) "
     << (eigenvalues_exact ? "" : "<= ") << FormatDouble(closed_loop_spectral_radius, 6)
     << (eigenvalues_exact ? "" : " (Lyapunov bound)") << ", " << FormatDouble(solve_seconds) << " s";
  return os.str();
}

std::string DareSummary::FullReport() const {
  std::ostringstream os;
  char line[160];
  os << "kfx filter DARE solver report\n";
  auto row = [&](const char* key, const std::string& value) {
    std::snprintf(line, sizeof(line), "  %-28s %s\n", key, value.c_str());
    os << line;
  };
  row("status", ToString(status));
  row("method used", ToString(method_used));
  row("fell back to Schur", fell_back ? "yes" : "no");
  row("doubling steps", std::to_string(iterations));
  row("refinement steps", std::to_string(refinement_steps));
  row("relative residual", FormatDouble(relative_residual));
  row("rho(A - K_p C)", eigenvalues_exact
                            ? FormatDouble(closed_loop_spectral_radius, 10)
                            : "<= " + FormatDouble(closed_loop_spectral_radius, 10) + " (Lyapunov bound)");
  row("min eigenvalue of P",
      eigenvalues_exact ? FormatDouble(min_eigenvalue) : ">= " + FormatDouble(min_eigenvalue) + " (Lyapunov bound)");
  row("stability proven by", lyapunov_certified ? "Lyapunov certificate" : "eigenvalues (DGEEV)");
  row("solve time [s]", FormatDouble(solve_seconds));
  row("message", message);
  return os.str();
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
  if (n == 0) {
    sol.P_pred.resize(0, 0);
    sol.P_filt.resize(0, 0);
    sol.filter_gain.resize(0, m);
    sol.predictor_gain.resize(0, m);
    sol.innovation_cov = R;
    sol.summary.status = DareStatus::kConverged;
    sol.summary.method_used = options.method == DareMethod::kSchur ? DareMethod::kSchur : DareMethod::kDoubling;
    sol.summary.message = "empty state (n = 0)";
    sol.summary.eigenvalues_exact = true;  // rho and lambda_min of empty matrices: 0 by convention
  } else if (options.method == DareMethod::kDoubling) {
    sol = Finalize(A, C, Q, R, SolveByDoubling(A, C, Q, R, options), options);
  } else if (options.method == DareMethod::kSchur) {
    sol = Finalize(A, C, Q, R, SolveBySchur(A, C, Q, R), options);
  } else {
    sol = Finalize(A, C, Q, R, SolveByDoubling(A, C, Q, R, options), options);
    if (!sol.summary.ok()) {
      const int doubling_steps = sol.summary.iterations;
      const std::string doubling_message = sol.summary.message;
      DareSolution schur = Finalize(A, C, Q, R, SolveBySchur(A, C, Q, R), options);
      // Keep Schur if it succeeded, or if both failed and Schur has the smaller residual.
      const bool take_schur =
          schur.summary.ok() ||
          (Usable(schur) && (!Usable(sol) || schur.summary.relative_residual < sol.summary.relative_residual));
      if (take_schur) {
        schur.summary.message = "doubling: " + doubling_message + "; fell back to Schur: " + schur.summary.message;
        sol = std::move(schur);
      } else {
        sol.summary.message += "; Schur fallback not better: " + schur.summary.message;
      }
      sol.summary.fell_back = true;
      sol.summary.iterations = doubling_steps;
    }
  }
  if (!sol.summary.ok()) {
    const Diagnosis diag = Diagnose(A, C, Q);
    if (diag.found) {
      sol.summary.status = diag.status;
      sol.summary.message = diag.message + "; " + sol.summary.message;
    }
  }
  sol.summary.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
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
  const Derived d = Derive(A, C, Q, R, P);
  if (d.s_ok) return d.residual;
  MatrixXd Ps = P;
  SymmetrizeInPlace(Ps);
  const MatrixXd CP = C * Ps;
  MatrixXd S = R;
  S.noalias() += CP * C.transpose();
  const Eigen::FullPivLU<MatrixXd> lu(S);
  if (!lu.isInvertible()) return std::numeric_limits<double>::infinity();
  MatrixXd Pf = Ps;
  Pf.noalias() -= CP.transpose() * lu.solve(CP);
  MatrixXd res = Ps - Q;
  res.noalias() -= A * Pf * A.transpose();
  return res.norm() / std::max(Ps.norm(), kTiny);
}

// ------------------------------------------------------------------------------------------------
// Discrete Lyapunov (Stein) equation: SolveSteinSb03md above (SLICOT SB03MD, Barraud's method), or,
// when no summary is requested and A is stable enough, the squared Smith iteration (Smith 1968):
//   X_0 = Q, A_0 = A;  X_{j+1} = X_j + A_j X_j A_j^T,  A_{j+1} = A_j^2,  so X_j = sum_{k < 2^j} A^k Q A^kT,
// 6 n^3 GEMM flops a step. Stops when the increment is below eps |X|_F; gives up (returns false)
// when A_j does not contract fast enough to converge within kSmithMaxSteps steps (rho(A) above about
// 0.998, or transient growth), and the result is accepted only if its residual is <= 1e-13
// (4 n^3 flops more). About 60 n^3 GEMM flops at rho = 0.95, against SB03MD's ~30 n^3 flops of
// mostly BLAS-2 Schur reduction: several times faster from n ~ 50 on.
constexpr int kSmithMaxSteps = 14;

bool SolveSteinSmith(const ConstRef& A, const ConstRef& Q, MatrixXd* X_out) {
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
  SymmetrizeInPlace(X);
  MatrixXd res = X - Q;
  AX.noalias() = A * X;
  res.noalias() -= AX * A.transpose();
  if (!(res.norm() <= 1e-13 * X.norm())) return false;
  X_out->swap(X);
  return true;
}

Eigen::MatrixXd SolveDiscreteLyapunov(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                      const Eigen::Ref<const Eigen::MatrixXd>& Q, LyapunovSummary* summary) {
  RequireSquare("A", A);
  RequireFinite("A", A);
  const Index n = A.rows();
  RequireShape("Q", Q, n, n);
  RequireSymmetric("Q", Q);
  LyapunovSummary local;
  LyapunovSummary& sum = summary ? *summary : local;
  sum = LyapunovSummary();
  if (n == 0) {
    sum.ok = true;
    sum.message = "empty state (n = 0)";
    return MatrixXd(0, 0);
  }
  MatrixXd x;
  if (!summary && SolveSteinSmith(A, Q, &x)) return x;
  double scale = 1.0, rho = 0.0;
  Eigen::VectorXcd eig;
  const int info = SolveSteinSb03md(A, Q, &x, &scale, &rho, &eig);
  sum.spectral_radius = rho;
  if (info > 0 && info <= n) {
    throw Error("A: the QR algorithm failed to compute the Schur form (SB03MD info " + std::to_string(info) + ")");
  }
  // SB03MD flags (almost) reciprocal pairs by info = n + 1, but misses a complex pair on the unit
  // circle (e.g. a rotation): rounding leaves a pivot of order eps and X of order 1e16. Hence our
  // own test of the eigenvalue products: singular if |1 - lambda_i lambda_j| <= 64 eps.
  double min_gap = std::numeric_limits<double>::infinity();
  if (info == 0) {
    for (Index i = 0; i < n; ++i)
      for (Index j = i; j < n; ++j) min_gap = std::min(min_gap, std::abs(1.0 - eig(i) * eig(j)));
  }
  if (info == n + 1 || min_gap <= 64 * std::numeric_limits<double>::epsilon()) {
    throw Error(
        "A: the Stein equation X = A X A^T + Q is singular or nearly singular: A has eigenvalues with "
        "lambda_i lambda_j ~= 1 (spectral radius " +
        FormatDouble(rho, 17) + ")");
  }
  if (!(scale > 0.0)) {
    throw Error("A: SB03MD returned scale 0: the solution overflows (spectral radius " + FormatDouble(rho, 17) + ")");
  }
  sum.ok = x.allFinite();
  // The residual costs two GEMMs (4 n^3 flops, ~10% of SB03MD): only when the caller asks for it.
  if (summary && !sum.ok) sum.relative_residual = std::numeric_limits<double>::quiet_NaN();
  if (summary && sum.ok) {
    MatrixXd res = x - Q;
    MatrixXd Ax(n, n);
    Ax.noalias() = A * x;
    res.noalias() -= Ax * A.transpose();
    sum.relative_residual = res.norm() / std::max(x.norm(), kTiny);
  }
  sum.message = "SB03MD (Schur method)";
  if (scale != 1.0) sum.message += "; solution divided by SB03MD's scale " + FormatDouble(scale, 17);
  if (!sum.ok) sum.message += "; the solution has non-finite entries";
  return x;
}

StabilityCertificate CertifyStability(const Eigen::Ref<const Eigen::MatrixXd>& F,
                                      const Eigen::Ref<const Eigen::MatrixXd>& X, double perturbation) {
  RequireSquare("F", F);
  RequireFinite("F", F);
  RequireShape("X", X, F.rows(), F.rows());
  RequireFinite("X", X);
  if (!(perturbation >= 0.0 && std::isfinite(perturbation))) {
    throw Error("perturbation: expected a finite value >= 0, got " + FormatDouble(perturbation));
  }
  MatrixXd Xs = X;
  SymmetrizeInPlace(Xs);
  return CertifyUnchecked(F, Xs, perturbation);
}

double SpectralRadius(const Eigen::Ref<const Eigen::MatrixXd>& A) {
  RequireSquare("A", A);
  RequireFinite("A", A);
  return SpectralRadiusUnchecked(A);
}

}  // namespace kfx
