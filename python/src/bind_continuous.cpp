// kfx._core, paper 003: continuous time: the continuous model, exact sampling, Kalman-Bucy, the CARE
// and the convergence of the sampled filter (include/kfx/continuous.hpp, sampling_convergence.hpp).
#include <cstdint>
#include <optional>
#include <vector>

#include "bindings.hpp"
#include "kfx/continuous.hpp"
#include "kfx/sampling_convergence.hpp"
#include "long_call.hpp"

namespace kfx::python {

void BindContinuous(py::module_& m) {
  py::class_<ContinuousModel>(m, "ContinuousModel",
                              "003: dz = A z dt + B du, dy = C z dt + dw, z(0) ~ N(m0, P0); Q, R the incremental "
                              "covariances of u, w. B, Q may be None (no input noise).")
      .def(py::init([](Eigen::MatrixXd A, std::optional<Eigen::MatrixXd> B, Eigen::MatrixXd C,
                       std::optional<Eigen::MatrixXd> Q, Eigen::MatrixXd R, Eigen::VectorXd m0, Eigen::MatrixXd P0) {
             ContinuousModel cm;
             cm.A = std::move(A);
             cm.B = B ? *B : Eigen::MatrixXd(cm.A.rows(), 0);
             cm.C = std::move(C);
             cm.Q = Q ? *Q : Eigen::MatrixXd(0, 0);
             cm.R = std::move(R);
             cm.m0 = std::move(m0);
             cm.P0 = std::move(P0);
             ValidateContinuousModel(cm);
             return cm;
           }),
           py::arg("A"), py::arg("B") = py::none(), py::arg("C"), py::arg("Q") = py::none(), py::arg("R"),
           py::arg("m0"), py::arg("P0"))
      .def_readonly("A", &ContinuousModel::A)
      .def_readonly("B", &ContinuousModel::B)
      .def_readonly("C", &ContinuousModel::C)
      .def_readonly("Q", &ContinuousModel::Q)
      .def_readonly("R", &ContinuousModel::R)
      .def_readonly("m0", &ContinuousModel::m0)
      .def_readonly("P0", &ContinuousModel::P0)
      .def("process_noise", &ContinuousModel::ProcessNoise);
  m.def(
      "sampled_model", [](const ContinuousModel& cm, double T, int n) { return SampledModel(cm, T, n); },
      py::arg("model"), py::arg("T"), py::arg("n"),
      "The model sampled at t_i = i T / n (augmented state [z; int z], exact) as a kfx.Model.");
  m.def(
      "sampled_model_at", [](const ContinuousModel& cm, const std::vector<double>& t) { return SampledModel(cm, t); },
      py::arg("model"), py::arg("times"));
  m.def(
      "sampled_filter_covariance",
      [](const ContinuousModel& cm, double T, int n) { return SampledFilterCovariance(cm, T, n); }, py::arg("model"),
      py::arg("T"), py::arg("n"), py::call_guard<py::gil_scoped_release>(),
      "P_{T,n}: the sampled filter's error covariance of z(T).");
  m.def("kalman_bucy_covariance", &KalmanBucyCovariance, py::arg("model"), py::arg("T"),
        py::call_guard<py::gil_scoped_release>(),
        "P_c(T) of the Kalman-Bucy filter (Hamiltonian exponential and doubling).");
  py::class_<CareSolution>(m, "CareSolution")
      .def_readonly("P", &CareSolution::P)
      .def_readonly("gain", &CareSolution::gain, "Kalman-Bucy gain K = (E P C^T + S) R^{-1} (n, m)")
      .def_readonly("closed_loop_max_real", &CareSolution::closed_loop_max_real)
      .def_readonly("refinement_steps", &CareSolution::refinement_steps)
      .def_readonly("summary", &CareSolution::summary);
  m.def("solve_filter_care", py::overload_cast<const ContinuousModel&>(&SolveFilterCare), py::arg("model"),
        py::call_guard<py::gil_scoped_release>(),
        "CARE A P + P A^T + B Q B^T - P C^T R^{-1} C P = 0 (SLICOT SB02OD); Kalman-Bucy gain K = P C^T R^{-1}. "
        "Or, from matrices, the filter CARE with a cross term S and a descriptor E.");
  m.def(
      "solve_filter_care",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& R,
         const std::optional<Eigen::MatrixXd>& S, const std::optional<Eigen::MatrixXd>& E) {
        const Eigen::MatrixXd none(0, 0);
        py::gil_scoped_release release;
        return SolveFilterCare(A, C, Q, R, S ? *S : none, E ? *E : none);
      },
      py::arg("A"), py::arg("C"), py::arg("Q"), py::arg("R"), py::arg("S") = py::none(), py::arg("E") = py::none(),
      "Filter CARE A P E^T + E P A^T + Q - (E P C^T + S) R^{-1} (C P E^T + S^T) = 0 (S = None: no cross term, "
      "E = None: identity), the dual of scipy's solve_continuous_are(A.T, C.T, Q, R, e=E.T, s=S) and "
      "python-control's care(A.T, C.T, Q, R, S, E.T) (its G is gain.T); gain K = (E P C^T + S) R^{-1}. SLICOT "
      "SB02OD with L = S (after E^{-1} when E is given). [[Q, S], [S^T, R]] must be PSD, R PD, E nonsingular. "
      "Numerical failures are in .summary.termination, never raised.");
  m.def(
      "simulate_continuous",
      [](const ContinuousModel& cm, double T, int N, std::uint64_t seed) {
        ContinuousTrajectory t = SimulateContinuous(cm, T, N, seed);
        return py::make_tuple(Eigen::Map<Eigen::VectorXd>(t.t.data(), static_cast<Eigen::Index>(t.t.size())).eval(),
                              t.z, t.dy);
      },
      py::arg("model"), py::arg("T"), py::arg("N"), py::arg("seed") = 1,
      "Exact simulation on t_i = i T / N: returns (t (N+1,), z (N+1, p), dy (N, r)).");
  m.def("sampled_filter_estimate", &SampledFilterEstimate, py::arg("model"), py::arg("T"), py::arg("dy"));
  m.def(
      "run_kalman_bucy",
      [](const ContinuousModel& cm, double T, const TimeSeries& dy, int substeps) {
        KalmanBucyRun r = RunKalmanBucy(cm, T, dy, substeps);
        return py::make_tuple(r.z_hat, r.P);
      },
      py::arg("model"), py::arg("T"), py::arg("dy"), py::arg("substeps") = 2, "Returns (z_hat(T), P_c(T)).");
  py::class_<SamplingBounds>(m, "SamplingBounds")
      .def_readonly("theorem1", &SamplingBounds::theorem1)
      .def_readonly("theorem2", &SamplingBounds::theorem2)
      .def_readonly("theorem2_proof", &SamplingBounds::theorem2_proof)
      .def_readonly("theorem3", &SamplingBounds::theorem3)
      .def_readonly("theorem4", &SamplingBounds::theorem4)
      .def_readonly("corollary1", &SamplingBounds::corollary1);
  py::class_<ConvergencePoint>(m, "ConvergencePoint")
      .def_readonly("n", &ConvergencePoint::n)
      .def_readonly("tr_P", &ConvergencePoint::tr_P)
      .def_readonly("err", &ConvergencePoint::err)
      .def_readonly("bounds", &ConvergencePoint::bounds);
  py::class_<ConvergenceStudy>(m, "ConvergenceStudy")
      .def_readonly("tr_Pc", &ConvergenceStudy::tr_Pc)
      .def_readonly("points", &ConvergenceStudy::points)
      .def_readonly("rate", &ConvergenceStudy::rate);
  m.def(
      "study_convergence",
      [](const ContinuousModel& cm, double T, std::vector<int> n_values, int rate_min_n, const py::object& progress) {
        ConvergenceStudyOptions o;
        o.n_values = std::move(n_values);
        o.rate_min_n = rate_min_n;
        LongCall call(progress);
        o.progress = call.callback();
        return call.Run([&] { return StudyConvergence(cm, T, o); });
      },
      py::arg("model"), py::arg("T"), py::arg("n_values") = std::vector<int>{1, 2, 4, 8, 16, 32, 64, 128, 256},
      py::arg("rate_min_n") = 16, py::arg("progress") = py::none(),
      (std::string("003: err(n) = tr P_{T,n} - tr P_c(T) for each n, the bounds of Theorems 1-4 and the fitted "
                   "rate; progress counts the values of n.") +
       kProgressDoc)
          .c_str());
  m.def("wave_modal_model", &WaveModalModel, py::arg("sigma2"), py::arg("d"), py::arg("R"),
        "003 Example 1: the wave equation in dyadic modes.");
  m.def("log_log_slope", &LogLogSlope, py::arg("x"), py::arg("y"), py::arg("x_min"));
}

}  // namespace kfx::python
