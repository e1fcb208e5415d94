#pragma once
// Many subsystems coupled by a low-dimensional stochastic input, and the block-diagonal filter
// (paper 004: L. Pogorelyuk, C. W. Rowley, N. J. Kasdin, "An efficient approximation of the Kalman
// filter for multiple systems coupled via low-dimensional stochastic input", arXiv:1911.10443; full
// reference in docs/papers/README.md; notation map in docs/notation.md, equation map in
// docs/papers/004.md). In kfx's indexing (first measurement y_1), for subsystems i = 1..n:
//
//   x_k^(i) = F_k^(i) x_{k-1}^(i) + v_k^(i) + G_k^(i) u_k,   v_k^(i) ~ N(0, V_k^(i))   (c states)
//   y_k^(i) = H_k^(i) x_k^(i) + w_k^(i),                      w_k^(i) ~ N(0, R_k^(i))   (d measurements)
//   u_k ~ N(0, U_k)                                                                      (r inputs)
//
// (004 writes x_{k+1} = F_k x_k + ...; only the step index differs.) The stacked system has block-
// diagonal F, H, V, R and process noise Q = V + G U G^T, which is dense: the Kalman filter costs
// O((cn)^3) per step. The block-diagonal filter (004 eqs. (3)-(7)) projects the updated covariance
// onto its diagonal blocks, D{.}, and runs in O(n r^2) by eqs. (8)-(17).
//
// Storage is per block, never a dense (cn x cn) matrix: a block-diagonal matrix with blocks
// a x b is packed as an a x (n b) matrix whose columns [i b, (i+1) b) hold block i (contiguous).
// G is stacked, (n c) x r.
#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "kfx/kalman_filter.hpp"
#include "kfx/linear_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/progress.hpp"
#include "kfx/simulation.hpp"
#include "kfx/step_schedule.hpp"
#include "kfx/summary.hpp"

namespace kfx {

/// The matrices of one step of the coupled system, per block (packed layout above).
struct CoupledStep {
  Eigen::MatrixXd F;  ///< c x (n c): F^(i), the subsystem transitions.
  Eigen::MatrixXd H;  ///< d x (n c): H^(i), the subsystem measurement matrices.
  Eigen::MatrixXd V;  ///< c x (n c): V^(i), symmetric PSD process-noise covariances.
  Eigen::MatrixXd R;  ///< d x (n d): R^(i), symmetric PD measurement-noise covariances.
  Eigen::MatrixXd G;  ///< (n c) x r: G^(i) stacked, the coupling input matrices.
  Eigen::MatrixXd U;  ///< r x r symmetric PSD covariance of the coupling input u_k (U = 0 allowed).

