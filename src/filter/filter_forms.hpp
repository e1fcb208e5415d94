#pragma once
// Private: the square-root, UD and information forms of the Kalman filter (FilterForm).
// kalman_filter.cpp dispatches here when options.form is not kConventional; the public entry
// points stay those of include/kfx/kalman_filter.hpp.
#include <Eigen/Dense>

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

}  // namespace kfx::detail
