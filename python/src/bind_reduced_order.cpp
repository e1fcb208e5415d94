// kfx._core, paper 001: reduced-order filters (projector tau) and subspace estimators (projector mu),
// the weighted costs and the spring-mass-dashpot chain (include/kfx/reduced_order.hpp,
// spring_mass_chain.hpp).
#include <string>

#include "bindings.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/reduced_order.hpp"
#include "kfx/spring_mass_chain.hpp"

namespace kfx::python {

namespace {

TwoStepOutput ParseTwoStepOutput(const std::string& s) { return ParseEnum<TwoStepOutput>("output", s); }

WeightSchedule MakeWeights(const py::object& L) {
  if (py::isinstance<py::array>(L) && L.cast<py::array>().ndim() == 2) return WeightSchedule(L.cast<Eigen::MatrixXd>());
  if (py::isinstance<py::array>(L) || py::isinstance<py::list>(L) || py::isinstance<py::tuple>(L))
    return WeightSchedule(MatrixList(L, "L"));
  return WeightSchedule(L.cast<Eigen::MatrixXd>());
}

}  // namespace

void BindReducedOrder(py::module_& m) {
  py::class_<WeightSchedule>(m, "WeightSchedule", "001: L_k (q x n, full row rank): one matrix or one per step.")
      .def(py::init(&MakeWeights), py::arg("L"))
      .def("at", &WeightSchedule::at, py::arg("k"))
      .def_property_readonly("rows", &WeightSchedule::rows)
      .def_property_readonly("cols", &WeightSchedule::cols);
  py::class_<ReducedOrderOneStep>(m, "ReducedOrderOneStep")
      .def_readonly("xi1", &ReducedOrderOneStep::xi1)
      .def_property_readonly(
          "Q", [](const ReducedOrderOneStep& s) { return Stack(s.Q, 1); }, "(T, n, n): Q_1..Q_T")
      .def_property_readonly(
          "Qhat", [](const ReducedOrderOneStep& s) { return Stack(s.Qhat, 1); }, "(T, n, n)")
      .def_readonly("cost", &ReducedOrderOneStep::cost, "tr(L_k Q_k L_k^T), k = 0..T (entry 0 NaN)")
      .def_readonly("singular_steps", &ReducedOrderOneStep::singular_steps)
      .def_readonly("summary", &ReducedOrderOneStep::summary);
  py::class_<ReducedOrderTwoStep>(m, "ReducedOrderTwoStep")
      .def_readonly("xi1", &ReducedOrderTwoStep::xi1)
      .def_readonly("cost_da", &ReducedOrderTwoStep::cost_da)
      .def_readonly("cost_f", &ReducedOrderTwoStep::cost_f)
      .def_readonly("singular_steps", &ReducedOrderTwoStep::singular_steps)
      .def_readonly("summary", &ReducedOrderTwoStep::summary);
  auto opts = [](int steps, double rank_tolerance) {
    ReducedOrderOptions o;
    o.steps = steps;
    o.rank_tolerance = rank_tolerance;
    return o;
  };
  m.def(
      "reduced_order_one_step",
      [opts](const Model& model, const WeightSchedule& L, int steps, double tol) {
        return ComputeReducedOrderOneStep(model, L, opts(steps, tol));
      },
      py::arg("model"), py::arg("L"), py::arg("steps") = -1, py::arg("rank_tolerance") = 1e-10,
      py::call_guard<py::gil_scoped_release>(), "001 Sec. II: the one-step reduced-order filter (offline part).");
  m.def("reduced_order_one_step_as_linear_filter", &ReducedOrderOneStepAsLinearFilter, py::arg("schedule"),
        py::arg("L"), "The one-step filter as a kfx.LinearFilter (output L_k^+ xi_k).");
  m.def(
      "reduced_order_two_step",
      [opts](const Model& model, const WeightSchedule& L, int steps, double tol) {
        return ComputeReducedOrderTwoStep(model, L, opts(steps, tol));
      },
      py::arg("model"), py::arg("L"), py::arg("steps") = -1, py::arg("rank_tolerance") = 1e-10,
      py::call_guard<py::gil_scoped_release>(), "001 Sec. III: the two-step (data assimilation + forecast) filter.");
  m.def(
      "reduced_order_two_step_as_linear_filter",
      [](const ReducedOrderTwoStep& s, const WeightSchedule& L, const std::string& output) {
        return ReducedOrderTwoStepAsLinearFilter(s, L, ParseTwoStepOutput(output));
      },
      py::arg("schedule"), py::arg("L"), py::arg("output") = "data_assimilation");
  m.def(
      "weighted_cost",
      [](const Model& truth, const LinearFilter& f, const WeightSchedule& L, int steps) {
        ReducedOrderOptions o;
        o.steps = steps;
        return WeightedCost(truth, f, L, o);
      },
      py::arg("truth"), py::arg("filter"), py::arg("L"), py::arg("steps"), py::call_guard<py::gil_scoped_release>(),
      "J_k = E|L_k x_k - L_k O_k z_k|^2, k = 0..T, from the exact-performance engine.");
  m.def(
      "kalman_costs",
      [](const Model& model, const WeightSchedule& L, int steps) {
        ReducedOrderOptions o;
        o.steps = steps;
        KalmanWeightedCosts c;
        {
          py::gil_scoped_release release;
          c = KalmanCosts(model, L, o);
        }
        return py::make_tuple(c.predictor, c.filter);
      },
      py::arg("model"), py::arg("L"), py::arg("steps"),
      "Full-order Kalman costs (predictor, filter): tr(L_k P_{k|k-1} L_k^T), tr(L_k P_{k|k} L_k^T).");
  py::class_<InvariantSubspaceBasis>(m, "InvariantSubspaceBasis")
      .def_readonly("T", &InvariantSubspaceBasis::T)
      .def_readonly("n_r", &InvariantSubspaceBasis::n_r)
      .def_readonly("eigenvalues", &InvariantSubspaceBasis::eigenvalues)
      .def_readonly("other_eigenvalues", &InvariantSubspaceBasis::other_eigenvalues)
      .def_readonly("invariance_residual", &InvariantSubspaceBasis::invariance_residual);
  m.def("least_damped_subspace", &LeastDampedSubspace, py::arg("A"), py::arg("n_r"),
        py::call_guard<py::gil_scoped_release>(),
        "The n_r least damped modes of A (ordered real Schur form), canonical basis T = [V_r, V_s].");
  m.def("triangularity_defect", &TriangularityDefect, py::arg("A"), py::arg("T"), py::arg("n_r"));
  py::class_<SubspaceOneStep>(m, "SubspaceOneStep")
      .def_readonly("xi1", &SubspaceOneStep::xi1)
      .def_readonly("cost", &SubspaceOneStep::cost)
      .def_readonly("triangularity_defect", &SubspaceOneStep::triangularity_defect)
      .def_readonly("summary", &SubspaceOneStep::summary);
  py::class_<SubspaceTwoStep>(m, "SubspaceTwoStep")
      .def_readonly("xi1", &SubspaceTwoStep::xi1)
      .def_readonly("cost_da", &SubspaceTwoStep::cost_da)
      .def_readonly("cost_f", &SubspaceTwoStep::cost_f)
      .def_readonly("triangularity_defect", &SubspaceTwoStep::triangularity_defect)
      .def_readonly("summary", &SubspaceTwoStep::summary);
  m.def(
      "subspace_one_step",
      [opts](const Model& model, const Eigen::MatrixXd& T, Eigen::Index n_r, const WeightSchedule& L, int steps,
             double tol) { return ComputeSubspaceOneStep(model, T, n_r, L, opts(steps, tol)); },
      py::arg("model"), py::arg("T"), py::arg("n_r"), py::arg("L"), py::arg("steps") = -1,
      py::arg("rank_tolerance") = 1e-10, py::call_guard<py::gil_scoped_release>(),
      "001 Sec. IV (4.10)-(4.13): the one-step subspace estimator.");
  m.def("subspace_one_step_as_linear_filter", &SubspaceOneStepAsLinearFilter, py::arg("schedule"), py::arg("T"),
        py::arg("n_r"));
  m.def(
      "subspace_two_step",
      [opts](const Model& model, const Eigen::MatrixXd& T, Eigen::Index n_r, const WeightSchedule& L, int steps,
             double tol) { return ComputeSubspaceTwoStep(model, T, n_r, L, opts(steps, tol)); },
      py::arg("model"), py::arg("T"), py::arg("n_r"), py::arg("L"), py::arg("steps") = -1,
      py::arg("rank_tolerance") = 1e-10, py::call_guard<py::gil_scoped_release>(),
      "001 (4.16)-(4.20): the two-step subspace estimator.");
  m.def(
      "subspace_two_step_as_linear_filter",
      [](const SubspaceTwoStep& s, const Eigen::MatrixXd& T, Eigen::Index n_r, const std::string& output) {
        return SubspaceTwoStepAsLinearFilter(s, T, n_r, ParseTwoStepOutput(output));
      },
      py::arg("schedule"), py::arg("T"), py::arg("n_r"), py::arg("output") = "data_assimilation");
  m.def(
      "spring_mass_chain",
      [](int N, double mass, double k, double c, bool left_fixed, bool right_fixed, double dt, int first_mass) {
        SpringMassChainOptions o = UniformChain(N, mass, k, c, left_fixed, right_fixed, dt);
        o.first_mass = first_mass;
        SpringMassChain ch = BuildSpringMassChain(o);
        py::dict d;
        d["Ac"] = ch.Ac;
        d["Ad"] = ch.Ad;
        d["K"] = ch.K;
        d["D"] = ch.D;
        d["order"] = ch.order;
        return d;
      },
      py::arg("N"), py::arg("mass") = 1.0, py::arg("k") = 1.0, py::arg("c") = 0.0, py::arg("left_fixed") = true,
      py::arg("right_fixed") = true, py::arg("dt") = 0.1, py::arg("first_mass") = 0,
      "001 Fig. 1: a uniform chain of N masses; dict with Ac, Ad = e^{Ac dt}, K, D, order.");
}

}  // namespace kfx::python
