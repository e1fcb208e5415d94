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
namespace {
using KF = FilterPyKalmanFilter;

// ---- predict and update as CPython vectorcall methods --------------------------------------------------
// A FilterPy loop calls predict() and update(z) once per step; at n = 4 pybind11's general dispatcher (an
// argument vector, default objects, a type look-up for self) cost as much as the step itself
// (docs/benchmarks.md, "Python overhead"). These two are METH_FASTCALL methods on the class instead: same
// names, arguments, checks and errors.

// The C++ object behind self (the method descriptor has checked that self is a _KalmanFilter).
KF& Self(PyObject* self) {
  // pybind11's one-C++-base layout: the pointer without a type look-up; else through pybind11's caster.
  const auto* inst = reinterpret_cast<const py::detail::instance*>(self);
  if (inst->simple_layout && inst->simple_holder_constructed) return *static_cast<KF*>(inst->simple_value_holder[0]);
  static const py::detail::type_info* const type = py::detail::get_type_info(typeid(KF));
  py::detail::type_caster_generic caster(type);
  if (!caster.load(self, false) || caster.value == nullptr) {
    throw py::type_error("self: expected a kfx.KalmanFilter");
  }
  return *static_cast<KF*>(caster.value);
}

// Binds positional and keyword arguments to `names` as Python would (None where not given).
// @throws TypeError as Python's for a missing, unknown, repeated or surplus argument.
template <int N>
void BindArguments(const char* fn, const char* const (&names)[N], int required, PyObject* const* args, Py_ssize_t nargs,
                   PyObject* kwnames, py::handle (&out)[N]) {
  const std::string f = std::string(fn) + "()";
  if (nargs > N) {
    throw py::type_error(f + " takes at most " + std::to_string(N) + " arguments (" + std::to_string(nargs) +
                         " given)");
  }
  for (int i = 0; i < N; ++i) out[i] = i < nargs ? py::handle(args[i]) : py::handle();
  const Py_ssize_t nkw = kwnames ? PyTuple_GET_SIZE(kwnames) : 0;
  for (Py_ssize_t k = 0; k < nkw; ++k) {
    PyObject* key = PyTuple_GET_ITEM(kwnames, k);
    int i = 0;
    while (i < N && PyUnicode_CompareWithASCIIString(key, names[i]) != 0) ++i;
    if (i == N)
      throw py::type_error(f + " got an unexpected keyword argument '" + py::str(key).cast<std::string>() + "'");
    if (out[i]) throw py::type_error(f + " got multiple values for argument '" + names[i] + "'");
    out[i] = args[nargs + k];
  }
  for (int i = 0; i < N; ++i) {
    if (out[i]) continue;
    if (i < required) throw py::type_error(f + " missing required argument '" + names[i] + "'");
    out[i] = Py_None;
  }
}

// The current C++ exception as a Python error, through pybind11's translators (kfx.Error, ...).
void RaiseInPython() {
  std::exception_ptr last = std::current_exception();
  try {
    std::rethrow_exception(last);
  } catch (py::error_already_set& e) {
    e.restore();
    return;
  } catch (...) {
  }
  for (auto& translate : py::detail::get_internals().registered_exception_translators) {
    try {
      translate(last);
      return;
    } catch (...) {
      last = std::current_exception();
    }
  }
  PyErr_SetString(PyExc_SystemError, "kfx: an exception escaped the exception translators");
}

PyObject* FastPredict(PyObject* self, PyObject* const* args, Py_ssize_t nargs, PyObject* kwnames) {
  static const char* const kNames[] = {"u", "B", "F", "Q"};
  try {
    py::handle a[4];
    BindArguments("predict", kNames, 0, args, nargs, kwnames, a);
    Self(self).Predict(a[0], a[1], a[2], a[3]);
  } catch (...) {
    RaiseInPython();
    return nullptr;
  }
  Py_RETURN_NONE;
}

PyObject* FastUpdate(PyObject* self, PyObject* const* args, Py_ssize_t nargs, PyObject* kwnames) {
  static const char* const kNames[] = {"z", "R", "H"};
  try {
    py::handle a[3];
    BindArguments("update", kNames, 1, args, nargs, kwnames, a);
    Self(self).Update(a[0], a[1], a[2], false);
  } catch (...) {
    RaiseInPython();
    return nullptr;
  }
  Py_RETURN_NONE;
}

// cls.<def->ml_name> = a method descriptor of `def` (its doc starts with the signature line inspect reads).
void DefFast(py::class_<KF>& cls, PyMethodDef* def) {
  py::object descr =
      py::reinterpret_steal<py::object>(PyDescr_NewMethod(reinterpret_cast<PyTypeObject*>(cls.ptr()), def));
  if (!descr) throw py::error_already_set();
  cls.attr(def->ml_name) = descr;
}

}  // namespace

