// kfx._core, paper 000: the optimal filter on a coarse subspace (Algorithm 2.3), its Sec. 6.1
// approximation, the discretization-error bounds and the damped wave equation
// (include/kfx/subspace_filter.hpp, damped_wave.hpp).
#include <optional>

#include "bindings.hpp"
#include "kfx/damped_wave.hpp"
#include "kfx/subspace_filter.hpp"
#include "long_call.hpp"

namespace kfx::python {

void BindSubspaceFilter(py::module_& m) {
  py::class_<Subspace>(m, "Subspace", "000: inner product W (gram) and Pi (n x N), orthonormal in W.")
      .def(py::init([](Eigen::MatrixXd projection, std::optional<Eigen::MatrixXd> gram) {
             Subspace s{OrEmpty(gram), std::move(projection)};
             ValidateSubspace(s, s.full_dim());
             return s;
           }),
           py::arg("projection"), py::arg("gram") = py::none())
      .def_readonly("gram", &Subspace::gram)
      .def_readonly("projection", &Subspace::projection)
      .def_property_readonly("full_dim", &Subspace::full_dim)
      .def_property_readonly("reduced_dim", &Subspace::reduced_dim);
  m.def("subspace_from_basis", &SubspaceFromBasis, py::arg("basis"), py::arg("gram"),
        "The span of basis (N x n) with W-orthonormal coordinates.");
  m.def("projection_adjoint", &ProjectionAdjoint, py::arg("subspace"), "Pi^* = W^{-1} Pi^T.");
  py::class_<SubspaceFilterSchedule>(m, "SubspaceFilterSchedule")
      .def_property_readonly(
          "gain", [](const SubspaceFilterSchedule& s) { return Stack(s.gain, 1); }, "(T, N, m): K_1..K_T if stored")
      .def_property_readonly(
          "output_map", [](const SubspaceFilterSchedule& s) { return Stack(s.output_map); }, "(T+1, N, n): Q_k")
      .def_readonly("K", &SubspaceFilterSchedule::K)
      .def_readonly("Q", &SubspaceFilterSchedule::Q)
      .def_readonly("P_final", &SubspaceFilterSchedule::P_final)
      .def_readonly("steps", &SubspaceFilterSchedule::steps)
      .def_readonly("converged_at", &SubspaceFilterSchedule::converged_at)
      .def_readonly("summary", &SubspaceFilterSchedule::summary)
      .def_readonly("rde_max_relative_difference", &SubspaceFilterSchedule::rde_max_relative_difference);
  m.def(
      "subspace_filter_schedule",
      [](const ModelStep& truth, const Eigen::MatrixXd& S0, const Subspace& sub, int steps, int max_steps,
         double tolerance, bool rde_check, bool stationary_prior, const py::object& progress) {
        SubspaceFilterOptions o;
        o.steps = steps;
        o.max_steps = max_steps;
        o.tolerance = tolerance;
        o.rde_check = rde_check;
        o.stationary_prior = stationary_prior;
        LongCall call(progress);
        o.progress = call.callback();
        return call.Run([&] { return ComputeSubspaceFilterSchedule(truth, S0, sub, o); });
      },
      py::arg("truth"), py::arg("S0"), py::arg("subspace"), py::arg("steps") = -1, py::arg("max_steps") = 20000,
      py::arg("tolerance") = 1e-11, py::arg("rde_check") = false, py::arg("stationary_prior") = false,
      py::arg("progress") = py::none(),
      (std::string("000 Algorithm 2.3 (offline part): gains K_k and output maps Q_k until convergence (or "
                   "`steps`).") +
       kProgressDoc)
          .c_str());
  m.def("subspace_filter_as_linear_filter", &SubspaceFilterAsLinearFilter, py::arg("truth"), py::arg("subspace"),
        py::arg("schedule"), py::arg("m0"), "The time-varying subspace filter (z_0 = Pi m0) for exact_performance.");
  m.def("converged_subspace_filter_as_linear_filter", &ConvergedSubspaceFilterAsLinearFilter, py::arg("truth"),
        py::arg("subspace"), py::arg("schedule"), py::arg("m0"));
  py::class_<ApproximateSubspaceFilter>(m, "ApproximateSubspaceFilter")
      .def_readonly("Q_hat", &ApproximateSubspaceFilter::Q_hat)
      .def_readonly("V_hat", &ApproximateSubspaceFilter::V_hat)
      .def_readonly("A_r", &ApproximateSubspaceFilter::A_r)
      .def_readonly("Q_r", &ApproximateSubspaceFilter::Q_r)
      .def_readonly("C_r", &ApproximateSubspaceFilter::C_r)
      .def_readonly("Phi", &ApproximateSubspaceFilter::Phi)
      .def_readonly("gain", &ApproximateSubspaceFilter::gain)
      .def_readonly("summary", &ApproximateSubspaceFilter::summary);
  m.def(
      "approximate_subspace_filter",
      [](const ModelStep& truth, const Eigen::MatrixXd& S, const Subspace& sub, bool residual) {
        return ComputeApproximateSubspaceFilter(truth, S, sub, residual);
      },
      py::arg("truth"), py::arg("S"), py::arg("subspace"), py::arg("measurement_noise_from_residual") = false,
      "000 Sec. 6.1: the approximate reduced model and its steady-state filter.");
  m.def("approximate_subspace_filter_as_linear_filter", &ApproximateSubspaceFilterAsLinearFilter, py::arg("approx"),
        py::arg("z0"));
  py::class_<DiscretizationBounds>(m, "DiscretizationBounds")
      .def_readonly("trace_M", &DiscretizationBounds::trace_M)
      .def_readonly("trace_M_inf", &DiscretizationBounds::trace_M_inf)
      .def_readonly("trace_delta_P", &DiscretizationBounds::trace_delta_P)
      .def_readonly("trace_delta_P_bound", &DiscretizationBounds::trace_delta_P_bound)
      .def_readonly("theorem41", &DiscretizationBounds::theorem41)
      .def_readonly("theorem41_exact_dP", &DiscretizationBounds::theorem41_exact_dP)
      .def_readonly("theorem42", &DiscretizationBounds::theorem42)
      .def_readonly("remark43", &DiscretizationBounds::remark43)
      .def_readonly("actual", &DiscretizationBounds::actual)
      .def_readonly("rho_full", &DiscretizationBounds::rho_full)
      .def_readonly("rho_reduced", &DiscretizationBounds::rho_reduced)
      .def_readonly("P_full", &DiscretizationBounds::P_full)
      .def_readonly("P_b", &DiscretizationBounds::P_b)
      .def_readonly("summary", &DiscretizationBounds::summary);
  m.def("discretization_bounds", &ComputeDiscretizationBounds, py::arg("truth"), py::arg("S"), py::arg("subspace"),
        py::arg("schedule"), "000 Sec. 4: Theorems 4.1, 4.2, Remark 4.3 and the actual error.");
  py::class_<WaveDiscretization>(m, "WaveDiscretization")
      .def_readonly("nodes", &WaveDiscretization::nodes)
      .def_readonly("stiffness", &WaveDiscretization::stiffness)
      .def_readonly("mass", &WaveDiscretization::mass)
      .def_readonly("load", &WaveDiscretization::load)
      .def_readonly("output", &WaveDiscretization::output)
      .def_readonly("step", &WaveDiscretization::step)
      .def_readonly("gram", &WaveDiscretization::gram);
  py::class_<DampedWaveProblem>(m, "DampedWaveProblem")
      .def_readonly("fine", &DampedWaveProblem::fine)
      .def_readonly("coarse", &DampedWaveProblem::coarse)
      .def_readonly("prolongation", &DampedWaveProblem::prolongation)
      .def_readonly("subspace", &DampedWaveProblem::subspace);
  m.def(
      "damped_wave",
      [](int fine_nodes, int coarse_nodes, double eps, double dt) {
        DampedWaveOptions o;
        o.fine_nodes = fine_nodes;
        o.coarse_nodes = coarse_nodes;
        o.eps = eps;
        o.dt = dt;
        return BuildDampedWave(o);
      },
      py::arg("fine_nodes") = 65, py::arg("coarse_nodes") = 5, py::arg("eps") = 0.4, py::arg("dt") = 0.01,
      "000 Sec. 5: the damped wave equation (P1 FEM, implicit Euler) on nested meshes and the coarse subspace.");
}

}  // namespace kfx::python
