// kfx._core: the filter DARE, the discrete Lyapunov equation and the spectral radius
// (include/kfx/riccati.hpp).
#include <string>

#include "bindings.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/riccati.hpp"

namespace kfx::python {

void BindRiccati(py::module_& m) {
  py::class_<DareSolution>(m, "DareSolution",
                           "Filter DARE solution. Gains: filter gain K_f = P C^T (C P C^T + R)^{-1} (x_{k|k} = "
                           "x_{k|k-1} + K_f nu_k); predictor gain K_p = A K_f (x_{k+1|k} = A x_{k|k-1} + K_p nu_k).")
      .def_readonly("P_pred", &DareSolution::P_pred, "a priori P_{k|k-1}: the DARE solution")
      .def_readonly("P_filt", &DareSolution::P_filt, "a posteriori P_{k|k}")
      .def_readonly("filter_gain", &DareSolution::filter_gain, "K_f (n, m)")
      .def_readonly("predictor_gain", &DareSolution::predictor_gain, "K_p = A K_f (n, m)")
      .def_readonly("innovation_cov", &DareSolution::innovation_cov)
      .def_property_readonly(
          "method_used", [](const DareSolution& s) { return std::string(ToString(s.method_used)); },
          "'doubling' or 'schur': what produced the result")
      .def_readonly("fell_back", &DareSolution::fell_back, "method 'auto': doubling failed and Schur was tried")
      .def_readonly("refinement_steps", &DareSolution::refinement_steps)
      .def_readonly("closed_loop_spectral_radius", &DareSolution::closed_loop_spectral_radius)
      .def_readonly("min_eigenvalue", &DareSolution::min_eigenvalue)
      .def_readonly("eigenvalues_exact", &DareSolution::eigenvalues_exact,
                    "True: closed_loop_spectral_radius and min_eigenvalue are eigenvalues; False: the Lyapunov "
                    "certificate's bounds (rho <= closed_loop_spectral_radius, lambda_min(P) >= min_eigenvalue)")
      .def_readonly("lyapunov_certified", &DareSolution::lyapunov_certified)
      .def_readonly("summary", &DareSolution::summary, "How the solve ended (kfx.Summary).");
  m.def(
      "solve_filter_dare",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& R,
         const std::string& method, int max_iterations, double tolerance, bool refine, bool exact_eigenvalues) {
        DareOptions o;
        o.method = ParseEnum<DareMethod>("method", method);
        o.max_iterations = max_iterations;
        o.tolerance = tolerance;
        o.refine = refine;
        o.exact_eigenvalues = exact_eigenvalues;
        return SolveFilterDare(A, C, Q, R, o);
      },
      py::arg("A"), py::arg("C"), py::arg("Q"), py::arg("R"), py::arg("method") = "auto",
      py::arg("max_iterations") = 60, py::arg("tolerance") = 1e-14, py::arg("refine") = true,
      py::arg("exact_eigenvalues") = false,
      "Filter DARE P = A P A^T + Q - A P C^T (C P C^T + R)^{-1} C P A^T (prediction form; scipy's "
      "solve_discrete_are(A.T, C.T, Q, R) gives the same P). Numerical failures are in .summary.termination, "
      "never raised. Stability is proven by a Lyapunov certificate whose bounds the summary reports; "
      "exact_eigenvalues=True reports rho(A - K_p C) and lambda_min(P) from the eigenvalues instead.");
  m.def("filter_dare_residual", &FilterDareResidual, py::arg("A"), py::arg("C"), py::arg("Q"), py::arg("R"),
        py::arg("P"));
  py::class_<LyapunovSolution>(m, "LyapunovSolution")
      .def_readonly("X", &LyapunovSolution::X, "the solution (n, n)")
      .def_readonly("spectral_radius", &LyapunovSolution::spectral_radius, "rho(A) from the Schur form (NaN: Smith)")
      .def_readonly("summary", &LyapunovSolution::summary, "How the solve ended (kfx.Summary).");
  m.def(
      "solve_discrete_lyapunov",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const std::string& method) {
        LyapunovOptions o;
        o.method = ParseEnum<LyapunovMethod>("method", method);
        py::gil_scoped_release release;
        return SolveDiscreteLyapunov(A, Q, o);
      },
      py::arg("A"), py::arg("Q"), py::arg("method") = "auto",
      "X = A X A^T + Q (the convention of scipy.linalg.solve_discrete_lyapunov): method 'auto' (the squared "
      "Smith iteration when it converges, else 'schur'), 'schur' (SLICOT SB03MD) or 'smith'. Returns a "
      "LyapunovSolution; a singular equation is .summary.termination 'singular', never raised.");
  m.def(
      "spectral_radius", [](const Eigen::MatrixXd& A) { return SpectralRadius(A); }, py::arg("A"));
}

}  // namespace kfx::python
