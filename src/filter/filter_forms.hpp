#pragma once
// Private: the square-root, UD and information forms of the Kalman filter (FilterForm) and the
// health monitor of RunFilter. kalman_filter.cpp dispatches here when options.form is not
// kConventional; the public entry points stay those of include/kfx/kalman_filter.hpp.
#include <Eigen/Dense>

#include "kfx/filter_health.hpp"
#include "kfx/kalman_filter.hpp"

namespace kfx::detail {

/// Predict/Update/RunFilter/ComputeKalmanSchedule for options.form != kConventional. The
/// one-step functions factor the given P (any positive semidefinite P for the square-root and UD
/// forms, a positive definite P for the information form); RunFilter and ComputeKalmanSchedule
/// keep the factored representation across steps.
Estimate FactoredPredict(const Estimate& e, const ModelStep& s, const KalmanFilterOptions& options);
UpdateResult FactoredUpdate(const Estimate& prior, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& y,
                            const KalmanFilterOptions& options);
FilterRun FactoredRunFilter(const Model& model, const TimeSeries& y, const FilterRunOptions& options);
KalmanSchedule FactoredKalmanSchedule(const Model& model, const KalmanScheduleOptions& options);

/// Accumulates FilterHealth over a run.
class HealthMonitor {
 public:
  explicit HealthMonitor(bool enabled);
  /// Step k: filtered covariance P_{k|k}, innovation nu (observed entries) and its covariance S.
  void Observe(int k, const Eigen::Ref<const Eigen::MatrixXd>& P, const Eigen::Ref<const Eigen::VectorXd>& nu,
               const Eigen::Ref<const Eigen::MatrixXd>& S);
  FilterHealth Finish() const;

 private:
  FilterHealth h_;
};

/// @throws kfx::NumericalError naming step k if x, the diagonal of P or the likelihood term is not finite.
void RequireFiniteStep(int k, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::MatrixXd>& P,
                       double log_likelihood);

}  // namespace kfx::detail
