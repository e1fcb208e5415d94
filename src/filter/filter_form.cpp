// The one run loop (RunFilter) and the one schedule loop (ComputeKalmanSchedule) of the Kalman
// filter, written over the steps of a form, and KalmanFormFor, the factory that chooses the form.
//
// A form (conventional_form.hpp, factored_forms.hpp) holds x and the covariance of the current step:
//   Form(options, n), Start(x, P), SetStep(step) (whenever the step's matrices change),
//   Predict(), ShiftMean(v), Update(y) (false when no entry of y is observed), then x(), P() (of type Matrix),
//   innovation(), innovation_cov(), gain(), observed(), log_likelihood() of the last update, and
//   context(), the prefix of a step's NumericalError messages. A form with kSteadyState also has
//   Freeze() and FrozenStep(y, shift) with frozen_prediction(), frozen_innovation(), frozen_log_likelihood()
//   for RunFilter's steady-state fast path.
#include "filter/filter_form.hpp"

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "base/stagnation.hpp"
#include "filter/conventional_form.hpp"
#include "filter/factored_forms.hpp"
#include "filter/filter_health_internal.hpp"
#include "kfx/error.hpp"

namespace kfx::detail {

namespace {

[[noreturn]] void ThrowAtStep(int k, const std::string& context, const NumericalError& err) {
  throw NumericalError("step " + std::to_string(k) + ": " + context + err.what());
}

// A run over steps 1..T with row 0 (the prior) filled in.
FilterRun StartRun(const Model& model, int T, bool store_covariances) {
  const Eigen::Index n = model.state_dim(), m = model.meas_dim();
  FilterRun run;
  run.x_filt.resize(T + 1, n);
  run.x_pred.resize(T + 1, n);
  run.P_filt_diag.resize(T + 1, n);
  run.P_pred_diag.resize(T + 1, n);
  run.innovations = TimeSeries::Constant(T, m, std::numeric_limits<double>::quiet_NaN());
  run.log_likelihood_terms = Eigen::VectorXd::Zero(T);
  run.num_observed.assign(static_cast<size_t>(T), 0);
  run.x_filt.row(0) = model.m0().transpose();
  run.x_pred.row(0) = model.m0().transpose();
  run.P_filt_diag.row(0) = model.P0().diagonal().transpose();
  run.P_pred_diag.row(0) = model.P0().diagonal().transpose();
  if (store_covariances) {
    run.P_filt.reserve(static_cast<size_t>(T) + 1);
    run.P_pred.reserve(static_cast<size_t>(T) + 1);
    run.P_filt.push_back(model.P0());
    run.P_pred.push_back(model.P0());
  }
  return run;
}

// The filter over a whole sequence: the form works in place, so x and its covariance (and, with the
// steady-state fast path, P_{k-1|k-1} for the convergence test) are all the storage a step needs
// besides the outputs.
// A known input (issue 22) enters here, the same for every form: G_k g_k is added to x_{k|k-1} after the
// form's Predict and D_k g_k is taken off y_k before its Update (a NaN entry stays missing).
template <typename Form>
FilterRun RunLoop(const Model& model, const TimeSeries& y, const TimeSeries& g, const FilterRunOptions& options,
                  int T) {
  const Eigen::Index m = model.meas_dim();
  FilterRun run = StartRun(model, T, options.store_covariances);
  HealthMonitor monitor(options.monitor_health, options.monitor_eigenvalues);
  Form form(options.filter, model.state_dim());
  form.Start(model.m0(), model.P0());
  const auto& x = form.x();
  const auto& P = form.P();
  StepPtr current;  // keeps the step that the form refers to alive
  // Steady-state fast path (FilterRunOptions::steady_state_tolerance): the form freezes its gain and
  // S_k factor; P keeps the frozen P_{k|k} so that a missing measurement can resume the full
  // recursion from it.
  const double tol = options.steady_state_tolerance;
  const bool fast = Form::kSteadyState && tol > 0.0 && model.time_invariant();
  bool frozen = false;
  SteadyStateSwitch steady(tol);  // the same switch as RunCoupledFilter's (base/stagnation.hpp)
  typename Form::Matrix P_prev, P_pred_ss;
  Eigen::VectorXd yk(m);
  for (int k = 1; k <= T; ++k) {
    StepPtr s = model.step(k);
    if (s.get() != current.get()) {
      form.SetStep(*s);
      current = std::move(s);
    }
    const KnownInputTerms input = KnownInputAt(*current, g, k);
    yk = y.row(k - 1).transpose();  // into storage allocated once
    if (input.measurement.size() > 0) yk -= input.measurement;
    if constexpr (Form::kSteadyState) {
      if (frozen && yk.allFinite()) {
        form.FrozenStep(yk, input.state);
        run.x_pred.row(k) = form.frozen_prediction().transpose();
        run.P_pred_diag.row(k) = run.P_pred_diag.row(k - 1);
        run.innovations.row(k - 1) = form.frozen_innovation().transpose();
        run.num_observed[static_cast<size_t>(k - 1)] = static_cast<int>(m);
        run.log_likelihood_terms(k - 1) = form.frozen_log_likelihood();
        run.x_filt.row(k) = x.transpose();
        run.P_filt_diag.row(k) = run.P_filt_diag.row(k - 1);
        if (options.store_covariances) {
          run.P_pred.emplace_back(P_pred_ss);
          run.P_filt.emplace_back(P);
        }
        ++run.steady_state_steps;
        if (options.progress) options.progress(k, T);
        continue;
      }
      frozen = false;
      if (fast) P_prev = P;
    }
    try {
      form.Predict();
    } catch (const NumericalError& err) {
      ThrowAtStep(k, form.context(), err);
    }
    if (input.state.size() > 0) form.ShiftMean(input.state);
    run.x_pred.row(k) = x.transpose();
    run.P_pred_diag.row(k) = P.diagonal().transpose();
    if (options.store_covariances) run.P_pred.emplace_back(P);
    if (fast && options.store_covariances) P_pred_ss = P;  // only the stored frozen P_{k|k-1} needs it
    try {
      form.Update(yk);
    } catch (const Error& err) {
      std::string what = err.what();
      if (what.rfind("y: ", 0) == 0) what = what.substr(3);
      throw Error("y (row " + std::to_string(k - 1) + "): " + what);
    } catch (const NumericalError& err) {
      ThrowAtStep(k, form.context(), err);
    }
    const std::vector<Eigen::Index>& observed = form.observed();
    const Eigen::Index mo = static_cast<Eigen::Index>(observed.size());
    for (Eigen::Index i = 0; i < mo; ++i) run.innovations(k - 1, observed[i]) = form.innovation()(i);
    run.num_observed[static_cast<size_t>(k - 1)] = static_cast<int>(mo);
    run.log_likelihood_terms(k - 1) = form.log_likelihood();
    if (!(x.allFinite() && P.allFinite() && std::isfinite(form.log_likelihood()))) {
      RequireFiniteStep(k, x, P, form.log_likelihood());  // throws, naming what is not finite
    }
    if (options.monitor_health) monitor.Observe(k, P, form.innovation(), form.innovation_cov());
    if constexpr (Form::kSteadyState) {
      if (fast && mo != m) steady.Reset();
      if (fast && mo == m && steady.Observe((P - P_prev).norm(), P.norm())) {
        frozen = true;
        steady.Reset();
        form.Freeze();
      }
    }
    run.x_filt.row(k) = x.transpose();
    run.P_filt_diag.row(k) = P.diagonal().transpose();
    if (options.store_covariances) run.P_filt.emplace_back(P);
    if (options.progress) options.progress(k, T);
  }
  run.log_likelihood = run.log_likelihood_terms.sum();
  run.health = monitor.Finish();
  run.health_warning = HealthWarning(run.health, options.filter);
  return run;
}

// The covariance recursion of RunFilter with all measurements present, and a zero measurement for
// the mean.
template <typename Form>
KalmanSchedule ScheduleLoop(const Model& model, const KalmanScheduleOptions& options, int T) {
  const Eigen::Index n = model.state_dim(), m = model.meas_dim();
  KalmanSchedule sch;
  sch.filter_gain.resize(static_cast<size_t>(T) + 1);
  sch.P_pred.reserve(static_cast<size_t>(T) + 1);
  sch.P_filt.reserve(static_cast<size_t>(T) + 1);
  sch.P_pred.push_back(model.P0());
  sch.P_filt.push_back(model.P0());
  const Eigen::VectorXd x0 = Eigen::VectorXd::Zero(n);
  const Eigen::VectorXd y0 = Eigen::VectorXd::Zero(m);
  Form form(options.filter, n);
  form.Start(x0, model.P0());
  StepPtr current;  // keeps the step that the form refers to alive
  for (int k = 1; k <= T; ++k) {
    StepPtr s = model.step(k);
    if (s.get() != current.get()) {
      form.SetStep(*s);
      current = std::move(s);
    }
    Eigen::MatrixXd& gain = sch.filter_gain[static_cast<size_t>(k)];
    try {
      form.Predict();
      sch.P_pred.emplace_back(form.P());
      form.Update(y0);
      sch.P_filt.emplace_back(form.P());
      gain = form.gain();
    } catch (const NumericalError& err) {
      ThrowAtStep(k, form.context(), err);
    }
    const Eigen::MatrixXd& P = sch.P_filt.back();
    if (!(P.allFinite() && gain.allFinite())) {
      RequireFiniteStep(k, x0, P, 0.0);  // throws if P is not finite
      throw NumericalError("step " + std::to_string(k) + ": filter gain not finite");
    }
    if (options.progress) options.progress(k, T);
  }
  return sch;
}

template <typename Form>
class FormEntryPoints final : public KalmanForm {
 public:
  Estimate Predict(const Estimate& e, const ModelStep& s, const KalmanFilterOptions& options) const override {
    Form form(options, e.x.size());
    form.Start(e.x, e.P);
    form.SetStep(s);
    form.Predict();
    return Estimate{form.x(), form.P()};
  }