  Eigen::Index c() const { return F.rows(); }                                ///< state dimension of one subsystem
  Eigen::Index d() const { return H.rows(); }                                ///< measurement dimension of one subsystem
  Eigen::Index r() const { return G.cols(); }                                ///< dimension of the coupling input
  Eigen::Index n() const { return F.rows() > 0 ? F.cols() / F.rows() : 0; }  ///< number of subsystems
};

/// The same (F, H, V, R, g) for all n subsystems; G = 1_n (x) g.
/// @throws kfx::Error if n < 1, F is not square (c x c), or H, V, R, g, U are not d x c, c x c, d x d, c x r,
///         r x r.
CoupledStep MakeIdenticalCoupledStep(Eigen::Index n, const Eigen::MatrixXd& F, const Eigen::MatrixXd& H,
                                     const Eigen::MatrixXd& V, const Eigen::MatrixXd& R, const Eigen::MatrixXd& g,
                                     const Eigen::MatrixXd& U);

/// Missing measurements (NaN entries of y, as everywhere in kfx): *masked is s with the row of H^(i) of each
/// missing component set to zero and that component's correlations in R^(i) dropped (its variance kept), and
/// *y_masked is y with each NaN set to 0. A measurement that is pure noise, uncorrelated with the others, carries
/// no information, so every filter's update on (masked, y_masked) is its update on the observed components alone
/// (for the Kalman filter: the gain's columns of the missing components are 0). Returns false, leaving the outputs
/// alone, when y has no NaN. @throws kfx::Error naming y for an infinite entry or a length other than n d.
bool MaskMissingMeasurements(const CoupledStep& s, const Eigen::VectorXd& y, CoupledStep* masked,
                             Eigen::VectorXd* y_masked);

/// Checks shapes (n subsystems of c states, d measurements, r inputs), finiteness, V_i and U
/// symmetric PSD, R_i symmetric PD. @throws kfx::Error naming the matrix (and block) at fault.
void ValidateCoupledStep(const CoupledStep& s, Eigen::Index n, Eigen::Index c, Eigen::Index d, Eigen::Index r,
                         const std::string& label = "");

/// A coupled system: time-invariant, a stored sequence, or a callback k -> step; prior
/// x_0 ~ N(m0, blockdiag(P0)) with P0 packed c x (n c). Copies are cheap.
/// @throws kfx::Error (every constructor) naming the matrix (and step) at fault, as ValidateCoupledStep, or
///         for m0 not of length n c, P0 not c x (n c) with symmetric PSD blocks, an empty list of steps.
class CoupledSystem {
 public:
  using StepFunction = std::function<CoupledStep(int k)>;
  /// @throws kfx::Error on invalid input.
  CoupledSystem(CoupledStep step, Eigen::VectorXd m0, Eigen::MatrixXd P0_blocks);
  CoupledSystem(std::vector<CoupledStep> steps, Eigen::VectorXd m0, Eigen::MatrixXd P0_blocks);
  CoupledSystem(Eigen::Index n, Eigen::Index c, Eigen::Index d, Eigen::Index r, StepFunction function,
                Eigen::VectorXd m0, Eigen::MatrixXd P0_blocks, int horizon = -1);

  Eigen::Index n() const { return n_; }               ///< number of subsystems
  Eigen::Index c() const { return c_; }               ///< state dimension of one subsystem
  Eigen::Index d() const { return d_; }               ///< measurement dimension of one subsystem
  Eigen::Index r() const { return r_; }               ///< dimension of the coupling input
  Eigen::Index state_dim() const { return n_ * c_; }  ///< n c
  Eigen::Index meas_dim() const { return n_ * d_; }   ///< n d
  bool time_invariant() const { return kind_ == detail::ScheduleKind::kInvariant; }
  int horizon() const { return horizon_; }
  /// Step k >= 1. @throws kfx::Error if k is out of range.
  std::shared_ptr<const CoupledStep> step(int k) const;
  const Eigen::VectorXd& m0() const { return m0_; }
  const Eigen::MatrixXd& P0_blocks() const { return P0_; }
  /// Steps to run for a request (negative: the horizon). @throws kfx::Error as Model::ResolveSteps.
  int ResolveSteps(int steps) const;

 private:
  void ValidatePrior() const;
  detail::ScheduleKind kind_;
  Eigen::Index n_ = 0, c_ = 0, d_ = 0, r_ = 0;
  int horizon_ = -1;
  std::vector<std::shared_ptr<const CoupledStep>> steps_;
  StepFunction function_;
  Eigen::VectorXd m0_;
  Eigen::MatrixXd P0_;
};

// ---- Packed block-diagonal helpers ----------------------------------------------------------------

/// The dense (n a) x (n b) block-diagonal matrix of packed blocks (a x (n b)).
/// @throws kfx::Error unless block_cols >= 1 divides the columns of blocks.
Eigen::MatrixXd BlockDiagonalToDense(const Eigen::MatrixXd& blocks, Eigen::Index block_cols);
/// D{M}: the diagonal a x a blocks of a square dense M, packed a x (n a) (004, definition of D).
/// @throws kfx::Error unless M is square and a >= 1 divides its size.
Eigen::MatrixXd DiagonalBlocks(const Eigen::MatrixXd& M, Eigen::Index a);
/// y = blockdiag(M) x for packed blocks M (a x (n b)), x of length n b.
Eigen::VectorXd BlockDiagonalApply(const Eigen::MatrixXd& blocks, Eigen::Index block_cols, const Eigen::VectorXd& x);

/// The stacked system as a dense kfx step: A = blockdiag(F), C = blockdiag(H), Q = blockdiag(V) + G U G^T,
/// R = blockdiag(R). O((cn)^2) memory: for comparisons at moderate n.
ModelStep ToDenseStep(const CoupledStep& s);
/// The stacked system as a dense kfx::Model (prior P0 = blockdiag(P0_blocks)); time-varying systems
/// become a callback model with the same horizon.
Model ToDenseModel(const CoupledSystem& system);

// ---- Offline part: covariance and gain of one step ------------------------------------------------

/// The block-diagonal filter's gain in factored form. By eq. (17) with C_{k,2} = C_{k,1} and
/// C_{k,3} = -C_{k,1} (docs/papers/004.md derives both),
///   K_k = blockdiag(J) - E C_1 Y^T,  J^(i) = L^(i) H^(i)T (M^(i))^{-1},  E = B_k - G,  Y = M_k^{-1} H_k G,
/// so K nu costs O(n r) and never forms the (cn x dn) matrix. E and Y are stored transposed (packed
/// r x c and r x d blocks): each subsystem's r-vectors are contiguous, which the O(n r^2) step needs.
struct BlockDiagonalGain {
  Eigen::MatrixXd J;   ///< c x (n d) packed blocks.
  Eigen::MatrixXd Et;  ///< r x (n c): E^T, E = B_k - G (eq. (10) minus G).
  Eigen::MatrixXd C1;  ///< r x r: C_{k,1} = (U^{-1} + N_k)^{-1} (eq. (11)), also Sigma_u.
  Eigen::MatrixXd Yt;  ///< r x (n d): Y^T, Y = M_k^{-1} H_k G.

