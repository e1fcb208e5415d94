#pragma once
// Private: the form of the Kalman filter behind the public entry points of kalman_filter.cpp
// (FilterForm, and for the conventional form its CovarianceUpdateForm), chosen once per call by
// KalmanFormFor. Its implementation (filter_form.cpp) holds the one run loop and the one schedule
// loop, written over the steps of a form.
#include <Eigen/Dense>

#include "kfx/kalman_filter.hpp"

namespace kfx::detail {

/// The entry points of one form, on arguments that the public functions have checked.
class KalmanForm {
 public:
  virtual Estimate Predict(const Estimate& e, const ModelStep& s, const KalmanFilterOptions& options) const = 0;
  virtual UpdateResult Update(const Estimate& prior, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& y,
                              const KalmanFilterOptions& options) const = 0;
  /// RunFilter over steps 1..T with the known input g (checked; 0 columns when the model has none).
  virtual FilterRun Run(const Model& model, const TimeSeries& y, const TimeSeries& g, const FilterRunOptions& options,
                        int T) const = 0;
  /// ComputeKalmanSchedule over steps 1..T.
  virtual KalmanSchedule Schedule(const Model& model, const KalmanScheduleOptions& options, int T) const = 0;

 protected:
  ~KalmanForm() = default;  // the forms are static objects, never deleted through this type
};

/// The storage of the conventional form: kSizeTuned takes matrices of compile-time maximum size and
/// loop kernels when n, m <= 8; kDynamic always Eigen::MatrixXd (ComputeKalmanSchedule, whose
/// covariances and gains are those of the dynamic kernels to the last bit).
enum class FormStorage { kSizeTuned, kDynamic };

/// The one factory: the form given by options.form for n states and m measurements (the conventional
/// form applies options.update_form and options.symmetrize at each step).
const KalmanForm& KalmanFormFor(const KalmanFilterOptions& options, Eigen::Index n, Eigen::Index m,
                                FormStorage storage = FormStorage::kSizeTuned);

}  // namespace kfx::detail
