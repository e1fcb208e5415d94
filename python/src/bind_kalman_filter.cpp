// kfx._core: the Kalman filter as functions: predict/update on an Estimate, whole-sequence runs, the
// RTS smoother, the offline schedule and the Kalman filter as a LinearFilter (include/kfx/kalman_filter.hpp).
// The FilterPy-style class kfx.KalmanFilter is in bind_filterpy_kalman_filter.cpp.
#include <optional>
#include <string>

#include "bindings.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/linear_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/validation.hpp"

namespace kfx::python {
namespace {

CovarianceUpdateForm ParseUpdateForm(const std::string& s) { return ParseEnum<CovarianceUpdateForm>("update_form", s); }

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
      [](const Estimate& e, const ModelStep& s, const std::string& form) {
        KalmanFilterOptions o;
        o.update_form = ParseUpdateForm(form);
        return Predict(e, s, o);
      },
      py::arg("estimate"), py::arg("step"), py::arg("update_form") = "joseph",
      "Time update x_{k|k-1} = A x, P_{k|k-1} = A P A^T + Q.");
  m.def(
      "update",
      [](const Estimate& e, const ModelStep& s, const Eigen::VectorXd& y, const std::string& form) {
        KalmanFilterOptions o;
        o.update_form = ParseUpdateForm(form);
        return Update(e, s, y, o);
      },
      py::arg("prior"), py::arg("step"), py::arg("y"), py::arg("update_form") = "joseph",
      "Measurement update with y (NaN entries are missing); Joseph form by default.");

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
  py::class_<FilterRun>(m, "FilterRun", "A whole-sequence filter run (kfx.run_filter).")
      .def_readonly("x_filt", &FilterRun::x_filt, "(T+1, n): row k = x_{k|k}; row 0 = m0")
      .def_readonly("x_pred", &FilterRun::x_pred, "(T+1, n): row k = x_{k|k-1}; row 0 = m0")
      .def_readonly("P_filt_diag", &FilterRun::P_filt_diag)
      .def_readonly("P_pred_diag", &FilterRun::P_pred_diag)
      .def_property_readonly(
          "P_filt", [](const FilterRun& r) { return Stack(r.P_filt); }, "(T+1, n, n) if stored")
      .def_property_readonly(
          "P_pred", [](const FilterRun& r) { return Stack(r.P_pred); }, "(T+1, n, n) if stored; [0] = P0")
      .def_readonly("innovations", &FilterRun::innovations, "(T, m), NaN where missing")
      .def_readonly("log_likelihood_terms", &FilterRun::log_likelihood_terms)
      .def_readonly("log_likelihood", &FilterRun::log_likelihood)
      .def_readonly("num_observed", &FilterRun::num_observed)
      .def_readonly("health", &FilterRun::health, "FilterHealth (monitor_health)")
      .def_readonly("health_warning", &FilterRun::health_warning,
                    "the warning issued for this run ('' when healthy or not monitored)");
  m.def(
      "run_filter",
      [](const Model& model, const TimeSeries& y, bool store_covariances, const std::string& form,
         const std::string& filter_form, bool monitor_health, std::optional<TimeSeries> input) {
        FilterRunOptions o;
        o.store_covariances = store_covariances;
        o.filter.update_form = ParseUpdateForm(form);
        o.filter.form = ParseEnum<FilterForm>("form", filter_form);
        // The cheap health checks by default (docs/robustness.md, class 8), with a RuntimeWarning.
        o.monitor_health = monitor_health;
        o.monitor_eigenvalues = false;
        FilterRun run = RunFilter(model, y, input ? *input : TimeSeries(0, 0), o);
        if (!run.health_warning.empty() &&
            PyErr_WarnEx(PyExc_RuntimeWarning, ("kfx.run_filter: " + run.health_warning).c_str(), 1) != 0) {
          throw py::error_already_set();
        }
        return run;
      },
      py::arg("model"), py::arg("y"), py::arg("store_covariances") = true, py::arg("update_form") = "joseph",
      py::arg("form") = "conventional", py::arg("monitor_health") = true, py::arg("input") = py::none(),
      "Runs the Kalman filter over y (T, m) (NaN = missing): predict then update for each row, starting "
      "from the prior (m0, P0) at k = 0. input: the known input g (T, q), row k-1 = g_k, for a model with G, D "
      "(a model with S is filtered by the correlated update). form: 'conventional', 'sqrt', 'ud' or 'information'. With "
      "monitor_health (default) the cheap health checks run (Cholesky of each P_{k|k}, the NIS): the result's "
      ".health, and a RuntimeWarning naming the form to use when the covariances went wrong.");
  py::class_<SmootherRun>(m, "SmootherRun")
      .def_readonly("x", &SmootherRun::x, "(T+1, n): row k = x_{k|T}")
      .def_readonly("P_diag", &SmootherRun::P_diag)
      .def_property_readonly(
          "P", [](const SmootherRun& r) { return Stack(r.P); }, "(T+1, n, n)");
  m.def("rts_smooth", &RtsSmooth, py::arg("model"), py::arg("run"),
        "Rauch-Tung-Striebel smoother of a run_filter result (needs store_covariances=True).");

  py::class_<KalmanSchedule>(m, "KalmanSchedule", "The offline part: gains and covariances, k = 1..T.")
      .def_property_readonly(
          "filter_gain", [](const KalmanSchedule& s) { return Stack(s.filter_gain, 1); }, "(T, n, m): K_1..K_T")
      .def_property_readonly(
          "P_pred", [](const KalmanSchedule& s) { return Stack(s.P_pred); }, "(T+1, n, n), [0] = P0")
      .def_property_readonly(
          "P_filt", [](const KalmanSchedule& s) { return Stack(s.P_filt); }, "(T+1, n, n), [0] = P0");
  m.def(
      "kalman_schedule",
      [](const Model& model, int steps) { return ComputeKalmanSchedule(model, KalmanScheduleOptions{steps}); },
      py::arg("model"), py::arg("steps") = -1);
  m.def(
      "kalman_as_linear_filter",
      [](const Model& model, int steps) {
        return KalmanAsLinearFilter(model, ComputeKalmanSchedule(model, KalmanScheduleOptions{steps}));
      },
      py::arg("model"), py::arg("steps") = -1,
      "The Kalman filter of `model` as a LinearFilter: Phi_k = (I - K_k C_k) A_k, gain K_k, z_0 = m0.");
  m.def("constant_gain_as_linear_filter", &ConstantGainAsLinearFilter, py::arg("design"), py::arg("filter_gain"),
        py::arg("z0"), "Phi = (I - K_f C) A, K = K_f, O = I (e.g. with the steady-state DareSolution.filter_gain).");
}

}  // namespace kfx::python
