// kfx._core: the filter DARE, the discrete Lyapunov equation and the spectral radius
// (include/kfx/riccati.hpp).
#include <optional>
#include <string>

#include "bindings.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/riccati.hpp"
#include "long_call.hpp"

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
         const std::string& method, int max_iterations, double tolerance, bool refine, bool exact_eigenvalues,
         const std::optional<Eigen::MatrixXd>& S, const std::optional<Eigen::MatrixXd>& E, const py::object& progress) {
        DareOptions o;
        o.method = ParseEnum<DareMethod>("method", method);
        o.max_iterations = max_iterations;
        o.tolerance = tolerance;
        o.refine = refine;
        o.exact_eigenvalues = exact_eigenvalues;
        LongCall call(progress);
        o.progress = call.callback();
        return call.Run([&] {
          if (!S && !E) return SolveFilterDare(A, C, Q, R, o);
          return SolveFilterDare(A, C, Q, R, S ? *S : Eigen::MatrixXd(0, 0), E ? *E : Eigen::MatrixXd(0, 0), o);
        });
      },
      py::arg("A"), py::arg("C"), py::arg("Q"), py::arg("R"), py::arg("method") = "auto",
      py::arg("max_iterations") = 60, py::arg("tolerance") = 1e-14, py::arg("refine") = true,
      py::arg("exact_eigenvalues") = false, py::arg("S") = py::none(), py::arg("E") = py::none(),
      py::arg("progress") = py::none(),
      "Filter DARE P = A P A^T + Q - A P C^T (C P C^T + R)^{-1} C P A^T (prediction form; scipy's "
      "solve_discrete_are(A.T, C.T, Q, R) gives the same P). Numerical failures are in .summary.termination, "
      "never raised. Stability is proven by a Lyapunov certificate whose bounds the summary reports; "
      "exact_eigenvalues=True reports rho(A - K_p C) and lambda_min(P) from the eigenvalues instead. "
      "With a cross term S (n, m) and/or a descriptor E (n, n): E P E^T = A P A^T + Q - (A P C^T + S) W^{-1} "
      "(A P C^T + S)^T, W = C P C^T + R, the dual of scipy's solve_discrete_are(A.T, C.T, Q, R, e=E.T, s=S) and "
      "python-control's dare(A.T, C.T, Q, R, S, E.T); predictor_gain K_p = (A P C^T + S) W^{-1} (python-control's "
      "G is K_p.T), filter_gain K_f = P C^T W^{-1}. method 'doubling': E^{-1} and the decorrelation "
      "A - S R^{-1} C, Q - S R^{-1} S^T, then the standard solver; 'schur': SLICOT SG02AD; 'auto': doubling, "
      "SG02AD if E is ill-conditioned or doubling fails. [[Q, S], [S^T, R]] must be PSD, E nonsingular. "
      "progress: None or progress(step, max_iterations) over the doubling steps (not the Schur method), at most "
      "every 0.05 s; the GIL is released, and Ctrl-C stops the doubling with KeyboardInterrupt.");
  m.def(
      "filter_dare_residual",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& R,
         const Eigen::MatrixXd& P, const std::optional<Eigen::MatrixXd>& S, const std::optional<Eigen::MatrixXd>& E) {
        py::gil_scoped_release release;
        if (!S && !E) return FilterDareResidual(A, C, Q, R, P);
        return FilterDareResidual(A, C, Q, R, S ? *S : Eigen::MatrixXd(0, 0), E ? *E : Eigen::MatrixXd(0, 0), P);
      },
      py::arg("A"), py::arg("C"), py::arg("Q"), py::arg("R"), py::arg("P"), py::arg("S") = py::none(),
      py::arg("E") = py::none(),
      "Relative residual of a candidate P of the filter DARE (with S and E: |A P A^T - E P E^T + Q - K_p W "
      "K_p^T|_F / |E P E^T|_F).");
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
      "Smith iteration when it converges, else 'schur'), 'schur' (Bartels-Stewart on LAPACK DGEES's real Schur form) "
      "or 'smith'. Returns a "
      "LyapunovSolution; a singular equation is .summary.termination 'singular', never raised.");
  m.def(
      "solve_generalized_discrete_lyapunov",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& E, const Eigen::MatrixXd& Q) {
        py::gil_scoped_release release;
        return SolveGeneralizedDiscreteLyapunov(A, E, Q);
      },
      py::arg("A"), py::arg("E"), py::arg("Q"),
      "A X A^T - E X E^T + Q = 0 (python-control dlyap(A, Q, None, E)) by SLICOT SG03AD. Returns a "
      "LyapunovSolution; a reciprocal eigenvalue pair of the pencil (A, E) is .summary.termination 'singular'.");
  py::class_<SteinSolution>(m, "SteinSolution")
      .def_readonly("X", &SteinSolution::X, "the solution (n, m)")
      .def_readonly("summary", &SteinSolution::summary, "How the solve ended (kfx.Summary).");
  m.def(
      "solve_discrete_sylvester",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::MatrixXd& C) {
        py::gil_scoped_release release;
        return SolveDiscreteSylvester(A, B, C);
      },
      py::arg("A"), py::arg("B"), py::arg("C"),
      "Stein / discrete Sylvester equation A X B - X + C = 0 (python-control dlyap(A, Q, C) is B = Q.T) by "
      "SLICOT SB04QD. Returns a SteinSolution; a singular equation is .summary.termination 'singular'.");
  m.def(
      "spectral_radius", [](const Eigen::MatrixXd& A) { return SpectralRadius(A); }, py::arg("A"),
      py::call_guard<py::gil_scoped_release>());
}

}  // namespace kfx::python
