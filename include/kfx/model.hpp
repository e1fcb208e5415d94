#pragma once
// Discrete-time linear Gaussian state-space model (notation: docs/notation.md).
//
//   x_k = A_k x_{k-1} + G_k g_k + w_k,   w_k ~ N(0, Q_k)   (or w_k = B_k u_k, u_k ~ N(0, U_k), Q_k = B_k U_k B_k^T)
//   y_k = C_k x_k + D_k g_k + v_k,       v_k ~ N(0, R_k),   cov(w_k, v_k) = S_k
//   x_0 ~ N(m_0, P_0),          k = 1, 2, ...
//
// g_k is a known (deterministic) input of q entries (issue 22; G_k, D_k empty: none); S_k pairs the noise
// that produces x_k with the measurement of x_k (FilterPy's M; empty: 0). Noises of different steps are
// independent.
//
// The first measurement is y_1 (of x_1); x_0 is only known through its prior. Steps are numbered
// from 1; a time-varying sequence stores step k at index k - 1.
#include <Eigen/Dense>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "kfx/step_schedule.hpp"

namespace kfx {

/// A sequence in time-major layout: row k is the vector at time k (the (T, n) shape of numpy).
using TimeSeries = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// The matrices of one step of the model.
struct ModelStep {
  Eigen::MatrixXd A;  ///< n x n state transition A_k.
  Eigen::MatrixXd C;  ///< m x n measurement matrix C_k.
  Eigen::MatrixXd Q;  ///< n x n process-noise covariance Q_k (symmetric PSD).
  Eigen::MatrixXd R;  ///< m x m measurement-noise covariance R_k (symmetric PD).
  /// Optional n x p noise input: when not empty, w_k = B_k u_k with u_k ~ N(0, U_k) and
  /// Q = B U B^T (filled in by MakeStepWithNoiseInput). Simulation then draws u_k (p numbers).
  Eigen::MatrixXd B;
  Eigen::MatrixXd U;  ///< p x p covariance of u_k (symmetric PSD); empty when B is empty.
  /// Optional n x q known-input matrix G_k: x_k gets G_k g_k (empty: no known input in the state).
  Eigen::MatrixXd G;
  /// Optional m x q feedthrough D_k: y_k gets D_k g_k (empty: none). G and D, when both given, have q columns.
  Eigen::MatrixXd D;
  /// Optional n x m cross-covariance S_k = E[w_k v_k^T] (empty: 0); [[Q, S], [S^T, R]] must be PSD.
  Eigen::MatrixXd S;

  Eigen::Index state_dim() const { return A.rows(); }  ///< n
  Eigen::Index meas_dim() const { return C.rows(); }   ///< m
  /// q, the length of g_k: the columns of G or D (0 when the step has no known input).
  Eigen::Index input_dim() const { return G.size() > 0 ? G.cols() : D.cols(); }
  bool has_known_input() const { return G.size() > 0 || D.size() > 0; }  ///< G or D given
  bool has_cross_covariance() const { return S.size() > 0; }             ///< S given
};

/// A step with process noise covariance Q given directly.
ModelStep MakeStep(Eigen::MatrixXd A, Eigen::MatrixXd C, Eigen::MatrixXd Q, Eigen::MatrixXd R);
/// A step with process noise w = B u, u ~ N(0, U); sets Q = B U B^T.
ModelStep MakeStepWithNoiseInput(Eigen::MatrixXd A, Eigen::MatrixXd B, Eigen::MatrixXd U, Eigen::MatrixXd C,
                                 Eigen::MatrixXd R);

/// Checks one step: dimensions (n x n, m x n, ...), finiteness, Q (and U) symmetric PSD, R symmetric
/// PD, Q == B U B^T when B is given; G n x q, D m x q (the same q), S n x m with the joint covariance
/// [[Q, S], [S^T, R]] PSD (reported as "S").
/// @param label prefix for messages, e.g. "step 3: " (may be empty).
/// @throws kfx::Error naming the offending matrix ("A", "Q", ...) and what was expected.
void ValidateStep(const ModelStep& step, Eigen::Index n, Eigen::Index m, const std::string& label = "");

using StepPtr = std::shared_ptr<const ModelStep>;

/// A validated model: time-invariant (one step), time-varying (a sequence) or given by a
/// callback k -> step. Copies are cheap (steps are shared, immutable). It has at least one state and one
/// measurement: n = 0 or m = 0 (a 0 x 0 A, a C with no rows) throws kfx::Error naming A or C (n, m for a
/// callback model) in every constructor, so model files and the Python package reject them too.
/// @throws kfx::Error (every constructor) naming the matrix (and step) at fault: A not square, C, Q, R, B, U
/// of the wrong shape, non-finite entries, Q, U, P0 not symmetric PSD, R not symmetric PD, Q given with
/// B, U, m0 not of length n, n = 0 or m = 0, an empty list of steps.
class Model {
 public:
  using StepFunction = std::function<ModelStep(int k)>;

