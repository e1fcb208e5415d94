#pragma once
// Private: the health checks of a filter run (FilterRunOptions::monitor_health, kfx/filter_health.hpp)
// and the finite check of each step's outputs, used by RunFilter and ComputeKalmanSchedule.
#include <Eigen/Dense>

#include "kfx/filter_health.hpp"

namespace kfx::detail {

/// Accumulates FilterHealth over a run.
class HealthMonitor {
 public:
  /// eigenvalues: a symmetric eigendecomposition of every P_{k|k}, else only where Cholesky fails.
  HealthMonitor(bool enabled, bool eigenvalues);
  /// Step k: filtered covariance P_{k|k}, innovation nu (observed entries) and its covariance S.
  void Observe(int k, const Eigen::Ref<const Eigen::MatrixXd>& P, const Eigen::Ref<const Eigen::VectorXd>& nu,
               const Eigen::Ref<const Eigen::MatrixXd>& S);
  FilterHealth Finish() const;

 private:
  FilterHealth h_;
  bool eigenvalues_ = true;
};

/// @throws kfx::NumericalError naming step k if x, the diagonal of P or the likelihood term is not finite.
void RequireFiniteStep(int k, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::MatrixXd>& P,
                       double log_likelihood);

}  // namespace kfx::detail
