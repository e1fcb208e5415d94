#pragma once
// Finite-horizon optimal reduced-order filters and subspace estimators with oblique projectors
// (paper 001: J. Chandrasekar, I. S. Kim, D. S. Bernstein, title unconfirmed, see docs/papers/README.md;
// corrections to the printed equations in docs/papers/001.md, symbols in docs/notation.md).
//
// Time indexing is kfx's (model.hpp): x_k = A_k x_{k-1} + w_k, y_k = C_k x_k + v_k, k >= 1, the first
// measurement is y_1. The weight L_k (n_e x n, full row rank) selects what is estimated at time k:
// every estimator state xi_k estimates L_k x_k (001's L_k, which weights x_{k+1}, is kfx's L_{k+1}).
// All moments are second moments E[. .^T] (as in 001's Q~ = E[x~ x~^T]), so a nonzero prior mean
// is handled exactly; the estimators start from the prior prediction L_1 A_1 m0.
//
// Reduced-order filter, one-step (001 Sec. II, (2.43)-(2.48)): xi_{k+1} = A_e xi_k + B_e y_k, the
// prediction of L_{k+1} x_{k+1} from y_1..y_k minimizing E|L_{k+1} x_{k+1} - xi_{k+1}|^2. With
// Q~1 = E[x_k x_k^T] = Q_k + Qh_k, E[x_k xi_k^T] = Qh_k L_k^T, E[xi_k xi_k^T] = L_k Qh_k L_k^T:
//   Vt = C_k Q_k C_k^T + R_k,  G_k = (L_k Qh_k L_k^T)^+ L_k Qh_k,  S = Q_k C_k^T Vt^{-1} C_k Q_k,
//   B_e = L_{k+1} A_{k+1} Q_k C_k^T Vt^{-1},  A_e = L_{k+1} A_{k+1} (I - Q_k C_k^T Vt^{-1} C_k) G_k^T,
//   M = A_{k+1} (Qh_k + S) A_{k+1}^T,  tau = M L_{k+1}^T (L_{k+1} M L_{k+1}^T)^+ L_{k+1},
//   Qh_{k+1} = tau M tau^T,  Q_{k+1} = A (Q_k - S) A^T + Q_{k+1}^{noise} + (I - tau) M (I - tau)^T.
// The cost is J_k = tr(L_k Q_k L_k^T).
//
// Two-step (001 Sec. III): data assimilation xi^da_k = C^f_k xi^f_k + D^f_k y_k estimates L_k x_k
// from y_1..y_k ((3.16)-(3.17), (3.32)-(3.33)); forecast xi^f_{k+1} = A^da_k xi^da_k estimates
// L_{k+1} x_{k+1} ((3.42), (3.46)-(3.47)).
//
// Pseudo-inverse: while fewer measurements than n_e have been seen, L M L^T (and with it
// L Qh L^T) is singular. Every such inverse is the Moore-Penrose pseudo-inverse by a symmetric
// eigen-decomposition that drops eigenvalues below rank_tolerance * (largest eigenvalue). This is
// the exact minimum-norm least-squares optimum: the estimator state never has a component in the
// null space of its second moment, the gains are unique on its range, and the pseudo-inverse gives
// the gain that is zero on the null space. Never a NaN.
//
// Subspace estimator (001 Sec. IV): for a plant in block upper-triangular coordinates x' = T^{-1} x
// = (x_r, x_s) (A'_sr = 0), xi_k (n_r = number of columns of the subspace) estimates x_r with the
// fixed structure A_e = A'_r - B_e C'_r; the estimate of L x is L V_r xi (V_r = T(:, 0:n_r)). With
// the error x~ = (x_r - xi, x_s) and Q_k = E[x~ x~^T] (n x n, in the x' coordinates):
//   Vh = C' Q C'^T + R,  Phi_k = [I, (L'_r^T L'_r)^{-1} L'_r^T L'_s] (L' = L_k T),  mu = F^T Phi,
//   xi_{k+1} = Phi_{k+1} A'(I - Q C'^T Vh^{-1} C') F^T xi_k + Phi_{k+1} A' Q C'^T Vh^{-1} y_k  (4.10),
//   Q_{k+1} = A' Q A'^T + Q' - N + (I - mu_{k+1}) N (I - mu_{k+1})^T,  N = A' Q C'^T Vh^{-1} C' Q A'^T
// (4.11); (4.11) is the true error covariance only when A'_sr = 0 (triangularity_defect reports it).
// Two-step: (4.16)-(4.20).
//
// Every estimator is a kfx::LinearFilter; its cost comes from the exact-performance engine
// (WeightedCost), never from its own recursion.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "kfx/enum_text.hpp"
#include "kfx/linear_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/performance.hpp"
#include "kfx/summary.hpp"

