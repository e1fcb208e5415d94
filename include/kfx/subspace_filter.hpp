#pragma once
// The subspace-optimal (reduced-order) filter of paper 000 (A. Aalto, "Spatial discretization error
// in Kalman filtering for discrete-time infinite dimensional systems", IMA Journal of Mathematical
// Control and Information, arXiv:1406.7160; full reference in docs/papers/README.md): Algorithm 2.3, the error
// covariance RDE (20) with the load term M_k (21), the Sec. 6.1 approximation and the bounds of
// Theorems 4.1, 4.2 and Remark 4.3. Symbols mapped in docs/notation.md, corrections to the printed
// formulas in docs/papers/000.md.
//
// The true model is kfx's x_k = A x_{k-1} + w_k, w_k = B u_k ~ N(0, Q = B U B^T), y_k = C x_k + v_k
// (000's w_k is kfx's v_k). The state space R^N carries the inner product <a, b> = a^T W b (W: the
// Gram matrix, e.g. blkdiag(stiffness, mass) of a FEM space); the subspace is given by
// Pi : R^N -> R^n with Pi Pi^* = I, Pi^* = W^{-1} Pi^T (the adjoint in W), Pi_s = Pi^* Pi.
// kfx stores every covariance as the matrix Sigma = E[x x^T]; 000's covariance operator is Sigma W,
// so its operator formulas become matrix formulas with ^T (A P A^* -> A P A^T, C P C^* -> C P C^T,
// B U B^* -> B U B^T), tr_X(P) = tr(W Sigma), and (I - Pi_s) X (I - Pi_s)^* -> (I - Pi_s) X (I - Pi_s)^T.
//
// Algorithm 2.3 in these matrices (with the corrections of docs/papers/000.md):
//   S_k  = A S_{k-1} A^T + Q                          state covariance (15)
//   P~_k = A P_{k-1} A^T + Q                          prediction error covariance (13)
//   K_k  = P~_k C^T (C P~_k C^T + R)^{-1}             (14)
//   V_k  = A Q_{k-1} S~_{k-1} Q_{k-1}^T A^T Pi^T + K_k (C P~_k C^T + R) K_k^T Pi^T   E[x_k x~_k^T]
//   S~_k = Pi V_k                                     E[x~_k x~_k^T]
//   Q_k  = Pi^* + (I - Pi_s) V_k S~_k^+               Remark 2.2 / Sec. 6.1 (E[x_k | x~_k] = Q_k x~_k)
//   P_k  = S_k - Q_k S~_k Q_k^T                       E[(x_k - Q_k x~_k)(...)^T]
// with S_0 = P_0 (the prior covariance), S~_0 = 0, Q_0 = Pi^*. Online (the kfx::LinearFilter the
// exact-performance engine evaluates):
//   x~_k = Pi A Q_{k-1} x~_{k-1} + Pi K_k (y_k - C A Q_{k-1} x~_{k-1}),  estimate Q_k x~_k,
// i.e. Phi_k = Pi (A - K_k C A) Q_{k-1}, gain Pi K_k, output map O_k = Q_k, z_0 = Pi m_0, O_0 = Pi^*.
#include <Eigen/Dense>
#include <functional>
#include <string>
#include <vector>

#include "kfx/linear_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/progress.hpp"
#include "kfx/riccati.hpp"

