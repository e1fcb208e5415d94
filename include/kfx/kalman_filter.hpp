#pragma once
// The Kalman filter and the Rauch-Tung-Striebel smoother (notation: docs/notation.md).
//
//   predict:  x_{k|k-1} = A_k x_{k-1|k-1},   P_{k|k-1} = A_k P_{k-1|k-1} A_k^T + Q_k
//   update:   nu_k = y_k - C_k x_{k|k-1},  S_k = C_k P_{k|k-1} C_k^T + R_k,
//             K_k = P_{k|k-1} C_k^T S_k^{-1}  (filter gain),   x_{k|k} = x_{k|k-1} + K_k nu_k,
//             P_{k|k} = (I - K_k C_k) P_{k|k-1} (I - K_k C_k)^T + K_k R_k K_k^T  (Joseph form)
//   log-likelihood term: -1/2 (m_obs log 2 pi + log det S_k + nu_k^T S_k^{-1} nu_k)
//
// Missing measurements: NaN entries of y_k are left out (the update uses the observed rows of
// C_k, R_k only); a step with no observed entry is a pure prediction. S_k is factored (Cholesky),
// never inverted. The offline part (gain and covariance schedule, ComputeKalmanSchedule) is
// separate from the online part (the estimate update); KalmanAsLinearFilter expresses the
// filter as the linear recursion that the exact-performance engine evaluates.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "kfx/enum_text.hpp"
#include "kfx/filter_health.hpp"
#include "kfx/linear_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/progress.hpp"
#include "kfx/riccati.hpp"

