// The kfx._core module: PYBIND11_MODULE, the two exceptions, the kfx.Summary class, and the calls to
// the other Bind functions, lowest layer first (docs/architecture.md). The docstrings summarize the C++
// doc comments of include/kfx/*.hpp (the reference).
#include <string>

#include "bindings.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/error.hpp"
#include "kfx/summary.hpp"

namespace kfx::python {

void BindCompare(py::module_& m);    // bind_compare.cpp: method_spec.hpp, compare.hpp
void AttachCppDocs(py::module_& m);  // cpp_docs.cpp: the C++ doc comments appended to the docstrings

namespace {

void BindSummary(py::module_& m) {
  py::class_<Summary>(m, "Summary",
                      "How a solver or long computation ended: the one outcome shape of kfx. Numerical outcomes "
                      "(no convergence, a singular equation, lost definiteness, an unstable system) are reported "
                      "here, never raised; invalid input raises kfx.Error.")
      .def_readonly("computation", &Summary::computation, "what was computed, e.g. 'filter DARE'")
      .def_property_readonly(
          "termination", [](const Summary& s) { return std::string(ToString(s.termination)); },
          "'converged', 'not_converged', 'not_stabilizing', 'not_detectable', 'not_stabilizable', 'unstable', "
          "'singular', 'lost_definiteness', 'undecided' or 'failed'")
      .def_property_readonly("ok", &Summary::ok, "termination == 'converged'")
      .def_readonly("message", &Summary::message)
      .def_readonly("method", &Summary::method, "the algorithm that produced the result")
      .def_readonly("iterations", &Summary::iterations)
      .def_readonly("relative_residual", &Summary::relative_residual, "NaN when not computed")
      .def_readonly("relative_change", &Summary::relative_change, "an iteration's last relative change (NaN: none)")
      .def_readonly("seconds", &Summary::seconds)
      .def_property_readonly(
          "details",
          [](const Summary& s) {
            py::dict d;
            for (const auto& [key, value] : s.details) d[py::str(key)] = value;
            return d;
          },
          "further named facts of the computation (as strings)")
      .def("brief_report", &Summary::BriefReport)
      .def("full_report", &Summary::FullReport)
      .def("__repr__", &Summary::BriefReport);
}

}  // namespace
}  // namespace kfx::python

PYBIND11_MODULE(_core, m) {
  using namespace kfx::python;
  m.doc() = "kfx: Kalman filtering for large and infinite-dimensional linear systems (compiled core; import kfx).";
  m.attr("__version__") = KFX_VERSION;
  py::register_exception<kfx::Error>(m, "Error", PyExc_ValueError);
  py::register_exception<kfx::NumericalError>(m, "NumericalError", PyExc_ArithmeticError);
  BindSummary(m);
  BindRiccati(m);
  BindModel(m);
  BindPerformance(m);
  BindKalmanFilter(m);
  BindFilterPyKalmanFilter(m);
  BindSubspaceFilter(m);
  BindReducedOrder(m);
  BindMismatch(m);
  BindContinuous(m);
  BindBlockDiagonal(m);
  BindCompare(m);
  BindReproduce(m);
  AttachCppDocs(m);
}