  UpdateResult Update(const Estimate& prior, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& y,
                      const KalmanFilterOptions& options) const override {
    Form form(options, prior.x.size());
    form.Start(prior.x, prior.P);
    form.SetStep(s);
    UpdateResult r;
    if (!form.Update(y)) {
      r.estimate = prior;
      r.gain.resize(prior.x.size(), 0);
      return r;
    }
    r.estimate.x = form.x();
    r.estimate.P = form.P();
    r.innovation = form.innovation();
    r.innovation_cov = form.innovation_cov();
    r.gain = form.gain();
    r.observed = form.observed();
    r.log_likelihood = form.log_likelihood();
    return r;
  }

  FilterRun Run(const Model& model, const TimeSeries& y, const TimeSeries& g, const FilterRunOptions& options,
                int T) const override {
    return RunLoop<Form>(model, y, g, options, T);
  }

  KalmanSchedule Schedule(const Model& model, const KalmanScheduleOptions& options, int T) const override {
    return ScheduleLoop<Form>(model, options, T);
  }
};

}  // namespace

const KalmanForm& KalmanFormFor(const KalmanFilterOptions& options, Eigen::Index n, Eigen::Index m,
                                FormStorage storage) {
  using conventional::ConventionalForm;
  static const FormEntryPoints<ConventionalForm<conventional::SmallMat, conventional::SmallVec>> small;
  static const FormEntryPoints<ConventionalForm<Eigen::MatrixXd, Eigen::VectorXd>> dynamic;
  static const FormEntryPoints<FactoredForm> factored;
  if (options.form != FilterForm::kConventional) return factored;
  if (storage == FormStorage::kSizeTuned && conventional::IsSmall(n, m)) return small;
  return dynamic;
}

}  // namespace kfx::detail