namespace kfx {

/// The inner product and the subspace of Algorithm 2.3. The Python constructor checks it (ValidateSubspace):
/// @throws kfx::Error naming subspace.gram or subspace.projection for bad shapes, non-finite entries, W not
/// SPD, or Pi W^{-1} Pi^T != I.
struct Subspace {
  Eigen::MatrixXd gram;        ///< N x N symmetric positive definite W (empty: identity)
  Eigen::MatrixXd projection;  ///< n x N Pi, orthonormal in W: Pi W^{-1} Pi^T = I
  Eigen::Index full_dim() const { return projection.cols(); }     ///< n, the full state dimension
  Eigen::Index reduced_dim() const { return projection.rows(); }  ///< N, the subspace dimension
};

/// The subspace spanned by the columns of `basis` (N x n, full column rank), with coordinates
/// orthonormal in W: Pi = L^{-1} E^T W for L L^T = E^T W E (so Pi^* = E L^{-T}).
/// @throws kfx::Error on bad shapes, a W that is not SPD, or a rank-deficient basis.
Subspace SubspaceFromBasis(const Eigen::Ref<const Eigen::MatrixXd>& basis, const Eigen::MatrixXd& gram);

/// Pi^* = W^{-1} Pi^T (N x n). @throws kfx::Error if the subspace is invalid (ValidateSubspace).
Eigen::MatrixXd ProjectionAdjoint(const Subspace& subspace);

/// Checks shapes, finiteness, W SPD and Pi W^{-1} Pi^T = I within `tol` (max-abs).
/// @throws kfx::Error naming "subspace.gram" or "subspace.projection".
void ValidateSubspace(const Subspace& subspace, Eigen::Index N, double tol = 1e-8);

/// X -> A X for an N x c block X. Lets a structured A (e.g. an implicit-Euler step applied by a sparse
/// LU solve) replace the dense product, which dominates the cost at large N.
using BlockOperator = std::function<Eigen::MatrixXd(const Eigen::MatrixXd&)>;

struct SubspaceFilterOptions {
  /// Run exactly this many steps (>= 0) and ignore convergence; -1: run until the schedule converges
  /// or max_steps is reached.
  int steps = -1;
  int max_steps = 20000;  ///< >= 1
  /// Convergence: |K_k - K_{k-1}|_F <= tolerance |K_k|_F and |Q_k S~_k - Q_{k-1} S~_{k-1}|_F <=
  /// tolerance |Q_k S~_k|_F on `patience` consecutive steps. The output map is compared on the range
  /// of S~_k, where the estimate lives (Remark 2.2); on its complement Q_k is fixed only by the
  /// pseudoinverse convention and carries amplified round-off. Range (0, 1e-2]. The attainable level
  /// is set by pinv_tolerance: with an S~_k whose spectrum decays to round-off (fine meshes) the
  /// changes level off near 1e-4 at pinv_tolerance = 1e-12 and near 1e-11 at 1e-8 (docs/papers/000.md).
  double tolerance = 1e-10;
  int patience = 5;  ///< >= 1
  /// Remark 2.2: S~_k^+ by a symmetric eigendecomposition, eigenvalues <= pinv_tolerance * lambda_max
  /// are treated as zero (then Q_k = Pi^* + (I - Pi_s) V_k S~_k^+ still gives Pi Q_k = I).
  /// Range [0, 1e-2]. The default 1e-8 drops directions in which the estimate's variance is below
  /// 1e-8 of its largest: on the damped wave at N_f = 125, N_c = 13 (rank 20 of 26) the converged
  /// filter's true stationary error is 7.5e-9 (relative) above that of the 1e-12 schedule, whose gain
  /// still changes by 2e-6 per step after 1600 steps and never converges.
  double pinv_tolerance = 1e-8;
  bool store_schedule = true;      ///< keep K_k and Q_k for every k (N (m + n) doubles per step)
  bool store_covariances = false;  ///< keep P_k (and (20)'s P_k, M_k when rde_check) per step: N^2 each
  /// Also propagate the RDE (20) as a second algorithm, with its load term M_k (21); the largest
  /// relative difference to P_k = S_k - Q_k S~_k Q_k^T goes to the result.
  bool rde_check = false;
  BlockOperator apply_A;  ///< empty: the dense product with truth.A
  /// S0 is the stationary state covariance (S0 = A S0 A^T + Q, checked to 1e-8 relative), so S_k = S0
  /// and no N x N product is formed per step: the cost per step is one application of A to an N x n
  /// block plus O(N n (n + m)) (P_k is then formed only at the end unless stored).
  bool stationary_prior = false;
  ProgressCallback progress{};
  bool IsValid(std::string* error) const;
};

/// @throws kfx::Error (ComputeSubspaceFilterSchedule) on invalid input (shapes, subspace, options); numerical
/// outcomes are in summary.
struct SubspaceFilterSchedule {             ///< The offline part of the subspace filter (000): gains, output maps, P.
  std::vector<Eigen::MatrixXd> gain;        ///< K_k (N x m), k = 1..T (index 0 empty), if stored
  std::vector<Eigen::MatrixXd> output_map;  ///< Q_k (N x n), k = 0..T, if stored
  std::vector<Eigen::MatrixXd> P;           ///< P_k, k = 0..T, if store_covariances
  std::vector<Eigen::MatrixXd> P_rde;       ///< P_k by (20), k = 0..T, if store_covariances && rde_check
  std::vector<Eigen::MatrixXd> M;           ///< M_k (21), k = 1..T (index 0 zero), same condition
  std::vector<int> pinv_rank;               ///< rank used for S~_k^+, k = 0..T
  // The last step T (the converged values when converged):
  Eigen::MatrixXd K, Q, P_final, P_pred, S, S_tilde, V, M_final;  ///< at the last step T
  int steps = 0;          ///< T: the steps computed (fewer than asked for when the schedule failed)
  int converged_at = -1;  ///< first step of the final run of `patience` small changes
  /// max_k |P_k - P_k^{(20)}|_F / max(|P_k|_F, tiny) when rde_check (else 0).
  double rde_max_relative_difference = 0.0;
  /// kConverged: the gain and output map met the tolerance (also in a run of options.steps >= 0 steps
  /// that settled); kNotConverged: they did not within the steps run; kLostDefiniteness (C P~_k C^T + R
  /// not positive definite) or kFailed (eigendecomposition of S~_k) at step steps + 1, the schedule
  /// then holding steps 0..steps. relative_change: the max of the two relative changes at step T;
  /// iterations = T; seconds.
  Summary summary;
};

/// The offline part of Algorithm 2.3 for a time-invariant true step (A, Q = B U B^T, C, R) and prior
/// covariance S0 (N x N PSD; 000's S_0 = P_0).
/// @throws kfx::Error on invalid input (shapes, subspace, options). Numerical outcomes are in summary.
SubspaceFilterSchedule ComputeSubspaceFilterSchedule(const ModelStep& truth, const Eigen::MatrixXd& S0,
                                                     const Subspace& subspace,
                                                     const SubspaceFilterOptions& options = SubspaceFilterOptions());

/// The online part as a time-varying LinearFilter over k = 1..T (needs store_schedule), with z_0 =
/// Pi m0 and O_0 = Pi^*. @throws kfx::Error if the schedule was not stored or does not match.
LinearFilter SubspaceFilterAsLinearFilter(const ModelStep& truth, const Subspace& subspace,
                                          const SubspaceFilterSchedule& schedule,
                                          const Eigen::Ref<const Eigen::VectorXd>& m0);

/// The converged (time-invariant) filter from the schedule's last K, Q:
/// Phi = Pi (A - K C A) Q, gain Pi K, O = Q, z_0 = Pi m0. @throws kfx::Error if m0 is not of length n.
LinearFilter ConvergedSubspaceFilterAsLinearFilter(const ModelStep& truth, const Subspace& subspace,
                                                   const SubspaceFilterSchedule& schedule,
                                                   const Eigen::Ref<const Eigen::VectorXd>& m0);

/// Sec. 6.1: Q^ = Pi^* + (I - Pi_s) S Pi^T (Pi S Pi^T)^+ (E[x | Pi x] = Q^ Pi x) and the covariance
/// V^ of x - Q^ Pi x from the stationary state covariance S; the approximate reduced model
///   A_r = Pi A Q^, Q_r = Pi (Q + A V^ A^T) Pi^T, C_r = C Q^  (R unchanged, as printed),
/// its DARE (SolveFilterDare) and the filter Phi = (I - K_r C_r) A_r, gain K_r, O = Q^.
/// @throws kfx::Error (ComputeApproximateSubspaceFilter) on invalid input; numerical outcomes are in summary.
struct ApproximateSubspaceFilter {
  Eigen::MatrixXd Q_hat, V_hat;  ///< N x n, N x N
  Eigen::MatrixXd A_r, Q_r, C_r;
  DareSolution dare;
  Eigen::MatrixXd Phi, gain;  ///< n x n, n x m (empty unless summary.ok())
  /// kConverged; the reduced DARE's termination when it fails (message "reduced filter DARE: ..."),
  /// kLostDefiniteness when Q_r is not PSD beyond round-off, kFailed when an eigendecomposition fails.
  Summary summary;
};
/// @param measurement_noise_from_residual also add C V^ C^T to R (an extra reading; 000 prints R).
/// @throws kfx::Error on invalid input. Numerical outcomes are in summary.
ApproximateSubspaceFilter ComputeApproximateSubspaceFilter(const ModelStep& truth, const Eigen::MatrixXd& S,
                                                           const Subspace& subspace,
                                                           bool measurement_noise_from_residual = false,
                                                           const BlockOperator& apply_A = BlockOperator());
/// @throws kfx::Error unless approx.summary.ok().
LinearFilter ApproximateSubspaceFilterAsLinearFilter(const ApproximateSubspaceFilter& approx,
                                                     const Eigen::Ref<const Eigen::VectorXd>& z0);

/// The error bounds of Sec. 4, computed in W-orthonormal coordinates (operator norms and traces of X).
/// @throws kfx::Error (ComputeDiscretizationBounds) on invalid input; numerical outcomes are in summary.
/// Full filter: K^(F), P~^(F) from the DARE with Q; Phi_F = A - K^(F) C A. Reduced: K_inf, Q_inf, M_inf
/// from a converged schedule. M = (I - Pi_s) S (I - Pi_s)^*.
struct DiscretizationBounds {
  double trace_M = 0.0;      ///< tr M = sup_k E|(I - Pi_s) x_k|^2
  double trace_M_inf = 0.0;  ///< tr M_inf (21)
  double L = 0.0;            ///< Lemma A.1 (iii): lambda_max(Y), Y = Phi_F^* Y Phi_F + I (via (29))
  double L0 = 0.0;           ///< sum_j |Phi_F^j|^2 (an upper bound, tail bounded by submultiplicativity)
  double L0_printed = 0.0;   ///< sum_j |Phi_F^{2j}| as printed in Lemma A.1
  double L_tilde = 0.0;      ///< L for Phi_inf = A - K_inf C A
  double a = 0.0, b = 0.0, c1 = 0.0, c2 = 0.0, c3 = 0.0, c4 = 0.0, c_hat1 = 0.0, c_hat2 = 0.0;
  double denominator = 0.0;          ///< 1 - (c1 trM + ... + c4 trM^4) of (27)
  double trace_delta_P_bound = 0.0;  ///< (27) (+inf when the denominator is <= 0)
  double trace_delta_P = 0.0;        ///< tr(P^(b) - P^(F)) from the two DAREs (23)
  double theorem41 = 0.0;            ///< (25) with (27): tr M + bound on tr dP
  double theorem41_exact_dP = 0.0;   ///< (25) with the exact tr dP
  double theorem42 = 0.0;            ///< C_1, C_2 form in tr M: tr M + L~ (|Phi_F|^2 trM + b/L trM^2)
  double remark43 = 0.0;             ///< Theorem 4.2 with Remark 4.3's bounds for K^(F), P~^(F) terms
  double actual = 0.0;               ///< lim E|Q x~ - x^|^2 = tr_X(P_A - P_F)
  double rho_full = 0.0;             ///< rho(A - K^(F) C A)
  double rho_reduced = 0.0;          ///< rho(A - K_inf C A)
  double rho_reduced_filter = 0.0;   ///< rho(Pi (A - K_inf C A) Q_inf), the online recursion
  Eigen::MatrixXd P_full;            ///< P^(F) (filtered, kfx matrix)
  Eigen::MatrixXd P_b;               ///< P^(b)
  /// kConverged; the termination of the full-state DARE or of (23)'s DARE with W^(b) when one fails
  /// (the fields after trace_M_inf are then not set). L, L_tilde are +inf when their Phi is unstable.
  Summary summary;
};
/// @param S the stationary state covariance (Lyapunov). Dense; intended for N up to a few hundred.
/// @throws kfx::Error on invalid input. Numerical outcomes are in summary.
DiscretizationBounds ComputeDiscretizationBounds(const ModelStep& truth, const Eigen::MatrixXd& S,
                                                 const Subspace& subspace, const SubspaceFilterSchedule& schedule);

}  // namespace kfx