namespace kfx {

/// A Gaussian estimate: mean and covariance.
struct Estimate {
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
};

enum class CovarianceUpdateForm {
  kJoseph,    ///< (I - K C) P (I - K C)^T + K R K^T, evaluated in O(n^2 m); PSD-preserving. Default.
  kStandard,  ///< P - K C P (cheaper in nothing here, kept for comparison studies).
};
/// "joseph", "standard".
const char* ToString(CovarianceUpdateForm form);
template <>
struct EnumValues<CovarianceUpdateForm> {
  static constexpr CovarianceUpdateForm kAll[] = {CovarianceUpdateForm::kJoseph, CovarianceUpdateForm::kStandard};
};

/// How the covariance is represented and propagated (src/filter/, docs/robustness.md).
/// All forms give the same gains in exact arithmetic; they differ in rounding.
enum class FilterForm {
  kConventional,  ///< P itself, update by update_form (Joseph or standard). Default.
  kSquareRoot,    ///< a square-root factor of P, propagated by QR of the pre-arrays (as SLICOT FB01QD)
  kUD,            ///< Bierman-Thornton: P = U D U^T (Bierman update, Thornton MWGS time update)
  kInformation,   ///< the information matrix P^{-1} (needs P0 > 0, and A_k invertible or Q_k > 0)
};
/// "conventional", "sqrt", "ud", "information" (the CLI's --form names the conventional form by its
/// update form, "joseph" or "standard").
const char* ToString(FilterForm form);
template <>
struct EnumValues<FilterForm> {
  static constexpr FilterForm kAll[] = {FilterForm::kConventional, FilterForm::kSquareRoot, FilterForm::kUD,
                                        FilterForm::kInformation};
};

struct KalmanFilterOptions {
  FilterForm form = FilterForm::kConventional;
  /// Conventional form only.
  CovarianceUpdateForm update_form = CovarianceUpdateForm::kJoseph;
  /// Replace P by (P + P^T)/2 after every predict and update.
  bool symmetrize = true;
  bool IsValid(std::string* error) const;
};

/// The result of one measurement update.
struct UpdateResult {
  Estimate estimate;                   ///< x_{k|k}, P_{k|k}
  Eigen::VectorXd innovation;          ///< nu_k over the observed entries (length num_observed)
  Eigen::MatrixXd innovation_cov;      ///< S_k over the observed entries
  Eigen::MatrixXd gain;                ///< n x num_observed filter gain K_k
  std::vector<Eigen::Index> observed;  ///< indices of the observed entries of y_k
  double log_likelihood = 0.0;         ///< the step's log-likelihood term (0 when nothing is observed)
};

/// Time update with step matrices s and the step's known input g (length q; empty when the step has no G
/// or D): x_{k|k-1} = A_k x_{k-1|k-1} + G_k g_k, P_{k|k-1} = A_k P A_k^T + Q_k (RunFilter's predict).
/// @throws kfx::Error on dimension mismatch, and naming g when the step has G or D and g is not of length q,
///         or g is given for a step without them (kfx::KnownInputOf).
Estimate Predict(const Estimate& estimate, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& g,
                 const KalmanFilterOptions& options = {});
/// Predict without a known input. @throws kfx::Error as above (naming g when the step has G or D).
Estimate Predict(const Estimate& estimate, const ModelStep& s, const KalmanFilterOptions& options = {});
/// Measurement update with y (length m; NaN entries are missing) and the step's known input g (D_k g_k is
/// taken off y_k). A step with a cross-covariance S is updated by the correlated update of RunFilter
/// (K = (P C^T + S)(C P C^T + C S + S^T C^T + R)^{-1}), which assumes that `prior` is the prediction of the same
/// step (S pairs w_k, in P_{k|k-1}, with v_k). The same code as RunFilter's update (one form per options).
/// @throws kfx::Error on dimension mismatch or infinite entries of y, naming g as Predict;
///         kfx::NumericalError if S_k is not numerically positive definite.
UpdateResult Update(const Estimate& prior, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& y,
                    const Eigen::Ref<const Eigen::VectorXd>& g, const KalmanFilterOptions& options = {});
/// Update without a known input. @throws kfx::Error, kfx::NumericalError as above.
UpdateResult Update(const Estimate& prior, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& y,
                    const KalmanFilterOptions& options = {});

/// A convenience filter over a Model: holds the current estimate and step index.
class KalmanFilter {
 public:
  explicit KalmanFilter(Model model, KalmanFilterOptions options = {});
  /// Back to k = 0 with the prior (m0, P0).
  void Reset();
  /// Advances to k + 1: x_{k+1|k}, P_{k+1|k}. @throws kfx::Error naming g when step k + 1 has G or D.
  void Predict();
  /// Predict with the known input g_{k+1} of step k + 1 (length q). @throws kfx::Error naming g (KnownInputOf).
  void Predict(const Eigen::Ref<const Eigen::VectorXd>& g);
  /// Updates the current (predicted) estimate with y_k. Must follow Predict().
  /// @throws kfx::Error naming g when step k has G or D.
  UpdateResult Update(const Eigen::Ref<const Eigen::VectorXd>& y);
  /// Update with the known input g_k of the current step k (D_k g_k is taken off y_k).
  UpdateResult Update(const Eigen::Ref<const Eigen::VectorXd>& y, const Eigen::Ref<const Eigen::VectorXd>& g);
  /// Predict() then Update(y).
  UpdateResult Step(const Eigen::Ref<const Eigen::VectorXd>& y);
  /// Predict(g) then Update(y, g): one step with the known input g_{k+1}.
  UpdateResult Step(const Eigen::Ref<const Eigen::VectorXd>& y, const Eigen::Ref<const Eigen::VectorXd>& g);
  int k() const { return k_; }
  const Estimate& estimate() const { return estimate_; }
  const Model& model() const { return model_; }

