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
#include <string>

namespace kfx {

enum class DareMethod {
  kAuto,      ///< doubling; falls back to generalized Schur if doubling fails or is not stabilizing.
  kDoubling,  ///< structure-preserving doubling algorithm (SDA; Chu, Fan, Lin 2005).
  kSchur,     ///< generalized Schur (QZ) method on the symplectic pencil (SLICOT SB02OD).
};

enum class DareStatus {
  kConverged,        ///< stabilizing solution found; residual in Summary.
  kNotConverged,     ///< iteration limit reached (doubling) without meeting the tolerance.
  kNotStabilizing,   ///< a solution was computed but the closed loop is not stable or P is not PSD.
  kNotDetectable,    ///< (A, C) has an unobservable mode with |lambda| >= 1.
  kNotStabilizable,  ///< (A, Q^{1/2}) has an unreachable mode on the unit circle.
  kFailed,           ///< the method broke down (singular pencil / LAPACK error); see message.
};

const char* ToString(DareStatus status);
const char* ToString(DareMethod method);

struct DareOptions {
  DareMethod method = DareMethod::kAuto;
  /// Doubling: maximum number of doubling steps (each doubles the horizon); range [1, 200].
  int max_iterations = 60;
  /// Doubling stops when |H_{k+1} - H_k|_F <= tolerance * |H_{k+1}|_F; range (0, 1e-2].
  double tolerance = 1e-14;
  /// The solution is accepted as stabilizing when rho(A - K_p C) < 1 - stability_margin; range [0, 1).
  double stability_margin = 0.0;
  /// Refine a successful result (either method): up to 4 fixed-point steps P <- A P_filt A^T + Q
  /// (each kept only if it at least halves the residual; error contracts like rho(A - K_p C)^2),
  /// then one Newton (Hewer) step via a Stein equation if the residual is still > 1e-13.
  bool refine = true;
  bool IsValid(std::string* error) const;
};

struct DareSummary {
  DareStatus status = DareStatus::kFailed;
  std::string message;
  DareMethod method_used = DareMethod::kAuto;  ///< kDoubling or kSchur: what produced the result.
  /// kAuto: doubling failed and Schur was tried (method_used says whose result is returned: Schur's
  /// if it succeeded or, when both failed, the one with the smaller residual).
  bool fell_back = false;
  int iterations = 0;        ///< doubling steps (0 for kSchur; after a kAuto fallback, doubling's steps).
  int refinement_steps = 0;  ///< accepted refinement steps (DareOptions::refine).
  /// |P - A P A^T - Q + A P C^T S^{-1} C P A^T|_F / max(|P|_F, tiny), evaluated in double.
  double relative_residual = 0.0;
  double closed_loop_spectral_radius = 0.0;  ///< rho(A - K_p C)
  double min_eigenvalue = 0.0;               ///< smallest eigenvalue of P
  double solve_seconds = 0.0;
  bool ok() const { return status == DareStatus::kConverged; }
  std::string BriefReport() const;
  std::string FullReport() const;
};

struct DareSolution {
  Eigen::MatrixXd P_pred;          ///< n x n, a priori P_{k|k-1} (the DARE solution).
  Eigen::MatrixXd P_filt;          ///< n x n, a posteriori P_{k|k} = P - K_f C P.
  Eigen::MatrixXd filter_gain;     ///< n x m, K_f.
  Eigen::MatrixXd predictor_gain;  ///< n x m, K_p = A K_f.
  Eigen::MatrixXd innovation_cov;  ///< m x m, S = C P C^T + R.
  DareSummary summary;
};

/// Solves the filter DARE above.
/// @param A n x n, @param C m x n, @param Q n x n symmetric PSD, @param R m x m symmetric PD.
/// @throws kfx::Error on invalid input (dimensions, symmetry, definiteness, NaN/Inf, options).
/// Numerical failures (not detectable, not stabilizable, no convergence) are reported in
/// summary.status, never thrown; the matrices are then those of the last iterate (may be empty).
/// kConverged requires relative_residual <= 1e-8, rho(A - K_p C) < 1 - stability_margin and
/// lambda_min(P) >= -1e-10 |P|_F. On failure, PBH rank tests on the eigenvalues of A refine the status
/// to kNotDetectable / kNotStabilizable when they apply. n = 0 is allowed (empty results).
DareSolution SolveFilterDare(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                             const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                             const DareOptions& options = DareOptions());

/// Relative residual of a candidate DARE solution P (definition in DareSummary::relative_residual).
double FilterDareResidual(const Eigen::Ref<const Eigen::MatrixXd>& A, const Eigen::Ref<const Eigen::MatrixXd>& C,
                          const Eigen::Ref<const Eigen::MatrixXd>& Q, const Eigen::Ref<const Eigen::MatrixXd>& R,
                          const Eigen::Ref<const Eigen::MatrixXd>& P);

struct LyapunovSummary {
  bool ok = false;
  std::string message;
  /// |X - A X A^T - Q|_F / max(|X|_F, tiny) (computed only when a summary is requested; NaN if X is
  /// not finite)
  double relative_residual = 0.0;
  double spectral_radius = 0.0;  ///< rho(A)
};

/// Discrete Lyapunov (Stein) equation X = A X A^T + Q, Schur-based (Bartels-Stewart / Barraud via
/// SLICOT SB03MD); without a summary, a stable A (rho below about 0.998) is solved by the squared
/// Smith iteration instead (doubling, GEMMs only; accepted if its residual is <= 1e-13, else SB03MD). Solvable when no
/// two eigenvalues of A have product 1; for stable A (rho < 1) X is the stationary covariance of x_k = A x_{k-1} + w_k
/// and PSD when Q is.
/// @param A n x n, @param Q n x n symmetric.
/// @throws kfx::Error on invalid input, or if the equation is singular (eigenvalue pair with
///         lambda_i lambda_j = 1), with the spectral radius in the message.
Eigen::MatrixXd SolveDiscreteLyapunov(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                      const Eigen::Ref<const Eigen::MatrixXd>& Q, LyapunovSummary* summary = nullptr);

/// Spectral radius max |lambda_i(A)| (eigenvalues by LAPACK DGEEV; 0 for a 0 x 0 matrix).
/// @throws kfx::Error if A is not square or not finite.
double SpectralRadius(const Eigen::Ref<const Eigen::MatrixXd>& A);

}  // namespace kfx
