#pragma once
// Private: the square-root, UD and information forms of the Kalman filter (FilterForm other than
// kConventional), each keeping its factored covariance from step to step (factored_forms.cpp).
#include <Eigen/Dense>
#include <memory>
#include <string>
#include <vector>

#include "kfx/kalman_filter.hpp"

namespace kfx::detail {

class FactoredCovariance;

/// One factored form over a run or one Predict/Update call: x, the factored covariance and P of the
/// current step (the form interface: filter_form.cpp). Single steps factor the given P (any positive
/// semidefinite P for the square-root and UD forms, a positive definite P for the information form).
class FactoredForm {
 public:
  using Matrix = Eigen::MatrixXd;
  /// RunFilter's steady-state fast path is the conventional form's only.
  static constexpr bool kSteadyState = false;

  FactoredForm(const KalmanFilterOptions& options, Eigen::Index n);
  ~FactoredForm();
  /// The prefix of a step's NumericalError messages: the form's name.
  std::string context() const;
  /// @throws kfx::NumericalError if P has no factor of this form.
  void Start(const Eigen::VectorXd& x, const Eigen::MatrixXd& P);
  /// After Start; the step must outlive its use (until the next SetStep).
  void SetStep(const ModelStep& s);
  void Predict();
  /// false (nothing changed) when no entry of y is observed.
  bool Update(const Eigen::Ref<const Eigen::VectorXd>& y);
  /// x <- x + v (a known input's G_k g_k after Predict).
  void ShiftMean(const Eigen::VectorXd& v) { x_ += v; }

  const Eigen::VectorXd& x() const { return x_; }
  const Eigen::MatrixXd& P() const { return P_; }
  const Eigen::VectorXd& innovation() const { return innovation_; }
  const Eigen::MatrixXd& innovation_cov() const { return innovation_cov_; }
  const Eigen::MatrixXd& gain() const { return gain_; }
  const std::vector<Eigen::Index>& observed() const { return observed_; }
  double log_likelihood() const { return log_likelihood_; }

 private:
  bool CorrelatedUpdate(const Eigen::Ref<const Eigen::VectorXd>& y);
  FilterForm form_;
  Eigen::Index n_;
  const ModelStep* step_ = nullptr;
  std::unique_ptr<FactoredCovariance> cov_;
  Eigen::VectorXd x_;
  Eigen::MatrixXd P_;  // the covariance of cov_, formed after each step
  Eigen::VectorXd innovation_;
  Eigen::MatrixXd innovation_cov_, gain_;
  std::vector<Eigen::Index> observed_;
  double log_likelihood_ = 0.0;
};

}  // namespace kfx::detail