 private:
  Model model_;
  KalmanFilterOptions options_;
  Estimate estimate_;
  int k_ = 0;
  bool predicted_ = false;
};

struct FilterRunOptions {
  KalmanFilterOptions filter{};
  /// Keep every P_{k|k-1}, P_{k|k} (needed by the smoother; n^2 (2T + 2) doubles).
  bool store_covariances = true;
  /// Check symmetry, definiteness (eigenvalues, Cholesky) of P_{k|k} and the NIS at every step
  /// (O(n^3) per step) and report them in FilterRun::health. The CLI and the Python package turn the
  /// cheap checks (below) on by default and warn with HealthWarning (docs/robustness.md, class 8).
  bool monitor_health = false;
  /// With monitor_health: false = the cheap checks (a Cholesky factorization of P_{k|k}, about n^3/3
  /// flops, and the NIS), the smallest eigenvalue computed only at steps where the factorization
  /// fails (FilterHealth::min_eigenvalue is then over those steps, +inf when none failed); true =
  /// also a symmetric eigendecomposition at every step.
  bool monitor_eigenvalues = true;
  ProgressCallback progress{};
  /// Steady-state fast path (time-invariant models only; 0 = off, the default): once a full step
  /// changes P_{k|k} by at most this, relative in the Frobenius norm, the gain, S_k and the
  /// covariances are frozen and later steps update only the mean, O(n^2 + n m) instead of O(n^3).
  /// The switch also freezes at the rounding floor of the changes when that lies above the tolerance
  /// (the StagnationDetector of the steady-state iterations). A step with a missing measurement ends the
  /// freeze (the full recursion resumes). Range [0, 1e-2].
  double steady_state_tolerance = 0.0;
};

/// A whole-sequence filter run on measurements y (T x m, row k-1 = y_k, NaN = missing).
struct FilterRun {
  TimeSeries x_filt;                     ///< (T+1) x n, row k = x_{k|k}; row 0 = m0
  TimeSeries x_pred;                     ///< (T+1) x n, row k = x_{k|k-1}; row 0 = m0
  TimeSeries P_filt_diag;                ///< (T+1) x n, diagonals of P_{k|k}; row 0 = diag P0
  TimeSeries P_pred_diag;                ///< (T+1) x n
  std::vector<Eigen::MatrixXd> P_filt;   ///< T+1 matrices if stored (index k), else empty
  std::vector<Eigen::MatrixXd> P_pred;   ///< T+1 matrices if stored (index 0 = P0), else empty
  TimeSeries innovations;                ///< T x m, NaN where the measurement was missing
  Eigen::VectorXd log_likelihood_terms;  ///< length T
  double log_likelihood = 0.0;           ///< sum of the terms
  std::vector<int> num_observed;         ///< length T
  int steady_state_steps = 0;            ///< steps done on the frozen gain (steady_state_tolerance)
  FilterHealth health;                   ///< filled when FilterRunOptions::monitor_health
  std::string health_warning;            ///< HealthWarning(health, options.filter): "" when healthy
};

/// One line for the user when a monitored run is not healthy, naming what failed and the form to use
/// instead (the UD or square-root form when P_{k|k} lost definiteness); empty when healthy or not
/// monitored.
std::string HealthWarning(const FilterHealth& health, const KalmanFilterOptions& filter);

/// Runs the filter over y. @throws kfx::Error on dimension mismatch / horizon exceeded;
/// kfx::NumericalError when an estimate, covariance or likelihood term is not finite.
FilterRun RunFilter(const Model& model, const TimeSeries& y, const FilterRunOptions& options = {});
/// Runs the filter over y with the known input g (T x q, row k-1 = g_k; issue 22): G_k g_k is added to
/// x_{k|k-1}, D_k g_k taken off y_k; in every form. A model with a cross-covariance S is filtered by the
/// correlated update (kfx/model.hpp, UpdateInPlace in src/filter/conventional_form.hpp).
/// @throws kfx::Error as above, and naming g when it does not fit the model's G, D (kfx::RequireKnownInput).
FilterRun RunFilter(const Model& model, const TimeSeries& y, const TimeSeries& g, const FilterRunOptions& options = {});

struct SmootherRun {               ///< The RTS smoother's estimates x_{k|T} and covariances P_{k|T}, k = 0..T.
  TimeSeries x;                    ///< (T+1) x n, row k = x_{k|T}
  TimeSeries P_diag;               ///< (T+1) x n
  std::vector<Eigen::MatrixXd> P;  ///< T+1 matrices P_{k|T}
};

struct SmootherOptions {
  ProgressCallback progress{};  ///< (T - k, T) after the smoothed estimate of step k
};

/// Rauch-Tung-Striebel smoother: G_k = P_{k|k} A_{k+1}^T P_{k+1|k}^{-1} (by a Cholesky solve; a
/// complete orthogonal decomposition, i.e. the pseudo-inverse, when P_{k+1|k} is singular),
/// x_{k|T} = x_{k|k} + G_k (x_{k+1|T} - x_{k+1|k}), P_{k|T} = P_{k|k} + G_k (P_{k+1|T} - P_{k+1|k}) G_k^T.
/// A known input needs nothing more (it is in x_{k+1|k}). At a step whose model has a cross-covariance S
/// and an observed measurement, x_k is not independent of y_{k+1} given x_{k+1}, and the step conditions on
/// the observed measurement noise too (the run's innovations; the equations in kalman_filter.cpp,
/// CorrelatedSmootherStep).
/// @throws kfx::Error if the run did not store covariances or does not match the model.
SmootherRun RtsSmooth(const Model& model, const FilterRun& run, const SmootherOptions& options = {});

/// The offline part of the Kalman filter: the gain and covariance schedule for k = 1..T (all
/// measurements present). Riccati difference equation P_{k|k-1} = A_k P_{k-1|k-1} A_k^T + Q_k.
struct KalmanSchedule {
  std::vector<Eigen::MatrixXd> filter_gain;  ///< index k = 1..T (index 0 unused, empty)
  std::vector<Eigen::MatrixXd> P_pred;       ///< index k = 0..T (P_pred[0] = P0)
  std::vector<Eigen::MatrixXd> P_filt;       ///< index k = 0..T (P_filt[0] = P0)
};
struct KalmanScheduleOptions {
  int steps = -1;  ///< T (negative: the model's horizon)
  KalmanFilterOptions filter{};
  ProgressCallback progress{};
};
/// @throws kfx::Error on invalid options or steps beyond the horizon; kfx::NumericalError (a recursion)
///         when a step's covariance cannot be computed.
KalmanSchedule ComputeKalmanSchedule(const Model& model, const KalmanScheduleOptions& options = {});

/// The steady-state Kalman filter of a time-invariant step, its cross-covariance S (kfx's pairing:
/// cov(w_k, v_k) = S with w_k producing x_k) included. Without S: SolveFilterDare(A, C, Q, R, options).
/// With S: the filter DARE of the equivalent pairing of the riccati layer, y_k = (C A) x_{k-1} + v~_k with
/// v~_k = C w_k + v_k, i.e. SolveFilterDare(A, C A, Q, C Q C^T + C S + S^T C^T + R, Q C^T + S): its P_pred is
/// the model's P_{k|k} and its predictor gain the model's filter gain K_f = (P C^T + S) W^{-1}, W = C P C^T +
/// C S + S^T C^T + R (RunFilter's correlated update); the result holds the model's P_pred = A P_{k|k} A^T + Q,
/// P_filt, K_f, K_p = A K_f and W. The certificate fields (closed_loop_spectral_radius, min_eigenvalue) are
/// those of the equivalent DARE: rho((I - K_f C) A), which equals rho(A (I - K_f C)), and lambda_min(P_{k|k}).
/// @throws kfx::Error as SolveFilterDare, naming S when C Q C^T + C S + S^T C^T + R is not positive definite.
DareSolution SteadyStateDare(const ModelStep& step, const DareOptions& options = {});

/// The Kalman filter as a linear recursion z_k = Phi_k z_{k-1} + K_k y_k + Gamma_k g_k with z = x_{k|k}:
/// Phi_k = (I - K_k C_k) A_k, K_k the filter gain, O = I, z_0 = m0, and for a model with a known input
/// Gamma_k = (I - K_k C_k) G_k - K_k D_k (RunFilter's G g in x_{k|k-1} and D g off y_k; empty without G, D).
/// @throws kfx::Error if the schedule has no step or more steps than the model defines.
LinearFilter KalmanAsLinearFilter(const Model& model, const KalmanSchedule& schedule);

/// A time-invariant filter with a constant filter gain K_f (e.g. the steady-state gain from
/// SolveFilterDare): Phi = (I - K_f C) A, K = K_f, O = I, z_0 = z0, Gamma = (I - K_f C) G - K_f D when the
/// design step has a known input (G, D).
/// @throws kfx::Error if filter_gain is not n x m, z0 not of length n, or an entry is not finite.
LinearFilter ConstantGainAsLinearFilter(const ModelStep& design, const Eigen::Ref<const Eigen::MatrixXd>& filter_gain,
                                        const Eigen::Ref<const Eigen::VectorXd>& z0);

}  // namespace kfx
