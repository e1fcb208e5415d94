#pragma once
// Riccati and Lyapunov solvers (notation: docs/notation.md).
//
// Filter DARE (prediction form), for the model x_k = A x_{k-1} + w_k, y_k = C x_k + v_k:
//   P = A P A^T + Q - A P C^T (C P C^T + R)^{-1} C P A^T,   P = P_{k|k-1} in steady state.
// Gains, named unambiguously (peers mix these up):
//   filter gain     K_f = P C^T (C P C^T + R)^{-1}:  x_{k|k}   = x_{k|k-1} + K_f (y_k - C x_{k|k-1})
//   predictor gain  K_p = A K_f:                     x_{k+1|k} = A x_{k|k-1} + K_p (y_k - C x_{k|k-1})
// (scipy.linalg.solve_discrete_are(A^T, C^T, Q, R) returns the same P; MATLAB/Octave's kalman()
//  calls K_f "M" and K_p "L".)
#include <Eigen/Dense>
#include <limits>
#include <string>

#include "kfx/progress.hpp"
#include "kfx/summary.hpp"

namespace kfx {

enum class DareMethod {
  kAuto,      ///< doubling; falls back to generalized Schur if doubling fails or is not stabilizing.
  kDoubling,  ///< structure-preserving doubling algorithm (SDA; Chu, Fan, Lin 2005).
  kSchur,     ///< generalized Schur (QZ) method on the symplectic pencil (SLICOT SB02OD).
};

const char* ToString(DareMethod method);
template <>
struct EnumValues<DareMethod> {
  static constexpr DareMethod kAll[] = {DareMethod::kAuto, DareMethod::kDoubling, DareMethod::kSchur};
};

struct DareOptions {
  DareMethod method = DareMethod::kAuto;
  /// Doubling: maximum number of doubling steps (each doubles the horizon); range [1, 200].
  int max_iterations = 60;
  /// Doubling stops when |H_{k+1} - H_k|_F <= tolerance * |H_{k+1}|_F; range (0, 1e-2].
  double tolerance = 1e-14;
  /// The solution is accepted as stabilizing when rho(A - K_p C) < 1 - stability_margin; range [0, 1).
  /// Decided by the Lyapunov certificate (CertifyStability on A - K_p C and P; docs/riccati.md), by
  /// the eigenvalues (LAPACK DGEEV) only when the certificate cannot decide.
  double stability_margin = 0.0;
  /// Also compute rho(A - K_p C) (DGEEV) and lambda_min(P) (DSYEVR) exactly for the result, instead
  /// of the certificate's bounds. About 10 n^3 flops of mostly non-BLAS-3 work: a third of the solve
  /// time at n = 200.
  bool exact_eigenvalues = false;
  /// Refine a successful result (either method): for n >= 32 first four terms of the Newton correction
  /// in single precision (error contracts like rho(A - K_p C)^8), then up to 4 fixed-point steps
  /// P <- A P_filt A^T + Q (error contracts like rho(A - K_p C)^2); each step is kept only if it at
  /// least halves the residual, stopping once the relative residual is <= 32 eps = 7.1e-15; then one
  /// Newton (Hewer) step via a Stein equation if the residual is still > 1e-13. The Summary's message
  /// says how many steps of each kind were kept.
  bool refine = true;
  /// Doubling: (k, max_iterations) after doubling step k (the Schur method is one LAPACK call).
  ProgressCallback progress{};
  bool IsValid(std::string* error) const;
};

struct DareSolution {
  Eigen::MatrixXd P_pred;                      ///< n x n, a priori P_{k|k-1} (the DARE solution).
  Eigen::MatrixXd P_filt;                      ///< n x n, a posteriori P_{k|k} = P - K_f C P.
  Eigen::MatrixXd filter_gain;                 ///< n x m, K_f.
  Eigen::MatrixXd predictor_gain;              ///< n x m, K_p = A K_f.
  Eigen::MatrixXd innovation_cov;              ///< m x m, S = C P C^T + R.
  DareMethod method_used = DareMethod::kAuto;  ///< kDoubling or kSchur: what produced the result.
  /// kAuto: doubling failed and Schur was tried (method_used says whose result is returned: Schur's
  /// if it succeeded or, when both failed, the one with the smaller residual).
  bool fell_back = false;
  int refinement_steps = 0;  ///< accepted refinement steps (DareOptions::refine).
  /// rho(A - K_p C) from its eigenvalues (LAPACK DGEEV) if eigenvalues_exact; otherwise the Lyapunov
  /// certificate's upper bound sqrt(1 - s / lambda_max(P)) (s a certified lower bound of
  /// lambda_min(P - (A - K_p C) P (A - K_p C)^T)): then rho(A - K_p C) <= this < 1, typically well
  /// above the true value. See docs/riccati.md.
  double closed_loop_spectral_radius = 0.0;
  /// Smallest eigenvalue of P (LAPACK DSYEVR) if eigenvalues_exact; otherwise the certificate's lower
  /// bound s > 0 (lambda_min(P) >= this).
  double min_eigenvalue = 0.0;
  /// true: the two fields above are eigenvalue computations (DareOptions::exact_eigenvalues, or the
  /// certificate could not decide); false: they are the certified bounds.
  bool eigenvalues_exact = false;
  /// The Lyapunov certificate proved P > 0 and rho(A - K_p C) < 1 - stability_margin (in floating
  /// point, with the rounding errors of its own computation bounded).
  bool lyapunov_certified = false;
  /// How the solve ended. termination: kConverged (stabilizing solution found), kNotConverged (the
  /// doubling's iteration limit), kNotStabilizing (a solution that is not stabilizing or not PSD),
  /// kNotDetectable / kNotStabilizable (PBH tests on the eigenvalues of A, run after a failure),
  /// kFailed (a breakdown: singular pencil, LAPACK error; see message). method "doubling" or "schur",
  /// iterations = doubling steps (after a kAuto fallback, doubling's), relative_residual =
  /// |P - A P A^T - Q + A P C^T S^{-1} C P A^T|_F / max(|P|_F, tiny), evaluated in double.
  Summary summary;
};

/// Solves the filter DARE above.
/// @param A n x n, @param C m x n, @param Q n x n symmetric PSD, @param R m x m symmetric PD.
/// @throws kfx::Error on invalid input (dimensions, symmetry, definiteness, NaN/Inf, options).
/// Numerical outcomes (not detectable, not stabilizable, no convergence) are reported in
/// summary.termination, never thrown; the matrices are then those of the last iterate (may be empty).
/// kConverged requires relative_residual <= 1e-8, rho(A - K_p C) < 1 - stability_margin and
/// lambda_min(P) >= -1e-10 |P|_F: proven by CertifyStability (P > 0 then), or, when the certificate
/// cannot decide, read from the eigenvalues (DGEEV, DSYEVR). On failure, PBH rank tests on the
/// eigenvalues of A refine the termination to kNotDetectable / kNotStabilizable when they apply.
/// n = 0 is allowed (empty results).
DareSolution SolveFilterDare(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                             const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                             const DareOptions& options = DareOptions());

/// Relative residual of a candidate DARE solution P (the definition of DareSolution::summary).
double FilterDareResidual(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                          const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                          const Eigen::Ref<const Eigen::MatrixXd>& P);

enum class LyapunovMethod {
  kAuto,   ///< kSmith when it converges to a residual <= 1e-13 (stable A, rho below about 0.998; for n >= 1000
           ///< only when it predicts at most 11 steps), else kSchur.
  kSchur,  ///< Bartels-Stewart on the real Schur form (LAPACK DGEES, then kfx's recursive blocked solve of the
           ///< quasi-triangular equation, its updates matrix products); any A without eigenvalue pairs
           ///< lambda_i lambda_j = 1.
  kSmith,  ///< the squared Smith iteration (doubling, GEMMs only); stable A only.
};
const char* ToString(LyapunovMethod method);
template <>
struct EnumValues<LyapunovMethod> {
  static constexpr LyapunovMethod kAll[] = {LyapunovMethod::kAuto, LyapunovMethod::kSchur, LyapunovMethod::kSmith};
};

struct LyapunovOptions {
  LyapunovMethod method = LyapunovMethod::kAuto;
  bool IsValid(std::string* error) const;
};

struct LyapunovSolution {  ///< The solution X (n x n) of a discrete Lyapunov equation, rho(A) and how the solve ended.
  Eigen::MatrixXd X;       ///< n x n symmetric solution (the last values when the solve failed; may be empty)
  /// rho(A) from the Schur form (kSchur); NaN when the Smith iteration produced X.
  double spectral_radius = std::numeric_limits<double>::quiet_NaN();
  /// termination kConverged, kSingular (eigenvalue pair with lambda_i lambda_j ~= 1, or kSmith on an A
  /// it cannot handle: rho(A) too close to or above 1), or kFailed (QR failed, overflow); method
  /// "smith" or "schur"; relative_residual = |X - A X A^T - Q|_F / max(|X|_F, tiny).
  Summary summary;
};

/// Discrete Lyapunov (Stein) equation X = A X A^T + Q. Solvable when no two eigenvalues of A have
/// product 1; for stable A (rho < 1) X is the stationary covariance of x_k = A x_{k-1} + w_k and PSD
/// when Q is. Squared Smith iteration: X_0 = Q, A_0 = A, X_{j+1} = X_j + A_j X_j A_j^T, A_{j+1} = A_j^2
/// (about 37 n^3 flops at rho = 0.95, its last terms in single precision); Schur: DGEES (~25 n^3 flops) and a recursive
/// blocked Bartels-Stewart solve (~9 n^3 flops in matrix products, the transformations included).
/// @param A n x n, @param Q n x n symmetric.
/// @throws kfx::Error on invalid input. A singular equation is summary.termination kSingular.
LyapunovSolution SolveDiscreteLyapunov(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                       const Eigen::Ref<const Eigen::MatrixXd>& Q,
                                       const LyapunovOptions& options = LyapunovOptions());

/// Result of CertifyStability.
struct StabilityCertificate {
  /// rho(F) <= this when certified (1 if only rho(F) < 1 was proven; +inf when not certified).
  double spectral_radius_bound = std::numeric_limits<double>::infinity();
  /// lambda_min(X) >= lambda_min(X - F X F^T) >= this when certified (0 if only > 0 was proven).
  double min_eigenvalue_bound = 0.0;
  /// termination kConverged: proven X > 0 and rho(F) < 1 (then also rho(F) <= spectral_radius_bound);
  /// kUndecided: not proven (the message says which test failed); method "Lyapunov certificate".
  Summary summary;
  bool certified() const { return summary.ok(); }
};

/// Lyapunov certificate of discrete-time stability: if X = X^T > 0 and M = X - F X F^T > s I with
/// s >= 0, every eigenvalue of F satisfies |lambda|^2 <= 1 - s / lambda_max(X) (and < 1 for s = 0).
/// Both definiteness tests are Cholesky factorizations (LAPACK DPOTRF) of X - c I and
/// M~ - (s + c + delta) I, where M~ is the computed M, delta a bound on |M~ - M|_2 from the GEMM
/// error bounds, and c Demmel's bound on the backward error of a successful Cholesky factorization;
/// so `certified` is a proof for the given floating-point F and X (barring underflow/overflow), not an
/// estimate. Never certifies an unstable F; may fail to certify a stable one (X singular or badly
/// conditioned, M singular, e.g. an eigenvalue of F on the unit circle): callers then fall back to
/// eigenvalues. X is symmetrized (0.5 (X + X^T)). Cost: 2 GEMMs and 2-3 Cholesky factorizations,
/// about 5 n^3 flops. Derivation: docs/riccati.md.
/// @throws kfx::Error if F and X are not square of the same size or not finite.
/// @param perturbation e >= 0: certify every F' with |F' - F|_2 <= e (SolveFilterDare passes the
///        rounding bound of forming A - K_p C, so the proof covers the exact closed loop of the returned
///        gain).
StabilityCertificate CertifyStability(const Eigen::Ref<const Eigen::MatrixXd>& F,
                                      const Eigen::Ref<const Eigen::MatrixXd>& X, double perturbation = 0.0);

/// Spectral radius max |lambda_i(A)| (eigenvalues by LAPACK DGEEV; 0 for a 0 x 0 matrix).
/// @throws kfx::Error if A is not square or not finite.
double SpectralRadius(const Eigen::Ref<const Eigen::MatrixXd>& A);

// ------------------------------------------------------------------------------------------------
// Generalized equations (issue 22): cross term S, descriptor E; generalized Lyapunov; Stein/Sylvester.

/// The filter DARE with a cross term S and a descriptor matrix E:
///   E P E^T = A P A^T + Q - (A P C^T + S) W^{-1} (A P C^T + S)^T,   W = C P C^T + R,
/// the steady state of the predictor E x_{k+1|k} = A x_{k|k-1} + K_p (y_k - C x_{k|k-1}) for
/// E x_{k+1} = A x_k + w_k, y_k = C x_k + v_k with cov(w_k, v_k) = S (the noises of the same step k:
/// SciPy's / python-control's problem class). It is the dual of
///   scipy.linalg.solve_discrete_are(a = A^T, b = C^T, q = Q, r = R, e = E^T, s = S)
///   control.dare(A^T, C^T, Q, R, S, E^T)   (python-control; its gain G is K_p^T).
/// (For the kfx model's convention cov(w_k, v_k) = S with w_k entering x_k, see docs/notation.md.)
/// Gains, named as in SolveFilterDare: filter gain K_f = P C^T W^{-1} (x_{k|k} = x_{k|k-1} + K_f e_k,
/// P_filt = P - K_f C P), predictor gain K_p = (A P C^T + S) W^{-1} (= A K_f + S W^{-1}; with E the
/// predictor above). closed_loop_spectral_radius is that of the pencil (A - K_p C, E).
/// Methods (DareOptions::method):
///  - kDoubling: the transformation to a standard filter DARE, solved by SolveFilterDare:
///    A~ = E^{-1} A, S~ = E^{-1} S, Q~ = E^{-1} Q E^{-T} (only if E is given), then the cross term is
///    removed: A^ = A~ - S~ R^{-1} C, Q^ = Q~ - S~ R^{-1} S~^T (PSD because [[Q, S], [S^T, R]] is);
///    the solution P and the closed loop A^ - A^ K_f C = E^{-1} (A - K_p C) are the same.
///  - kSchur: SLICOT SG02AD (generalized Schur / QZ on the extended pencil; E and S handled directly).
///  - kAuto: kDoubling when E is well conditioned (rcond_1(E) >= 1e-8) and it succeeds; otherwise
///    kSchur (fell_back says so).
/// The result is checked like SolveFilterDare's (Lyapunov certificate on E^{-1} (A - K_p C) and P,
/// eigenvalues when it cannot decide; acceptance at relative residual <= 1e-8), with
/// relative_residual = |A P A^T - E P E^T + Q - K_p W K_p^T|_F / max(|E P E^T|_F, tiny).
/// @param A n x n, @param C m x n, @param Q n x n symmetric, @param R m x m symmetric PD,
/// @param S n x m, or 0 x 0 for none; @param E n x n nonsingular, or 0 x 0 for the identity.
/// @throws kfx::Error on invalid input, naming the argument: shapes, NaN/Inf, symmetry, R not PD,
///         the joint covariance [[Q, S], [S^T, R]] not PSD (named "S"; "Q" if Q alone is not PSD), E
///         singular (rcond_1(E) < n eps), options.
DareSolution SolveFilterDare(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                             const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                             const Eigen::Ref<const Eigen::MatrixXd>& S, const Eigen::Ref<const Eigen::MatrixXd>& E,
                             const DareOptions& options = DareOptions());

/// Relative residual of a candidate P of the generalized filter DARE above (its definition).
/// @throws kfx::Error on shapes / NaN / asymmetric P (S and E may be 0 x 0 as above).
double FilterDareResidual(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                          const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                          const Eigen::Ref<const Eigen::MatrixXd>& S, const Eigen::Ref<const Eigen::MatrixXd>& E,
                          const Eigen::Ref<const Eigen::MatrixXd>& P);

/// Generalized discrete Lyapunov equation A X A^T - E X E^T + Q = 0 (python-control dlyap(A, Q, None,
/// E); E = I gives SolveDiscreteLyapunov's X = A X A^T + Q). Solvable when no two eigenvalues of the
/// pencil (A, E) have product 1; E nonsingular. SLICOT SG03AD (Bartels-Stewart on the generalized
/// Schur form, Penzl 1998; about 75 n^3 flops). summary: kConverged, kSingular (reciprocal eigenvalue
/// pair) or kFailed (QZ failed, overflow); method "schur"; relative_residual =
/// |A X A^T - E X E^T + Q|_F / max(|E X E^T|_F, tiny). spectral_radius: max |lambda(A, E)|.
/// @param A, E, Q n x n, Q symmetric. @throws kfx::Error on invalid input (E singular: rcond < n eps).
LyapunovSolution SolveGeneralizedDiscreteLyapunov(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                                  const Eigen::Ref<const Eigen::MatrixXd>& E,
                                                  const Eigen::Ref<const Eigen::MatrixXd>& Q);

struct SteinSolution {  ///< The solution X (n x m) of a Stein (discrete Sylvester) equation and how the solve ended.
  Eigen::MatrixXd X;    ///< n x m (the last values when the solve failed)
  /// termination kConverged, kSingular (lambda_i(A) lambda_j(B) ~= 1) or kFailed (QR failed); method
  /// "hessenberg-schur"; relative_residual = |A X B - X + C|_F / max(|X|_F, tiny).
  Summary summary;
};

/// Discrete Sylvester (Stein) equation A X B - X + C = 0 (python-control dlyap(A, Q, C) is B = Q^T).
/// Solvable when no eigenvalue pair has lambda_i(A) lambda_j(B) = 1. SLICOT SB04QD (Hessenberg-Schur
/// method, Golub, Nash, Van Loan, IEEE TAC 24 (1979) 909-913) on X + (-A) X B = C.
/// @param A n x n, @param B m x m, @param C n x m. @throws kfx::Error on invalid input.
SteinSolution SolveDiscreteSylvester(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                     const Eigen::Ref<const Eigen::MatrixXd>& B,
                                     const Eigen::Ref<const Eigen::MatrixXd>& C);

// ------------------------------------------------------------------------------------------------
// The filter CARE (continuous time; paper 003's Kalman-Bucy filter and its steady state).

/// Result of SolveFilterCare: the stabilizing solution of the filter CARE, its gain and how the solve ended.
struct CareSolution {
  Eigen::MatrixXd P;  ///< n x n stabilizing solution (empty unless SB02OD succeeded)
  /// n x m Kalman-Bucy gain K = (E P C^T + S) R^{-1} (K = P C^T R^{-1} without S and E): the steady
  /// filter E dx^ = A x^ dt + K (dy - C x^ dt). python-control's care(A^T, C^T, Q, R, S, E^T) returns
  /// its G = K^T; MATLAB/Octave's kalman() calls K "L".
  Eigen::MatrixXd gain;
  double closed_loop_max_real = 0.0;  ///< max Re lambda(E^{-1} (A - K C)) (DGEEV)
  int refinement_steps = 0;           ///< accepted Newton (Kleinman) steps, at most two (Lyapunov by SB03MD)
  /// kConverged (closed loop stable and relative residual <= 1e-8), kNotStabilizing (SB02OD found no
  /// stable deflating subspace of dimension n or its U11 is singular, or the closed loop is not stable), kFailed
  /// (another SB02OD failure, a non-finite result, or relative residual > 1e-8); method "schur"; relative_residual =
  /// |res|_F / (2 |A P E^T|_F + |Q|_F + |K R K^T|_F), res = A P E^T + E P A^T + Q - (E P C^T + S) R^{-1} (C P E^T +
  /// S^T).
  Summary summary;
};

/// The filter CARE with a cross term S and a descriptor E:
///   A P E^T + E P A^T + Q - (E P C^T + S) R^{-1} (C P E^T + S^T) = 0,
/// (S = 0, E = I: A P + P A^T + Q - P C^T R^{-1} C P = 0), the steady state of the Kalman-Bucy filter
/// for E dx = A x dt + dw, dy = C x dt + dv with incremental covariances Q, R and cross covariance
/// S = cov(dw, dv) / dt. It is the dual of
///   scipy.linalg.solve_continuous_are(a = A^T, b = C^T, q = Q, r = R, e = E^T, s = S)
///   control.care(A^T, C^T, Q, R, S, E^T)   (python-control; its gain G is K^T).
/// Without E: SLICOT SB02OD (DICO = 'C', generalized Schur on the extended pencil, L = S) on
/// (A^T, C^T, Q, R, S). With E: the same on A~ = E^{-1} A, Q~ = E^{-1} Q E^{-T}, S~ = E^{-1} S (same P;
/// E must be nonsingular). Then at most two Newton (Kleinman) steps, each a continuous Lyapunov equation
/// in the closed loop (SB03MD) kept only if it lowers the residual. The solution is accepted when the
/// closed loop E^{-1} (A - K C) has all eigenvalues in the open left half plane (DGEEV) and the relative
/// residual is <= 1e-8. P is PSD when [[Q, S], [S^T, R]] is PSD and P stabilizing.
/// @param A n x n, @param C m x n, @param Q n x n symmetric PSD, @param R m x m symmetric PD,
/// @param S n x m, or 0 x 0 for none; @param E n x n nonsingular, or 0 x 0 for the identity.
/// @throws kfx::Error on invalid input, naming the argument: shapes, NaN/Inf, symmetry, Q not PSD, R not
///         PD, the joint covariance [[Q, S], [S^T, R]] not PSD (named "S"), E singular (rcond_1(E) < n eps).
/// Numerical outcomes (no stabilizing solution: not detectable or not stabilizable) are in summary.
CareSolution SolveFilterCare(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                             const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                             const Eigen::Ref<const Eigen::MatrixXd>& S, const Eigen::Ref<const Eigen::MatrixXd>& E);

}  // namespace kfx