void BindFilterPyKalmanFilter(py::module_& m) {
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
          "update_correlated", [](KF& f, py::handle z, py::handle R, py::handle H) { f.Update(z, R, H, true); },
          py::arg("z"), py::arg("R") = py::none(), py::arg("H") = py::none(),
          "Update when the measurement noise is correlated with the prior error (cross-covariance M): "
          "S = H P H^T + H M + M^T H^T + R, K = (P H^T + M) S^-1. Raises kfx.Error as update, or if M does not have "
          "a column per row of H; kfx.NumericalError if S is not positive definite.")
      .def("update_steadystate", &KF::UpdateSteadyState, py::arg("z"),
           "x = x + K (z - H x) with the stored K; P kept. Raises kfx.Error if z is not a measurement of length "
           "dim_z or has an infinite entry.")
      .def("predict_steadystate", &KF::PredictSteadyState, py::arg("u") = 0, py::arg("B") = py::none(),
           "x = F x + B u; P kept. Raises kfx.Error if B is not (dim_x, k) or u does not have k entries (a number "
           "needs k = 1), or if either is not a real numeric array.")
      .def("update_sequential", &KF::UpdateSequential, py::arg("start"), py::arg("z_i"), py::arg("R_i") = py::none(),
           py::arg("H_i") = py::none(),
           "Update with rows start .. start + len(z_i) of the measurement only (R_i, H_i default to those rows of "
           "R, H); fills those rows of y, K, z. Raises kfx.Error if z_i is not a number or a vector, if the rows run "
           "past dim_z, or if R_i, H_i do not have len(z_i) rows; kfx.NumericalError if S is not positive "
           "definite.")
      .def("batch_filter", &KF::BatchFilter, py::arg("zs"), py::arg("Fs") = py::none(), py::arg("Qs") = py::none(),
           py::arg("Hs") = py::none(), py::arg("Rs") = py::none(), py::arg("Bs") = py::none(),
           py::arg("us") = py::none(), py::arg("update_first") = false, py::arg("saver") = py::none(),
           "Filters every zs[i] in one call (predict then update, or update then predict with update_first): "
           "returns (means, covariances, means_p, covariances_p), means (T, dim_x, 1) for a column x, (T, dim_x) "
           "for a 1-D x; the filter ends in the last state. Per-step Fs, Qs, Hs, Rs, Bs, us; saver.save() after "
           "each step. Without a saver the loop runs in C++ with the GIL released. Raises kfx.Error if zs is not "
           "(T, dim_z) / (T, dim_z, 1) or a sequence of measurements, if zs has an infinite entry, if a per-step "
           "list does not have one item per step or an item has the wrong shape; kfx.NumericalError (naming the "
           "step) if S is not positive definite.")
      .def("rts_smoother", &KF::RtsSmoother, py::arg("Xs"), py::arg("Ps"), py::arg("Fs") = py::none(),
           py::arg("Qs") = py::none(),
           "Rauch-Tung-Striebel smoother over filtered means Xs and covariances Ps (Fs[k+1], Qs[k+1] take step k "
           "to k+1): returns (x, P, K, Pp) as FilterPy: K the smoother gains (zero last), Pp the predicted "
           "covariances with Pp[-1] = Ps[-1]. Raises kfx.Error if Xs, Ps differ in length or are not (T, dim_x) / "
           "(T, dim_x, 1) and (T, dim_x, dim_x), or if Fs, Qs do not have one (dim_x, dim_x) item per step.")
      .def("get_prediction", &KF::GetPrediction, py::arg("u") = py::none(), py::arg("B") = py::none(),
           py::arg("F") = py::none(), py::arg("Q") = py::none(),
           "(x, P) predict() would give; the filter is unchanged. Raises kfx.Error as predict.")
      .def("get_update", &KF::GetUpdate, py::arg("z") = py::none(),
           "(x, P) update(z) would give; the filter is unchanged (z None: the current x, P). Raises kfx.Error as "
           "update_steadystate; kfx.NumericalError if S is not positive definite.")
      .def("residual_of", &KF::ResidualOf, py::arg("z"),
           "z - H x_prior. Raises kfx.Error if z is not a measurement of length dim_z or has an infinite entry.")
      .def("to_model", &KF::AsModel, "The time-invariant kfx.Model (F, H, Q, R, x, P); B and M are not part of it.");
  static PyMethodDef predict = {
      "predict", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(FastPredict)),
      METH_FASTCALL | METH_KEYWORDS,
      "predict($self, /, u=None, B=None, F=None, Q=None)\n--\n\n"
      "x = F x + B u, P = alpha^2 F P F^T + Q (Q given as a number: q I); sets x_prior, P_prior. Raises "
      "kfx.Error if F, Q are not (dim_x, dim_x) (Q also a number), B is not (dim_x, k) or u does not have k "
      "entries, if an argument is not a real numeric array, or if x, P, F or Q was reshaped in place."};
  static PyMethodDef update = {
      "update", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(FastUpdate)), METH_FASTCALL | METH_KEYWORDS,
      "update($self, /, z, R=None, H=None)\n--\n\n"
      "Joseph-form update with z (a number, (dim_z,), (dim_z, 1) or (1, dim_z)); None: no update; NaN "
      "entries are missing. Sets y, S, K, z, x_post, P_post. Raises kfx.Error if z is not a measurement of "
      "length k = the rows of H or has an infinite entry, if H is not (k, dim_x) or R not (k, k) (or a "
      "number), or if an attribute was reshaped in place; kfx.NumericalError if S is not positive definite."};
  DefFast(cls, &predict);
  DefFast(cls, &update);
}

}  // namespace kfx::python
