// kfx._core: the Kalman filter as functions: predict/update on an Estimate, whole-sequence runs, the
// RTS smoother, the offline schedule and the Kalman filter as a LinearFilter (include/kfx/kalman_filter.hpp).
// The FilterPy-style class kfx.KalmanFilter is in bind_filterpy_kalman_filter.cpp.
#include <optional>
#include <string>

#include "bindings.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/linear_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/validation.hpp"
#include "long_call.hpp"

namespace kfx::python {
namespace {

CovarianceUpdateForm ParseUpdateForm(const std::string& s) { return ParseEnum<CovarianceUpdateForm>("update_form", s); }

// The results that hold a matrix per step keep them as numpy arrays built once (TakeStack): a property
// returns the same read-only array on every access, with no copy.
struct PyFilterRun : FilterRun {
  py::object P_filt_stack = py::none(), P_pred_stack = py::none();  // (T+1, n, n), or None: not stored
};
struct PySmootherRun : SmootherRun {
  py::object P_stack = py::none();
};
struct PyKalmanSchedule {
  py::object filter_gain, P_pred, P_filt;
};

// run_filter's store_covariances: 'diag' (default) or 'full'; True / False as before ('full' / 'diag').
bool StoreFullCovariances(const py::object& store) {
  if (py::isinstance<py::bool_>(store)) return store.cast<bool>();
  if (py::isinstance<py::str>(store)) {
    const std::string s = store.cast<std::string>();
    if (s == "full") return true;
    if (s == "diag") return false;
    throw Error("store_covariances: expected 'diag' or 'full', got '" + s + "'");
  }
  throw Error("store_covariances: expected 'diag' or 'full', got " + py::str(py::type::of(store)).cast<std::string>());
}

py::object StoredOrRaise(const py::object& stack, const char* name) {
  if (stack.is_none()) {
    throw Error(std::string(name) + ": not stored (only the diagonals are, " + name +
                "_diag); run kfx.run_filter(..., store_covariances='full') to keep every covariance");
  }
  return stack;
}

SmootherRun SmoothStored(const Model& model, const PyFilterRun& stored, const py::object& progress) {
  if (stored.P_filt_stack.is_none() || stored.P_pred_stack.is_none()) {
    throw Error("run: expected stored covariances: kfx.run_filter(..., store_covariances='full')");
  }
  FilterRun run = stored;  // the means and diagonals; the covariances from the stored stacks
  run.P_filt = Unstack(stored.P_filt_stack, "run.P_filt");
  run.P_pred = Unstack(stored.P_pred_stack, "run.P_pred");
  LongCall call(progress);
  SmootherOptions o;
  o.progress = call.callback();
  return call.Run([&] {
    SmootherRun sm = RtsSmooth(model, run, o);
    run = FilterRun();  // freed before the smoothed covariances are stacked
    return sm;
  });
}

void BindSmootherAndSchedule(py::module_& m);

}  // namespace

void BindKalmanFilter(py::module_& m) {
  py::class_<Estimate>(m, "Estimate", "A Gaussian estimate (x, P).")
      .def(py::init([](Eigen::VectorXd x, Eigen::MatrixXd P) {
             // As a Model checks its prior (docs/robustness.md, class 10).
             RequireVector("x", x, -1);
             RequireShape("P", P, x.size(), x.size());
             RequirePositiveSemidefinite("P", P);
             return Estimate{std::move(x), std::move(P)};
           }),
           py::arg("x"), py::arg("P"), "Validated: x finite, P symmetric positive semidefinite (raises kfx.Error).")
      .def_readonly("x", &Estimate::x)
      .def_readonly("P", &Estimate::P);
  py::class_<UpdateResult>(m, "UpdateResult")
      .def_readonly("estimate", &UpdateResult::estimate)
      .def_readonly("innovation", &UpdateResult::innovation, "nu_k over the observed entries")
      .def_readonly("innovation_cov", &UpdateResult::innovation_cov, "S_k over the observed entries")
      .def_readonly("gain", &UpdateResult::gain, "n x num_observed filter gain K_k")
      .def_readonly("observed", &UpdateResult::observed)
      .def_readonly("log_likelihood", &UpdateResult::log_likelihood);
  m.def(
      "predict",
      [](const Estimate& e, const ModelStep& s, const std::string& form, std::optional<Eigen::VectorXd> input) {
        KalmanFilterOptions o;
        o.update_form = ParseUpdateForm(form);
        return Predict(e, s, input ? *input : Eigen::VectorXd(), o);
      },
      py::arg("estimate"), py::arg("step"), py::arg("update_form") = "joseph", py::arg("input") = py::none(),
      "Time update x_{k|k-1} = A x + G g, P_{k|k-1} = A P A^T + Q; input: the step's known input g_k (q,), "
      "required when the step has G or D. Raises kfx.Error naming the estimate or step on a bad shape, and "
      "naming g when input is missing for a step with G or D, given for a step without, or not of length q.");
  m.def(
      "update",
      [](const Estimate& e, const ModelStep& s, const Eigen::VectorXd& y, const std::string& form,
         std::optional<Eigen::VectorXd> input) {
        KalmanFilterOptions o;
        o.update_form = ParseUpdateForm(form);
        return Update(e, s, y, input ? *input : Eigen::VectorXd(), o);
      },
      py::arg("prior"), py::arg("step"), py::arg("y"), py::arg("update_form") = "joseph", py::arg("input") = py::none(),
      "Measurement update with y (NaN entries are missing), Joseph form by default; input: the step's known "
      "input g_k (D g_k is taken off y). A step with S gets run_filter's correlated update, K = (P C^T + S) "
      "(C P C^T + C S + S^T C^T + R)^-1, for a prior that is the prediction of the same step. Raises kfx.Error "
      "as predict, or for y of the wrong length; kfx.NumericalError if the innovation covariance is not "
      "positive definite.");

  py::class_<FilterHealth>(m, "FilterHealth", "Health of a filter run (docs/robustness.md, 'Health checks').")
      .def_readonly("monitored", &FilterHealth::monitored)
      .def_readonly("steps", &FilterHealth::steps)
      .def_readonly("max_asymmetry", &FilterHealth::max_asymmetry)
      .def_readonly("min_eigenvalue", &FilterHealth::min_eigenvalue)
      .def_readonly("min_eigenvalue_step", &FilterHealth::min_eigenvalue_step)
      .def_readonly("cholesky_failures", &FilterHealth::cholesky_failures)
      .def_readonly("first_cholesky_failure", &FilterHealth::first_cholesky_failure)
      .def_readonly("nis_mean", &FilterHealth::nis_mean)
      .def_readonly("nis_dof", &FilterHealth::nis_dof)
      .def_readonly("nis_lower", &FilterHealth::nis_lower)
      .def_readonly("nis_upper", &FilterHealth::nis_upper)
      .def_readonly("nis_consistent", &FilterHealth::nis_consistent)
      .def_property_readonly("healthy", &FilterHealth::healthy);
  py::class_<PyFilterRun>(m, "FilterRun",
                          "A whole-sequence filter run (kfx.run_filter). Every array is a read-only view, the same "
                          "object on every access.")
      .def_readonly("x_filt", &FilterRun::x_filt, "(T+1, n): row k = x_{k|k}; row 0 = m0")
      .def_readonly("x_pred", &FilterRun::x_pred, "(T+1, n): row k = x_{k|k-1}; row 0 = m0")
      .def_readonly("P_filt_diag", &FilterRun::P_filt_diag, "(T+1, n): diagonals of P_{k|k}; row 0 = diag P0")
      .def_readonly("P_pred_diag", &FilterRun::P_pred_diag, "(T+1, n): diagonals of P_{k|k-1}; row 0 = diag P0")
      .def_property_readonly(
          "P_filt", [](const PyFilterRun& r) { return StoredOrRaise(r.P_filt_stack, "P_filt"); },
          "(T+1, n, n): P_{k|k}, with store_covariances='full' (else raises kfx.Error)")
      .def_property_readonly(
          "P_pred", [](const PyFilterRun& r) { return StoredOrRaise(r.P_pred_stack, "P_pred"); },
          "(T+1, n, n): P_{k|k-1}, [0] = P0, with store_covariances='full' (else raises kfx.Error)")
      .def_property_readonly(
          "covariances_stored", [](const PyFilterRun& r) { return !r.P_filt_stack.is_none(); },
          "True when run with store_covariances='full'")
      .def_readonly("innovations", &FilterRun::innovations, "(T, m), NaN where missing")
      .def_readonly("log_likelihood_terms", &FilterRun::log_likelihood_terms)
      .def_readonly("log_likelihood", &FilterRun::log_likelihood)
      .def_readonly("num_observed", &FilterRun::num_observed)
      .def_readonly("health", &FilterRun::health, "FilterHealth (monitor_health)")
      .def_readonly("health_warning", &FilterRun::health_warning,
                    "the warning issued for this run ('' when healthy or not monitored)");
  m.def(
      "run_filter",
      [](const Model& model, const TimeSeries& y, const py::object& store_covariances, const std::string& form,
         const std::string& filter_form, bool monitor_health, const py::object& progress,
         std::optional<TimeSeries> input) {
        FilterRunOptions o;
        o.store_covariances = StoreFullCovariances(store_covariances);
        o.filter.update_form = ParseUpdateForm(form);
        o.filter.form = ParseEnum<FilterForm>("form", filter_form);
        // The cheap health checks by default (docs/robustness.md, class 8), with a RuntimeWarning.
        o.monitor_health = monitor_health;
        o.monitor_eigenvalues = false;
        LongCall call(progress);
        o.progress = call.callback();
        const TimeSeries g = input ? std::move(*input) : TimeSeries(0, 0);
        PyFilterRun run;
        static_cast<FilterRun&>(run) = call.Run([&] { return RunFilter(model, y, g, o); });
        if (o.store_covariances) {
          run.P_filt_stack = TakeStack(&run.P_filt);
          run.P_pred_stack = TakeStack(&run.P_pred);
        }
        if (!run.health_warning.empty() &&
            PyErr_WarnEx(PyExc_RuntimeWarning, ("kfx.run_filter: " + run.health_warning).c_str(), 1) != 0) {
          throw py::error_already_set();
        }
        return run;
      },
      py::arg("model"), py::arg("y"), py::arg("store_covariances") = "diag", py::arg("update_form") = "joseph",
      py::arg("form") = "conventional", py::arg("monitor_health") = true, py::arg("progress") = py::none(),
      py::arg("input") = py::none(),
      (std::string("Runs the Kalman filter over y (T, m) (NaN = missing): predict then update for each row, "
                   "starting from the prior (m0, P0) at k = 0. store_covariances: 'diag' (default: the diagonals "
                   "P_filt_diag, P_pred_diag, (T+1) n numbers) or 'full' (also every P_{k|k}, P_{k|k-1} as "
                   "P_filt, P_pred: 2 (T+1) n^2 numbers; rts_smooth needs them). form: 'conventional', 'sqrt', "
                   "'ud' or 'information'. input: the known input g (T, q), row k-1 = g_k, required for a model "
                   "with G or D (a model with S is filtered by the correlated update). With monitor_health "
                   "(default) the cheap health checks run (Cholesky of each P_{k|k}, the NIS): the result's "
                   ".health, and a RuntimeWarning naming the form to use when the covariances went wrong.") +
       kProgressDoc)
          .c_str());
  BindSmootherAndSchedule(m);
}

namespace {

// The smoother, the offline schedule and the filters as LinearFilters for the engine.
void BindSmootherAndSchedule(py::module_& m) {
  py::class_<PySmootherRun>(m, "SmootherRun")
      .def_readonly("x", &SmootherRun::x, "(T+1, n): row k = x_{k|T}")
      .def_readonly("P_diag", &SmootherRun::P_diag, "(T+1, n): diagonals of P_{k|T}")
      .def_readonly("P", &PySmootherRun::P_stack, "(T+1, n, n): P_{k|T} (read-only, built once)");
  m.def(
      "rts_smooth",
      [](const Model& model, const PyFilterRun& run, const py::object& progress) {
        PySmootherRun sm;
        static_cast<SmootherRun&>(sm) = SmoothStored(model, run, progress);
        sm.P_stack = TakeStack(&sm.P);
        return sm;
      },
      py::arg("model"), py::arg("run"), py::arg("progress") = py::none(),
      (std::string("Rauch-Tung-Striebel smoother of a run_filter result (needs store_covariances='full'; "
                   "raises kfx.Error otherwise).") +
       kProgressDoc)
          .c_str());

  py::class_<PyKalmanSchedule>(m, "KalmanSchedule", "The offline part: gains and covariances, k = 1..T.")
      .def_readonly("filter_gain", &PyKalmanSchedule::filter_gain, "(T, n, m): K_1..K_T")
      .def_readonly("P_pred", &PyKalmanSchedule::P_pred, "(T+1, n, n), [0] = P0")
      .def_readonly("P_filt", &PyKalmanSchedule::P_filt, "(T+1, n, n), [0] = P0");
  m.def(
      "kalman_schedule",
      [](const Model& model, int steps, const py::object& progress) {
        LongCall call(progress);
        KalmanScheduleOptions o{steps};
        o.progress = call.callback();
        KalmanSchedule s = call.Run([&] { return ComputeKalmanSchedule(model, o); });
        PyKalmanSchedule out;
        out.filter_gain = TakeStack(&s.filter_gain, 1);
        out.P_pred = TakeStack(&s.P_pred);
        out.P_filt = TakeStack(&s.P_filt);
        return out;
      },
      py::arg("model"), py::arg("steps") = -1, py::arg("progress") = py::none(),
      (std::string("The Kalman filter's gain and covariance schedule over steps (default: the model's horizon).") +
       kProgressDoc)
          .c_str());
  m.def(
      "kalman_as_linear_filter",
      [](const Model& model, int steps) {
        py::gil_scoped_release release;
        return KalmanAsLinearFilter(model, ComputeKalmanSchedule(model, KalmanScheduleOptions{steps}));
      },
      py::arg("model"), py::arg("steps") = -1,
      "The Kalman filter of `model` as a LinearFilter: Phi_k = (I - K_k C_k) A_k, gain K_k, z_0 = m0. Raises "
      "kfx.Error if steps exceeds the model's horizon, or is negative for a model without one.");
  m.def("constant_gain_as_linear_filter", &ConstantGainAsLinearFilter, py::arg("design"), py::arg("filter_gain"),
        py::arg("z0"), "Phi = (I - K_f C) A, K = K_f, O = I (e.g. with the steady-state DareSolution.filter_gain).");
}

}  // namespace

}  // namespace kfx::python