  /// Time-invariant model. @throws kfx::Error on invalid input.
  Model(ModelStep step, Eigen::VectorXd m0, Eigen::MatrixXd P0);
  /// Time-varying model over steps k = 1..steps.size() (steps[k-1] is step k).
  /// @throws kfx::Error on invalid input, naming the step.
  Model(std::vector<ModelStep> steps, Eigen::VectorXd m0, Eigen::MatrixXd P0);
  /// Time-varying model given by a callback; each step is validated when it is first asked for.
  /// @param horizon number of steps defined (-1: unbounded).
  Model(Eigen::Index n, Eigen::Index m, StepFunction function, Eigen::VectorXd m0, Eigen::MatrixXd P0,
        int horizon = -1);

  Eigen::Index state_dim() const { return n_; }                      ///< n
  Eigen::Index meas_dim() const { return m_; }                       ///< m
  bool time_invariant() const { return kind_ == Kind::kInvariant; }  ///< one step for every k
  /// The known input's length q of every step (0: none). A callback model reports the q of step 1.
  Eigen::Index input_dim() const;
  /// Number of steps for which the model is defined, or -1 when unbounded (time-invariant or
  /// callback without horizon).
  int horizon() const { return horizon_; }
  /// The matrices of step k >= 1. @throws kfx::Error if k is out of range.
  StepPtr step(int k) const;
  const Eigen::VectorXd& m0() const { return m0_; }  ///< prior mean of x_0 (length n)
  const Eigen::MatrixXd& P0() const { return P0_; }  ///< prior covariance of x_0 (n x n, symmetric PSD)

  /// Number of steps to run when the caller asks for `steps` (negative: the model's horizon).
  /// @throws kfx::Error if steps exceeds the horizon, or if both are unbounded.
  int ResolveSteps(int steps, const std::string& what = "steps") const;

  /// The same model with a different prior. @throws kfx::Error if m0 is not of length n or P0 not n x n
  /// symmetric PSD.
  Model WithPrior(Eigen::VectorXd m0, Eigen::MatrixXd P0) const;

 private:
  using Kind = detail::ScheduleKind;
  void ValidatePrior();
  Kind kind_;
  Eigen::Index n_ = 0, m_ = 0;
  int horizon_ = -1;
  std::vector<StepPtr> steps_;
  StepFunction function_;
  Eigen::VectorXd m0_;
  Eigen::MatrixXd P0_;
};

/// The known-input terms of one step: G_k g_k (length n) and D_k g_k (length m); an empty vector where
/// the step has no G (no D).
struct KnownInputTerms {
  Eigen::VectorXd state;
  Eigen::VectorXd measurement;
};
/// The terms of step k from the series g (T x q, row k-1 = g_k; 0 columns when the model has no known input).
/// @throws kfx::Error naming g when its width is not the step's q or row k-1 is missing or not finite.
KnownInputTerms KnownInputAt(const ModelStep& step, const TimeSeries& g, int k);
/// The terms of one step for its known input g_k (length q; an empty vector when the step has no G or D), for
/// the single-step Predict / Update (kfx/kalman_filter.hpp).
/// @throws kfx::Error naming g when the step has G or D and g is empty or not of length q, when g is given for
///         a step with neither, or when an entry is not finite.
KnownInputTerms KnownInputOf(const ModelStep& step, const Eigen::Ref<const Eigen::VectorXd>& g);
/// Checks g against the model for steps 1..T: at least T rows and q columns when the model has a known
/// input (q = model.input_dim()), none (0 columns) when it has not; finite.
/// @throws kfx::Error naming g and what was expected.
void RequireKnownInput(const Model& model, const TimeSeries& g, int T);

}  // namespace kfx