  /// K nu for an innovation nu of length n d (eq. (7)'s correction term, O(n r)).
  Eigen::VectorXd Apply(const Eigen::VectorXd& innovation) const;
  /// Posterior mean of the coupling input, mu_u = C_1 G^T H^T M^{-1} nu (004 after eq. (17), with
  /// -C_{k,3} = C_{k,1}); nu must be the innovation of the block-diagonal estimate.
  Eigen::VectorXd CouplingMean(const Eigen::VectorXd& innovation) const;
  /// The dense (n c) x (n d) gain (moderate n).
  Eigen::MatrixXd ToDense() const;
};

struct BlockDiagonalCovarianceStep {
  Eigen::MatrixXd P_filt;  ///< c x (n c): P~_{k|k} (eq. (8)).
  BlockDiagonalGain gain;
};

/// One offline step of the block-diagonal filter in the O(n r^2) form, eqs. (8)-(17):
/// P~_{k-1|k-1} (packed) -> P~_{k|k}, K~_k. Memory O(n (c + d) r); no (cn x cn) matrix.
/// @throws kfx::Error on inconsistent shapes; kfx::NumericalError if some M^(i) is not PD.
BlockDiagonalCovarianceStep BlockDiagonalCovarianceUpdate(const CoupledStep& s, const Eigen::MatrixXd& P_prev_blocks);
/// The same, writing into `out` and reusing its storage when the sizes agree (no allocation or page
/// faults per step at large n). P_prev_blocks must not alias out->P_filt.
void BlockDiagonalCovarianceUpdate(const CoupledStep& s, const Eigen::MatrixXd& P_prev_blocks,
                                   BlockDiagonalCovarianceStep* out);

namespace detail {
/// Test hook: with false, the O(n r^2) step uses only its generic (run-time size) kernels instead of
/// the fixed-shape ones for small c, d; both must agree to rounding. Default true; not meant to be
/// switched while another thread runs a step.
void SetBlockDiagonalSpecializedKernels(bool enabled);
}  // namespace detail

struct DenseGainCovarianceStep {
  Eigen::MatrixXd P_filt;  ///< as produced by the method (packed blocks or dense).
  Eigen::MatrixXd K;       ///< (n c) x (n d) dense gain.
};

/// The naive form of the same step, eqs. (3)-(6), with dense (cn x cn) matrices: the reference the
/// fast form is tested against. Returns packed P~_{k|k} and the dense gain.
DenseGainCovarianceStep NaiveBlockDiagonalCovarianceUpdate(const CoupledStep& s, const Eigen::MatrixXd& P_prev_blocks);

/// The banded filter (004 ref. [12]): the Kalman filter of each subsystem with process noise
/// D{V + G U G^T}, i.e. the projection applied at the predict step. Returns packed P_{k|k} and gain
/// blocks K (c x (n d) packed). O(n (c^3 + c^2 r)).
struct BandedCovarianceStep {
  Eigen::MatrixXd P_filt;  ///< c x (n c)
  Eigen::MatrixXd K;       ///< c x (n d) packed gain blocks
};
BandedCovarianceStep BandedCovarianceUpdate(const CoupledStep& s, const Eigen::MatrixXd& P_prev_blocks);

/// The full Kalman filter's step on the stacked system, exploiting the block structure of F, H, R:
/// predict O(c (cn)^2 + (cn)^2 r), update O((cn)^2 dn) with dense P (cn x cn). The gain is kept in
/// factored form K = (H P_pred)^T S^{-1}.
struct FullCovarianceStep {
  Eigen::MatrixXd P_filt;         ///< (n c) x (n c) dense P_{k|k}
  Eigen::MatrixXd HP;             ///< (n d) x (n c): H_k P_{k|k-1}
  Eigen::LLT<Eigen::MatrixXd> S;  ///< Cholesky factor of S_k = H P_{k|k-1} H^T + R
  /// K nu = (H P)^T S^{-1} nu.
  Eigen::VectorXd Apply(const Eigen::VectorXd& innovation) const;
  Eigen::MatrixXd ToDense() const;  ///< K, (n c) x (n d)
};
/// @throws kfx::Error on inconsistent shapes; kfx::NumericalError if S_k is not PD.
FullCovarianceStep FullCovarianceUpdate(const CoupledStep& s, const Eigen::MatrixXd& P_prev);

/// D{V + G U G^T} packed c x (n c): the banded filter's process noise (compute once when V, G and U
/// do not change).
Eigen::MatrixXd BandedProcessNoise(const CoupledStep& s);
/// The banded step with precomputed process-noise blocks Q_blocks = BandedProcessNoise(s).
BandedCovarianceStep BandedCovarianceUpdate(const CoupledStep& s, const Eigen::MatrixXd& P_prev_blocks,
                                            const Eigen::MatrixXd& Q_blocks);

// ---- Online part ----------------------------------------------------------------------------------

/// Prediction of the measurement: H_k F_k x (packed blocks).
Eigen::VectorXd CoupledPredictMeasurement(const CoupledStep& s, const Eigen::VectorXd& x_prev);
/// F_k x (packed blocks).
Eigen::VectorXd CoupledPropagate(const CoupledStep& s, const Eigen::VectorXd& x_prev);

enum class CoupledFilterKind {
  kBlockDiagonal,       ///< eqs. (8)-(17), O(n r^2) per step
  kBlockDiagonalNaive,  ///< eqs. (3)-(7), dense; for tests
  kBanded,              ///< projection at the predict step, O(n c^3)
  kFull,                ///< the Kalman filter of the stacked system, O((cn)^3)
};
/// "block-diagonal", "block-diagonal-naive", "banded", "full".
const char* ToString(CoupledFilterKind kind);
template <>
struct EnumValues<CoupledFilterKind> {
  static constexpr CoupledFilterKind kAll[] = {CoupledFilterKind::kBlockDiagonal,
                                               CoupledFilterKind::kBlockDiagonalNaive, CoupledFilterKind::kBanded,
                                               CoupledFilterKind::kFull};
};

/// A running filter of one of the kinds above: x_k = F_k x_{k-1} + K_k (y_k - H_k F_k x_{k-1}).
/// The block-diagonal kinds also give the coupling-input posterior N(mu_u, Sigma_u).
class CoupledFilter {
 public:
  /// @param x0 length n c; @param P0_blocks c x (n c) packed (the full filter starts from blockdiag).
  CoupledFilter(CoupledFilterKind kind, Eigen::VectorXd x0, const Eigen::MatrixXd& P0_blocks);
  /// One step with the measurement y (length n d); a NaN entry is a missing measurement, skipped in the
  /// update as the Kalman filter skips it (MaskMissingMeasurements). @throws kfx::Error on shape mismatch or
  /// an infinite entry of y.
  void Step(const CoupledStep& s, const Eigen::VectorXd& y);
  /// One step given the innovation directly (extended filters: nu = y - h(F x)), with the step's
  /// linearized H and R. The state moves to F x + K nu.
  void StepWithInnovation(const CoupledStep& s, const Eigen::VectorXd& innovation);

