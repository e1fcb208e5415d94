#pragma once
// Every filter in kfx is a linear recursion (docs/exact-performance.md):
//   z_k = Phi_k z_{k-1} + K_k y_k + Gamma_k g_k,   estimate of x_k = O_k z_k,   k = 1, 2, ...,  z_0 given,
// where z_k (dimension n_z) is the filter's own state and g_k the model's known input (kfx/model.hpp; the
// term is optional: a filter with no Gamma ignores the input). The offline part of a method computes the
// schedule (Phi_k, K_k, O_k); the online part is RunLinearFilter. The exact-performance engine
// (performance.hpp) evaluates any LinearFilter against any true Model.
#include <Eigen/Dense>
#include <functional>
#include <memory>
#include <vector>

#include "kfx/step_schedule.hpp"

#include "kfx/model.hpp"

namespace kfx {

struct LinearFilterStep {  ///< One step of a linear filter: z_k = Phi z_{k-1} + K y_k + Gamma g_k, estimate O z_k.
  Eigen::MatrixXd Phi;     ///< n_z x n_z
  Eigen::MatrixXd K;       ///< n_z x m
  Eigen::MatrixXd O{};     ///< n_out x n_z output map; empty means identity (n_out = n_z)
  /// n_z x q known-input map (issue 22); empty means none at this step (the filter ignores g_k). The Kalman
  /// filter's is (I - K C) G - K D (KalmanAsLinearFilter).
  Eigen::MatrixXd Gamma{};
};

using LinearFilterStepPtr = std::shared_ptr<const LinearFilterStep>;

/// A validated linear filter. @throws kfx::Error (every constructor) naming the matrix (and step) at fault:
/// Phi not n_z x n_z, K not n_z x m, O not n_out x n_z (or missing when n_out != n_z), Gamma not n_z x q
/// (q: the columns of the first step's Gamma, or the callback constructor's q), z0 not of length n_z,
/// O0 not n_out x n_z, non-finite entries, an empty list of steps.
class LinearFilter {
 public:
  using StepFunction = std::function<LinearFilterStep(int k)>;

  /// Time-invariant filter with initial state z0 and output map O0 for k = 0 (empty: the step's O).
  /// @throws kfx::Error on inconsistent dimensions or non-finite entries.
  LinearFilter(LinearFilterStep step, Eigen::VectorXd z0, Eigen::MatrixXd O0 = Eigen::MatrixXd());
  /// Time-varying filter over k = 1..steps.size() (steps[k-1] is step k).
  LinearFilter(std::vector<LinearFilterStep> steps, Eigen::VectorXd z0, Eigen::MatrixXd O0 = Eigen::MatrixXd());
  /// Filter given by a callback (validated as each step is asked for); horizon -1: unbounded; q the
  /// known input's length that the steps' Gamma take (0: the steps have no Gamma).
  LinearFilter(Eigen::Index n_z, Eigen::Index m, Eigen::Index n_out, StepFunction function, Eigen::VectorXd z0,
               Eigen::MatrixXd O0, int horizon = -1, Eigen::Index q = 0);

  Eigen::Index state_dim() const { return n_z_; }                    ///< n_z
  Eigen::Index meas_dim() const { return m_; }                       ///< m
  Eigen::Index output_dim() const { return n_out_; }                 ///< n_out (the estimated state's dimension)
  Eigen::Index input_dim() const { return q_; }                      ///< q of Gamma (0: ignores any known input)
  bool time_invariant() const { return kind_ == Kind::kInvariant; }  ///< one step for every k
  int horizon() const { return horizon_; }                           ///< steps defined, -1 when unbounded
  /// The step k >= 1 (Phi_k, K_k, O_k). @throws kfx::Error if k is outside 1..horizon.
  LinearFilterStepPtr step(int k) const;
  const Eigen::VectorXd& z0() const { return z0_; }  ///< initial filter state (length n_z)
  /// Output map at k = 0 (identity when empty and n_out == n_z).
  const Eigen::MatrixXd& O0() const { return O0_; }

 private:
  using Kind = detail::ScheduleKind;
  void Validate(const LinearFilterStep& s, const std::string& label) const;
  Kind kind_;
  Eigen::Index n_z_ = 0, m_ = 0, n_out_ = 0, q_ = 0;
  int horizon_ = -1;
  std::vector<LinearFilterStepPtr> steps_;
  StepFunction function_;
  Eigen::VectorXd z0_;
  Eigen::MatrixXd O0_;
};

/// Applies O (empty = identity) to z.
Eigen::VectorXd ApplyOutput(const Eigen::MatrixXd& O, const Eigen::VectorXd& z);

/// The online part: runs the filter on measurements y (T x m, row k-1 = y_k; no NaN) and returns
/// the estimates O_k z_k for k = 0..T as a (T+1) x n_out time series.
/// @throws kfx::Error on dimension mismatch, non-finite y, T beyond the filter's horizon, or (naming g) a
///         filter with a known-input map Gamma (input_dim() > 0): use the overload with g.
TimeSeries RunLinearFilter(const LinearFilter& filter, const TimeSeries& y);
/// The same with the known input g (T x q, row k-1 = g_k; q = filter.input_dim(), 0 columns for a filter
/// without Gamma): z_k gets Gamma_k g_k.
/// @throws kfx::Error as above, and naming g when it has not q columns and T rows or has a non-finite entry.
TimeSeries RunLinearFilter(const LinearFilter& filter, const TimeSeries& y, const TimeSeries& g);

}  // namespace kfx