namespace kfx {

/// The weights L_k (q x n, full row rank), k = 1..T: one matrix (constant) or T matrices
/// (index k - 1). @throws kfx::Error on a wrong shape, rank, or count.
class WeightSchedule {
 public:
  WeightSchedule() = default;
  explicit WeightSchedule(Eigen::MatrixXd constant);
  explicit WeightSchedule(std::vector<Eigen::MatrixXd> per_step);
  /// L_k for k >= 1 (k = 0 gives L_1). @throws kfx::Error if k is beyond a time-varying schedule.
  const Eigen::MatrixXd& at(int k) const;
  /// The pseudo-inverse L_k^+ = L_k^T (L_k L_k^T)^{-1} (an output map: L_k L_k^+ = I).
  const Eigen::MatrixXd& pinv_at(int k) const;
  Eigen::Index rows() const { return rows_; }  ///< q, the rows of every L_k
  Eigen::Index cols() const { return cols_; }  ///< n, the columns of every L_k
  int size() const { return static_cast<int>(L_.size()); }

 private:
  std::vector<Eigen::MatrixXd> L_, pinv_;
  Eigen::Index rows_ = 0, cols_ = 0;
};

struct ReducedOrderOptions {
  int steps = -1;                 ///< T (negative: the model's horizon)
  double rank_tolerance = 1e-10;  ///< relative eigenvalue cut of the pseudo-inverses, in (0, 1)
  bool IsValid(std::string* error) const;
};

/// One-step reduced-order filter (001 Sec. II): the offline part. Index k = 1..T; gains with index
/// k produce xi_k from (xi_{k-1}, y_{k-1}) (k >= 2). @throws kfx::Error (ComputeReducedOrderOneStep) for
/// weights L without n columns or fewer than the steps, steps beyond the
/// model's horizon (or none given without one), invalid options.
struct ReducedOrderOneStep {
  Eigen::Index meas_dim = 0;          ///< m
  Eigen::VectorXd xi1;                ///< prior prediction L_1 A_1 m0
  std::vector<Eigen::MatrixXd> Ae;    ///< k = 2..T (n_e x n_e)
  std::vector<Eigen::MatrixXd> Be;    ///< k = 2..T (n_e x m)
  std::vector<Eigen::MatrixXd> Q;     ///< k = 1..T: Q_k (n x n)
  std::vector<Eigen::MatrixXd> Qhat;  ///< k = 1..T: Qh_k (n x n)
  std::vector<Eigen::MatrixXd> tau;   ///< k = 2..T: the oblique projector tau_k (n x n)
  Eigen::VectorXd cost;               ///< k = 0..T: tr(L_k Q_k L_k^T) by the recursion (entry 0: NaN)
  std::vector<int> singular_steps;    ///< k where L_k M L_k^T was singular (pseudo-inverse used)
  Summary summary;                    ///< kConverged, iterations = T, seconds; message lists singular_steps
};

/// @throws kfx::Error on invalid input (weights of the wrong width, steps beyond the horizon).
ReducedOrderOneStep ComputeReducedOrderOneStep(const Model& model, const WeightSchedule& L,
                                               const ReducedOrderOptions& options = ReducedOrderOptions());

/// The one-step filter as a LinearFilter with state z_k = (xi_k, y_k) (n_e + m): step 1 copies the
/// prior prediction xi_1 (z_0 = (xi_1, 0)), step k >= 2 is z_k = [[A_e, B_e], [0, 0]] z_{k-1} +
/// [0; I] y_k, output L_k^+ xi_k (compared with x_k). Output at k = 0 is zero (no estimate of x_0).
/// @throws kfx::Error if s is not a computed one-step schedule.
LinearFilter ReducedOrderOneStepAsLinearFilter(const ReducedOrderOneStep& s, const WeightSchedule& L);

/// Two-step reduced-order filter (001 Sec. III). Index k = 1..T. @throws kfx::Error (ComputeReducedOrderTwoStep)
/// for weights L without n columns or fewer than the steps, steps beyond the
/// model's horizon (or none given without one), invalid options.
struct ReducedOrderTwoStep {
  Eigen::VectorXd xi1;                                  ///< prior forecast L_1 A_1 m0
  std::vector<Eigen::MatrixXd> Cf, Df;                  ///< k = 1..T: data assimilation gains (3.16)-(3.17)
  std::vector<Eigen::MatrixXd> Ada;                     ///< k = 2..T: A^da producing xi^f_k from xi^da_{k-1} (3.42)
  std::vector<Eigen::MatrixXd> Qf, Qhatf, Qda, Qhatda;  ///< k = 1..T
  std::vector<Eigen::MatrixXd> tau_da;                  ///< k = 1..T
  std::vector<Eigen::MatrixXd> tau_f;                   ///< k = 2..T
  Eigen::VectorXd cost_da, cost_f;  ///< k = 0..T: tr(L_k Q^da_k L_k^T), tr(L_k Q^f_k L_k^T) (entry 0: NaN)
  std::vector<int> singular_steps;
  Summary summary;  ///< kConverged, iterations = T, seconds; message lists singular_steps
};

ReducedOrderTwoStep ComputeReducedOrderTwoStep(const Model& model, const WeightSchedule& L,
                                               const ReducedOrderOptions& options = ReducedOrderOptions());

enum class TwoStepOutput {
  kDataAssimilation,  ///< output L_k^+ xi^da_k (estimate of L_k x_k from y_1..y_k)
  kForecast,          ///< output L_k^+ xi^f_k (estimate of L_k x_k from y_1..y_{k-1})
};
/// "data_assimilation", "forecast".
const char* ToString(TwoStepOutput output);
template <>
struct EnumValues<TwoStepOutput> {
  static constexpr TwoStepOutput kAll[] = {TwoStepOutput::kDataAssimilation, TwoStepOutput::kForecast};
};

/// The two-step filter as a LinearFilter with state z_k = (xi^da_k, xi^f_k): step 1 is
/// [[C^f_1, 0], [I, 0]] on z_0 = (xi^f_1, 0); step k >= 2 is [[C^f A^da, 0], [A^da, 0]], K = [D^f; 0].
/// `output` chooses which estimate is compared with x_k (through L_k^+).
/// @throws kfx::Error if s is not a computed two-step schedule.
LinearFilter ReducedOrderTwoStepAsLinearFilter(const ReducedOrderTwoStep& s, const WeightSchedule& L,
                                               TwoStepOutput output);

/// J_k = E|L_k x_k - L_k O_k z_k|^2, k = 0..T, from the exact-performance engine's error moments
/// (ExactPerformance with store_error_moments): tr(L_k E[e_k e_k^T] L_k^T). For the filters above
/// L_k O_k z_k is the estimator state itself.
/// options.steps: T (negative: the shorter horizon of model and filter); rank_tolerance is not used.
/// @throws kfx::Error if L does not have n columns, or as ExactPerformance (dimensions, steps, options).
Eigen::VectorXd WeightedCost(const Model& truth, const LinearFilter& filter, const WeightSchedule& L,
                             const ReducedOrderOptions& options, PerformanceResult* result = nullptr);

/// The full-order Kalman costs tr(L_k P_{k|k-1} L_k^T) (predictor) and tr(L_k P_{k|k} L_k^T)
/// (filter), k = 0..T (entry 0 uses P0), from ComputeKalmanSchedule.
struct KalmanWeightedCosts {
  Eigen::VectorXd predictor, filter;
};
/// options.steps: T (negative: the model's horizon). @throws kfx::Error if L does not have n columns, for
/// invalid options, or as ComputeKalmanSchedule (steps beyond the horizon).
KalmanWeightedCosts KalmanCosts(const Model& model, const WeightSchedule& L, const ReducedOrderOptions& options);

// ---- subspace estimators (001 Sec. IV) --------------------------------------------------------

/// A change of basis x = T x' whose first n_r columns span an invariant subspace of A.
struct InvariantSubspaceBasis {
  Eigen::MatrixXd T;                   ///< n x n orthogonal: [V_r, V_s], V_s spans the orthogonal complement
  Eigen::Index n_r = 0;                ///< dimension of the subspace
  Eigen::VectorXcd eigenvalues;        ///< the n_r selected eigenvalues of A (sorted by decreasing |.|)
  Eigen::VectorXcd other_eigenvalues;  ///< the remaining ones
  double invariance_residual = 0.0;    ///< |A V_r - V_r (V_r^T A V_r)|_F / |A|_F
};

/// The n_r least damped modes of a discrete-time A (largest |lambda|) by an ordered real Schur form
/// (LAPACK DGEES, then DTRSEN moves the selected eigenvalues to the leading block). The basis is
/// canonical for the subspace, not LAPACK's Schur vectors: V_r is the orthonormal polar factor of
/// P E_r (P the orthogonal projector on the subspace, E_r the coordinate axes chosen by a pivoted
/// QR of P), likewise V_s on the complement, so any basis of the same subspace gives the same T.
/// @throws kfx::Error if A is not square/finite, n_r is outside 1..n-1, or n_r splits a complex
///         conjugate pair or a tie in |lambda|; kfx::NumericalError if LAPACK fails.
InvariantSubspaceBasis LeastDampedSubspace(const Eigen::MatrixXd& A, Eigen::Index n_r);

/// |A'_sr|_F / |A'|_F of T^{-1} A T: zero for a block upper-triangular form.
/// @throws kfx::Error if A is not square, T not n x n, or n_r outside 1..n.
double TriangularityDefect(const Eigen::MatrixXd& A, const Eigen::MatrixXd& T, Eigen::Index n_r);

/// One-step subspace estimator (4.10)-(4.13) in the coordinates x' = T^{-1} x. Index k = 1..T.
/// @throws kfx::Error (ComputeSubspaceOneStep) for T not n x n, finite and invertible, n_r outside 1..n, L_k V_r
/// not of full column rank, or as ComputeReducedOrderOneStep (weights, steps, options).
struct SubspaceOneStep {
  Eigen::Index meas_dim = 0;          ///< m
  Eigen::VectorXd xi1;                ///< prior prediction F T^{-1} A_1 m0
  std::vector<Eigen::MatrixXd> Ae;    ///< k = 2..T (n_r x n_r), (4.10)
  std::vector<Eigen::MatrixXd> Be;    ///< k = 2..T (n_r x m)
  std::vector<Eigen::MatrixXd> Q;     ///< k = 1..T: Q_k = E[x~ x~^T] in x' coordinates (4.11)
  std::vector<Eigen::MatrixXd> mu;    ///< k = 2..T: the oblique projector mu_k (4.13)
  Eigen::VectorXd cost;               ///< k = 0..T: tr(L_k T Q_k T^T L_k^T) (entry 0: NaN)
  double triangularity_defect = 0.0;  ///< largest TriangularityDefect over the steps
  Summary summary;                    ///< kConverged, iterations = T, seconds
};

/// @param T n x n invertible change of basis; the first n_r columns span the estimated subspace.
/// @param L weights q x n with L_k V_r of full column rank n_r.
SubspaceOneStep ComputeSubspaceOneStep(const Model& model, const Eigen::MatrixXd& T, Eigen::Index n_r,
                                       const WeightSchedule& L,
                                       const ReducedOrderOptions& options = ReducedOrderOptions());

/// As ReducedOrderOneStepAsLinearFilter, with output V_r xi_k. @throws kfx::Error if s is not a computed
/// schedule, T not square, or n_r not the schedule's subspace dimension.
LinearFilter SubspaceOneStepAsLinearFilter(const SubspaceOneStep& s, const Eigen::MatrixXd& T, Eigen::Index n_r);

/// Two-step subspace estimator (4.16)-(4.20). Index k = 1..T. @throws kfx::Error (ComputeSubspaceTwoStep) as
/// ComputeSubspaceOneStep.
struct SubspaceTwoStep {
  Eigen::VectorXd xi1;                   ///< prior forecast
  std::vector<Eigen::MatrixXd> Cf, Df;   ///< k = 1..T: (4.16)
  std::vector<Eigen::MatrixXd> Af;       ///< k = 2..T: Phi_k A'_k F^T (4.19)
  std::vector<Eigen::MatrixXd> Qf, Qda;  ///< k = 1..T: (4.20), (4.17)
  std::vector<Eigen::MatrixXd> mu;       ///< k = 1..T
  Eigen::VectorXd cost_da, cost_f;       ///< k = 0..T (entry 0: NaN)
  double triangularity_defect = 0.0;
  Summary summary;  ///< kConverged, iterations = T, seconds
};

SubspaceTwoStep ComputeSubspaceTwoStep(const Model& model, const Eigen::MatrixXd& T, Eigen::Index n_r,
                                       const WeightSchedule& L,
                                       const ReducedOrderOptions& options = ReducedOrderOptions());

/// As ReducedOrderTwoStepAsLinearFilter, with outputs V_r xi. @throws kfx::Error if s is not a computed
/// schedule or n_r not the schedule's subspace dimension.
LinearFilter SubspaceTwoStepAsLinearFilter(const SubspaceTwoStep& s, const Eigen::MatrixXd& T, Eigen::Index n_r,
                                           TwoStepOutput output);

}  // namespace kfx
