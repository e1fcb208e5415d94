// kfx._core._KalmanFilter: the compiled part of kfx.KalmanFilter, the drop-in for
// filterpy.kalman.KalmanFilter 1.4.5 (filterpy_kalman_filter.hpp; the Python subclass
// python/kfx/_filterpy.py adds __repr__, test_matrix_dimensions, measurement_of_state, pickling).
#include <string>

#include "bindings.hpp"
#include "filterpy_kalman_filter.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"

namespace kfx::python {

void BindFilterPyKalmanFilter(py::module_& m) {
  using KF = FilterPyKalmanFilter;
  py::class_<KF> cls(m, "_KalmanFilter",
                     "The compiled core of kfx.KalmanFilter (use kfx.KalmanFilter, which adds __repr__, "
                     "test_matrix_dimensions and pickling).");
  cls.def(py::init<Eigen::Index, Eigen::Index, Eigen::Index>(), py::arg("dim_x"), py::arg("dim_z"),
          py::arg("dim_u") = 0,
          "FilterPy's KalmanFilter(dim_x, dim_z, dim_u=0): x = 0 (dim_x, 1), P = Q = F = I, H = 0, R = I, B = None, "
          "M = 0, alpha = 1.")
      .def(py::init<const Model&>(), py::arg("model"),
           "From a time-invariant kfx.Model: F = A, H = C, Q, R, x = m0 as a column, P = P0.")
      .def_property_readonly("dim_x", &KF::n)
      .def_property_readonly("dim_z", &KF::m)
      .def_property_readonly("dim_u", &KF::dim_u);
  static const char* const kDocs[KF::kNumAttrs] = {
      "state estimate: (dim_x, 1), or (dim_x,) when a 1-D array was assigned",
      "state covariance (dim_x, dim_x); a number p means p I",
      "state transition (dim_x, dim_x)",
      "measurement matrix (dim_z, dim_x)",
      "process noise covariance (dim_x, dim_x); a number q means q everywhere (q 1 1^T), as in FilterPy",
      "measurement noise covariance (dim_z, dim_z); a number r means r 1 1^T, as in FilterPy",
      "control transition (dim_x, dim_u) or None",
      "process-measurement cross-covariance (dim_x, dim_z), used by update_correlated",
      "x after the last predict",
      "P after the last predict",
      "x after the last update",
      "P after the last update",
      "gain of the last update (dim_x, dim_z)",
      "residual z - H x of the last update",
      "innovation covariance H P H^T + R of the last update",
      "the last measurement (None before any)"};
  for (int a = 0; a < KF::kNumAttrs; ++a) {
    cls.def_property(
        KF::Name(a), [a](KF& f) { return f.Get(a); }, [a](KF& f, py::handle v) { f.Set(a, v); }, kDocs[a]);
  }
  cls.def(
      "_restore",
      [](KF& f, const std::string& name, py::handle v) {
        for (int a = 0; a < KF::kNumAttrs; ++a)
          if (name == KF::Name(a)) return f.Set(a, v, false);
        if (name != "SI") throw Error("_restore: no attribute " + name);
        f.SetSI(v);
      },
      "Sets an attribute as a copy or unpickling restores it (shape checked, no numerical checks).");
  cls.def_property("SI", &KF::GetSI, &KF::SetSI, "inverse of S (computed on first read after an update)")
      .def_property("alpha", &KF::alpha, &KF::set_alpha, "fading-memory factor >= 1: P = alpha^2 F P F^T + Q")
      .def_property_readonly("log_likelihood", &KF::LogLikelihood,
                             "log N(y; 0, S) of the last update (over its observed entries; -inf if S is not PD)")
      .def_property_readonly("likelihood", &KF::Likelihood, "exp(log_likelihood), at least the smallest float")
      .def_property_readonly("mahalanobis", &KF::Mahalanobis, "sqrt(y^T SI y) of the last update")
      .def("_set_likelihoods", &KF::SetLikelihoods)
      .def_property(
          "update_form", [](const KF& f) { return std::string(f.joseph() ? "joseph" : "standard"); },
          [](KF& f, const std::string& s) {
            f.set_joseph(ParseEnum<CovarianceUpdateForm>("update_form", s) == CovarianceUpdateForm::kJoseph);
          },
          "'joseph' (default, as FilterPy's update) or 'standard' (P - K H P)")
      .def(
          "predict", [](KF& f, py::handle u, py::handle B, py::handle F, py::handle Q) { f.Predict(u, B, F, Q); },
          py::arg("u") = py::none(), py::arg("B") = py::none(), py::arg("F") = py::none(), py::arg("Q") = py::none(),
          "x = F x + B u, P = alpha^2 F P F^T + Q (Q given as a number: q I); sets x_prior, P_prior.")
      .def(
          "update", [](KF& f, py::handle z, py::handle R, py::handle H) { f.Update(z, R, H, false); }, py::arg("z"),
          py::arg("R") = py::none(), py::arg("H") = py::none(),
          "Joseph-form update with z (a number, (dim_z,), (dim_z, 1) or (1, dim_z)); None: no update; NaN "
          "entries are missing. Sets y, S, K, z, x_post, P_post. Raises kfx.NumericalError if S is not "
          "positive definite.")
      .def(
          "update_correlated", [](KF& f, py::handle z, py::handle R, py::handle H) { f.Update(z, R, H, true); },
          py::arg("z"), py::arg("R") = py::none(), py::arg("H") = py::none(),
          "Update when the measurement noise is correlated with the prior error (cross-covariance M): "
          "S = H P H^T + H M + M^T H^T + R, K = (P H^T + M) S^-1.")
      .def("update_steadystate", &KF::UpdateSteadyState, py::arg("z"), "x = x + K (z - H x) with the stored K; P kept.")
      .def("predict_steadystate", &KF::PredictSteadyState, py::arg("u") = 0, py::arg("B") = py::none(),
           "x = F x + B u; P kept.")
      .def("update_sequential", &KF::UpdateSequential, py::arg("start"), py::arg("z_i"), py::arg("R_i") = py::none(),
           py::arg("H_i") = py::none(),
           "Update with rows start .. start + len(z_i) of the measurement only (R_i, H_i default to those rows of "
           "R, H); fills those rows of y, K, z.")
      .def("batch_filter", &KF::BatchFilter, py::arg("zs"), py::arg("Fs") = py::none(), py::arg("Qs") = py::none(),
           py::arg("Hs") = py::none(), py::arg("Rs") = py::none(), py::arg("Bs") = py::none(),
           py::arg("us") = py::none(), py::arg("update_first") = false, py::arg("saver") = py::none(),
           "Filters every zs[i] in one call (predict then update, or update then predict with update_first): "
           "returns (means, covariances, means_p, covariances_p), means (T, dim_x, 1) for a column x, (T, dim_x) "
           "for a 1-D x; the filter ends in the last state. Per-step Fs, Qs, Hs, Rs, Bs, us; saver.save() after "
           "each step. Without a saver the loop runs in C++ with the GIL released.")
      .def("rts_smoother", &KF::RtsSmoother, py::arg("Xs"), py::arg("Ps"), py::arg("Fs") = py::none(),
           py::arg("Qs") = py::none(),
           "Rauch-Tung-Striebel smoother over filtered means Xs and covariances Ps (Fs[k+1], Qs[k+1] take step k "
           "to k+1): returns (x, P, K, Pp) as FilterPy: K the smoother gains (zero last), Pp the predicted "
           "covariances with Pp[-1] = Ps[-1].")
      .def("get_prediction", &KF::GetPrediction, py::arg("u") = py::none(), py::arg("B") = py::none(),
           py::arg("F") = py::none(), py::arg("Q") = py::none(),
           "(x, P) predict() would give; the filter is unchanged.")
      .def("get_update", &KF::GetUpdate, py::arg("z") = py::none(),
           "(x, P) update(z) would give; the filter is unchanged (z None: the current x, P).")
      .def("residual_of", &KF::ResidualOf, py::arg("z"), "z - H x_prior.")
      .def("to_model", &KF::AsModel, "The time-invariant kfx.Model (F, H, Q, R, x, P); B and M are not part of it.");
}

}  // namespace kfx::python