  CoupledFilterKind kind() const { return kind_; }
  const Eigen::VectorXd& x() const { return x_; }
  /// The filter's own covariance: packed blocks c x (n c) (block kinds), dense (cn x cn) for kFull.
  const Eigen::MatrixXd& P() const { return P_; }
  /// mu_u and Sigma_u of the last step (block-diagonal kinds; empty otherwise).
  const Eigen::VectorXd& coupling_mean() const { return mu_u_; }
  const Eigen::MatrixXd& coupling_cov() const { return sigma_u_; }

 private:
  // x_k = x_pred + K_k nu with x_pred = F_k x_{k-1}, and the covariance step.
  void Update(const CoupledStep& s, const Eigen::VectorXd& nu, Eigen::VectorXd x_pred);
  void CheckStep(const CoupledStep& s) const;  // shapes, and the same n and c as the filter

  CoupledFilterKind kind_;
  Eigen::Index c_;
  Eigen::VectorXd x_;
  Eigen::MatrixXd P_;
  Eigen::VectorXd mu_u_;
  Eigen::MatrixXd sigma_u_;
  BlockDiagonalCovarianceStep work_;  // storage reused across steps
  Eigen::VectorXd x_next_, nu_;       // the block-diagonal step's x_k and innovation (reused)
};

struct CoupledRun {       ///< A filter run over a coupled system: filtered means, coupling inputs, covariance trace.
  TimeSeries x_filt;      ///< (T+1) x (n c), row 0 the prior mean
  TimeSeries coupling;    ///< T x r: mu_u,k (block-diagonal kinds; empty otherwise)
  Eigen::VectorXd trace;  ///< length T+1: trace of the filter's own covariance
  int steady_state_steps = 0;  ///< steps done on the frozen gain (CoupledFilterOptions::steady_state_tolerance)
  /// The filter's own covariance after the last step (CoupledFilter::P(); for a frozen run, the one the gain
  /// was frozen at).
  Eigen::MatrixXd P_filt;
  Eigen::MatrixXd coupling_cov;  ///< r x r: Sigma_u of the last step (block-diagonal kinds; empty otherwise)
};
struct CoupledFilterOptions {
  /// Number of steps T: RunCoupledFilter runs min(T, rows of y) (negative: all rows of y);
  /// CoupledFilterAsLinearFilter runs T (negative: the system's horizon).
  int steps = -1;
  ProgressCallback progress{};
  /// Steady state of the block-diagonal filter (RunCoupledFilter, kBlockDiagonal, time-invariant systems;
  /// 0 = off, the default): the fixed point of eq. (19). Once a full step changes the covariance blocks by
  /// at most this, relative in the Frobenius norm, or the changes reach their rounding floor (the switch
  /// of RunFilter's steady-state fast path), the gain is frozen and later steps update only the estimate,
  /// several steps at a time: the coupling enters through r-vectors, so E and Y are streamed once per
  /// group of kSteadyStateGroup steps instead of G twice per step (docs/papers/004.md). A row of y with a
  /// missing value ends the freeze. Range [0, 1e-2].
  double steady_state_tolerance = 0.0;
  static constexpr int kSteadyStateGroup = 8;
};

/// Runs a filter over measurements y ((T, n d), row k-1 = y_k). @throws kfx::Error on shapes.
CoupledRun RunCoupledFilter(const CoupledSystem& system, CoupledFilterKind kind, const TimeSeries& y,
                            const CoupledFilterOptions& options = CoupledFilterOptions());

/// The filter as a kfx::LinearFilter (dense Phi_k = (I - K_k H_k) F_k, K_k) over options.steps steps,
/// for the exact-performance engine: its true error on any model (ExactPerformance). Moderate n only.
/// @throws kfx::Error for steps beyond the system's horizon (or none given without one);
///         kfx::NumericalError if a step's innovation covariance is not positive definite.
LinearFilter CoupledFilterAsLinearFilter(const CoupledSystem& system, CoupledFilterKind kind,
                                         const CoupledFilterOptions& options);

/// Draws x_0 and (x_k, y_k), k = 1..steps, per block in O(n (c + r)) per step.
struct CoupledTrajectory {
  TimeSeries x;  ///< (T+1) x (n c)
  TimeSeries y;  ///< T x (n d)
  TimeSeries u;  ///< T x r
};
/// options.steps: T (negative: the system's horizon). @throws kfx::Error for steps beyond the horizon (or
/// none given without one) or a step that fails ValidateCoupledStep.
CoupledTrajectory SimulateCoupled(const CoupledSystem& system, const SimulationOptions& options);

// ---- Many independent small filters (U = 0) -------------------------------------------------------

/// n independent time-invariant Kalman filters of c states and d measurements each: 004's subsystems
/// without the coupling input (U = 0), the "one small filter per pixel" case. Each matrix holds one
/// block for all filters or one block per filter, packed as above (filter i in columns [i b, (i+1) b)).
struct ManyFilterModel {
  Eigen::MatrixXd F;   ///< c x c or c x (n c): transitions.
  Eigen::MatrixXd H;   ///< d x c or d x (n c): measurement matrices.
  Eigen::MatrixXd Q;   ///< c x c or c x (n c): symmetric PSD process-noise covariances.
  Eigen::MatrixXd R;   ///< d x d or d x (n d): symmetric PD measurement-noise covariances.
  Eigen::MatrixXd x0;  ///< c x 1 or c x n: prior means (column i: filter i).
  Eigen::MatrixXd P0;  ///< c x c or c x (n c): symmetric PSD prior covariances.
  Eigen::Index c() const { return F.rows(); }
  Eigen::Index d() const { return H.rows(); }
};
struct ManyFiltersRun {
  TimeSeries x_filt;       ///< T x (n c): row k-1 holds x_{k|k} of every filter (filter i in [i c, (i+1) c))
  Eigen::MatrixXd P_filt;  ///< c x (n c): the last P_{T|T} of every filter
};
/// Runs the n filters over y (T x (n d): row k-1 holds y_k of every filter, filter i in [i d, (i+1) d);
/// NaN = missing, skipped as MaskMissingMeasurements skips it): x_{k|k-1} = F x, P_{k|k-1} = F P F^T + Q,
/// S = H P H^T + R, K = P H^T S^{-1}, x_{k|k} = x_{k|k-1} + K (y_k - H x_{k|k-1}), P_{k|k} = P_{k|k-1} - K S K^T.
/// The whole run of a chunk of filters stays in cache (fixed-shape vectorized kernels for c <= 4,
/// d <= 2; any other c, d one filter at a time). x_filt (T x (n c), e.g. a numpy array) is written in place.
/// @throws kfx::Error naming the argument (and filter) on bad shapes, non-finite values, Q or P0 not
/// symmetric PSD, R not symmetric PD, or inf in y.
void FilterMany(const ManyFilterModel& model, const Eigen::Ref<const TimeSeries>& y, Eigen::Ref<TimeSeries> x_filt,
                Eigen::MatrixXd* P_filt);
/// The same, allocating the outputs.
ManyFiltersRun FilterMany(const ManyFilterModel& model, const TimeSeries& y);

// ---- Steady state and analysis (time-invariant) ---------------------------------------------------

struct SteadyStateOptions {
  int max_iterations = 100000;  ///< range >= 1
  /// Stop when |P_{k|k} - P_{k-1|k-1}|_F <= tolerance |P_{k|k}|_F; range (0, 1e-2].
  double tolerance = 1e-13;
  ProgressCallback progress{};
  bool IsValid(std::string* error) const;
};

/// P~_+ of eq. (19) (update-step form) by iterating the O(n r^2) step from P~_{0|0} = 0, which by
/// the proof of Prop. 2.1 is non-decreasing and converges when (F, H) is detectable and Q > 0.
struct BlockDiagonalSteadyState {
  Eigen::MatrixXd P_filt;  ///< c x (n c): P~_+
  BlockDiagonalGain gain;  ///< the limiting gain
  /// kConverged (relative_change <= tolerance), kNotConverged (max_iterations), kUnstable (the
  /// covariance grows without bound: no steady state), kLostDefiniteness (some H P H^T + R not positive
  /// definite); iterations, relative_change.
  Summary summary;
};
/// @throws kfx::Error on an invalid step or options. Numerical outcomes are in summary.
BlockDiagonalSteadyState SolveBlockDiagonalSteadyState(const CoupledStep& s,
                                                       const SteadyStateOptions& options = SteadyStateOptions());

/// P_+(D{V + G U G^T}) of the banded filter: one DARE per subsystem (packed c x (n c)); its gain
/// blocks c x (n d).
struct BandedSteadyState {
  Eigen::MatrixXd P_filt;  ///< c x (n c)
  Eigen::MatrixXd K;       ///< c x (n d) packed gain blocks
  /// kConverged, or the termination of the first subsystem DARE that fails (message names the block).
  Summary summary;
};
/// @throws kfx::Error on an invalid step. Numerical outcomes are in summary.
BandedSteadyState SolveBandedSteadyState(const CoupledStep& s);

/// Prop. 2.2 (004 Appendix A.2): the constants and the bounds, with Q = V + G U G^T, as printed and
/// as corrected by kfx. The printed bounds fail on random systems
/// (tests/methods/block_diagonal/block_diagonal_test.cpp); docs/papers/004.md derives the three corrections:
///  - alpha1 = 1 / (1 - rho(F_c)^2) is the norm of the inverse Lyapunov operator only for normal F_c;
///    the corrected constant is the operator norm ||(I - A (x) A)^{-1}||_2 itself;
///  - the forcing of the perturbed Riccati equation passes through I - K H (update form) or the
///    predictor closed loop A_p = F (I - K H), not through F_c = (I - K H) F: part (1) uses
///    alpha3^2 = ||I - K H||_2^2 for alpha2^2, part (2) uses ||A_p||_2 for alpha2;
///  - part (2)'s invariant set is ||Z||_F <= radius (printed: ||Z||_F^2).
struct Proposition22 {
  // Per subsystem (length n), as printed:
  Eigen::VectorXd alpha1, alpha2, alpha3, alpha4, alpha5;
  Eigen::VectorXd epsilon;          ///< ||G^(i) C G^(i)T||_F with C of eq. (20)
  Eigen::VectorXd bauer_fike;       ///< beta^(i): cond_2 of the eigenvector matrix of F_c^(i)(V)
  Eigen::VectorXd spectral_radius;  ///< max |lambda(F_c^(i)(V))|
  std::vector<bool> part1_applies;  ///< both conditions of part (1) as printed
  Eigen::VectorXd part1_bound;      ///< printed bound on ||Delta P~_+^(i)||_F (inf where it does not apply)
  // Per subsystem, corrected:
  Eigen::VectorXd lyapunov_norm;            ///< ||(I - F_c (x) F_c)^{-1}||_2 (>= alpha1)
  Eigen::VectorXd predictor_lyapunov_norm;  ///< ||(I - A_p (x) A_p)^{-1}||_2, A_p = F (I - K H)
  Eigen::VectorXd predictor_norm;           ///< ||A_p||_2
  std::vector<bool> part1_corrected_applies;
  Eigen::VectorXd part1_corrected_bound;  ///< on ||Delta P~_+^(i)||_F
  Eigen::MatrixXd C;                      ///< r x r, eq. (20)
  // Part (2), with alpha_j = max_i alpha_j^(i):
  double eta = 0.0;                 ///< ||G U G^T||_F
  bool part2_applies = false;       ///< 4 alpha1^2 alpha2^2 alpha5 eta < 1
  double part2_bound = 0.0;         ///< printed bound on ||Delta P_-||_F (inf when it does not apply)
  double part2_simple_bound = 0.0;  ///< 2 alpha1 eta
  double closed_loop_bound = 0.0;   ///< alpha3 alpha4 * part2_bound, on ||Delta F_c||_F
  bool part2_corrected_applies = false;
  double part2_corrected_bound = 0.0;  ///< on ||Delta P_-||_F, block-diagonal and full filters
  double closed_loop_corrected_bound = 0.0;
  /// kConverged, or the termination of the first DARE that fails (the constants are then incomplete).
  Summary summary;
};
/// @throws kfx::Error on invalid input. Numerical outcomes are in summary.
Proposition22 ComputeProposition22(const CoupledStep& s);

// ---- Identical subsystems: an exact reduction for any n -------------------------------------------
//
// With F^(i) = F, H^(i) = H, V^(i) = V, R^(i) = R, G^(i) = g for all i, every covariance and gain of
// the full, block-diagonal and banded filters has the form I_n (x) X + 1 1^T (x) Y. On the
// mean direction 1/sqrt(n) such a matrix acts as X + n Y, on its orthogonal complement as X; the
// process noise is V + n g U g^T on the first and V on the second. So the n-subsystem problem splits
// into two c-dimensional ones, exactly, for any n (docs/papers/004.md).

/// A symmetric (or gain) matrix I_n (x) X + 1 1^T (x) Y.
struct KroneckerStructured {
  Eigen::Index n = 0;
  Eigen::MatrixXd X, Y;
  Eigen::MatrixXd Dense() const;          ///< (n a) x (n b) (moderate n)
  Eigen::MatrixXd DiagonalBlock() const;  ///< X + Y
  Eigen::MatrixXd MeanMode() const;       ///< X + n Y
};
/// ||A - B||_F of two structured matrices with the same n: sqrt(n |dX + dY|^2 + n (n - 1) |dY|^2).
/// @throws kfx::Error unless a and b have the same n and block shapes.
double FrobeniusDistance(const KroneckerStructured& a, const KroneckerStructured& b);

struct IdenticalSubsystems {         ///< n identical subsystems (state c, measurement d) coupled by an r-input.
  Eigen::MatrixXd F, H, V, R, g, U;  ///< c x c, d x c, c x c, d x d, c x r, r x r
};

struct IdenticalAnalysis {  ///< Steady states of n identical coupled subsystems (004 Sec. 5), as I (x) X + 1 1^T (x) Y.
  KroneckerStructured full_P;       ///< P = P_+(V + G U G^T) of the full Kalman filter
  KroneckerStructured uncoupled_P;  ///< P_0 = P_+(V) (Y = 0)
  KroneckerStructured block_P;      ///< P~ = P~_+(V + G U G^T) (Y = 0)
  KroneckerStructured banded_P;     ///< P_+(D{V + G U G^T}) (Y = 0)
  KroneckerStructured block_gain;   ///< steady gain K~ (c x d blocks)
  KroneckerStructured banded_gain;  ///< steady gain of the banded filter
  KroneckerStructured full_gain;    ///< steady gain of the full Kalman filter
  /// True stationary error covariances E[e e^T] of each filter's steady-state gain on the true
  /// system (empty X when the filter is unstable on a mode). The full filter's equals full_P.
  KroneckerStructured block_true, banded_true, full_true;
  Summary block_summary;  ///< the block-diagonal steady-state iteration (as SolveBlockDiagonalSteadyState)
  /// kConverged, or the termination of the first DARE that fails (the later fields are then not set).
  Summary summary;
};
/// Everything of Sec. 3.1 for n identical subsystems, in O(c^3) per iteration independent of n.
/// @throws kfx::Error on invalid input. Numerical outcomes are in summary and block_summary.
IdenticalAnalysis AnalyzeIdenticalSubsystems(const IdenticalSubsystems& sys, Eigen::Index n,
                                             const SteadyStateOptions& options = SteadyStateOptions());

/// Whether the full Kalman filter "decouples" as n -> infinity (004 Sec. 3.1). The mean mode carries
/// process noise V + n g U g^T; as n -> infinity u_k becomes an unknown input with no prior, and the
/// mean-mode covariance stays bounded iff the system is strongly detectable. When H g is square and
/// invertible (d = r) the input is reconstructed exactly from y_k, no measurement is left over, and
/// the condition is rho((I - g (H g)^{-1} H) F) < 1, the spectral radius returned here (its eigenvalues
/// are the invariant zeros of y_k against u_k). For 004 Sec. 3.1 it is max(|0.9 - beta/2|, 0).
/// @throws kfx::Error unless d = r and H g is invertible.
double UnknownInputSpectralRadius(const IdenticalSubsystems& sys);

}  // namespace kfx
