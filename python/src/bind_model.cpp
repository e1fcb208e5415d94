// kfx._core: the model (ModelStep, Model), seeded simulation and exact discretization
// (include/kfx/model.hpp, simulation.hpp, discretize.hpp).
#include <cstdint>
#include <optional>

#include "bindings.hpp"
#include "kfx/discretize.hpp"
#include "kfx/error.hpp"
#include "kfx/model.hpp"
#include "kfx/simulation.hpp"
#include "long_call.hpp"

namespace kfx::python {

void BindModel(py::module_& m) {
  py::class_<ModelStep>(m, "ModelStep",
                        "The matrices of one step: x_k = A x_{k-1} + w_k, w_k ~ N(0, Q) (or w_k = B u_k, u_k ~ "
                        "N(0, U), Q = B U B^T); y_k = C x_k + v_k, v_k ~ N(0, R).")
      .def(py::init([](Eigen::MatrixXd A, Eigen::MatrixXd C, std::optional<Eigen::MatrixXd> Q, Eigen::MatrixXd R,
                       std::optional<Eigen::MatrixXd> B, std::optional<Eigen::MatrixXd> U) {
             if (B || U) {
               if (!B || !U) throw Error("B, U: expected both (noise input w = B u, u ~ N(0, U)) or neither");
               if (Q) throw Error("Q: expected None when B and U are given (Q = B U B^T)");
               ModelStep s =
                   MakeStepWithNoiseInput(std::move(A), std::move(*B), std::move(*U), std::move(C), std::move(R));
               ValidateStep(s, s.A.rows(), s.C.rows());
               return s;
             }
             if (!Q) throw Error("Q: expected the process-noise covariance (or B and U)");
             ModelStep s = MakeStep(std::move(A), std::move(C), std::move(*Q), std::move(R));
             ValidateStep(s, s.A.rows(), s.C.rows());
             return s;
           }),
           py::arg("A"), py::arg("C"), py::arg("Q") = py::none(), py::arg("R"), py::arg("B") = py::none(),
           py::arg("U") = py::none(), "Validated step (raises kfx.Error naming the matrix at fault).")
      .def_readonly("A", &ModelStep::A)
      .def_readonly("C", &ModelStep::C)
      .def_readonly("Q", &ModelStep::Q)
      .def_readonly("R", &ModelStep::R)
      .def_readonly("B", &ModelStep::B)
      .def_readonly("U", &ModelStep::U)
      .def_property_readonly("state_dim", &ModelStep::state_dim)
      .def_property_readonly("meas_dim", &ModelStep::meas_dim);

  py::class_<Model>(m, "Model",
                    "A validated discrete-time model x_k = A_k x_{k-1} + w_k, y_k = C_k x_k + v_k, x_0 ~ N(m0, P0); "
                    "the first measurement is y_1. Time-invariant (one ModelStep) or time-varying (a list).")
      .def(py::init([](const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, std::optional<Eigen::MatrixXd> Q,
                       const Eigen::MatrixXd& R, Eigen::VectorXd m0, Eigen::MatrixXd P0,
                       std::optional<Eigen::MatrixXd> B, std::optional<Eigen::MatrixXd> U) {
             ModelStep s;
             if (B || U) {
               if (!B || !U) throw Error("B, U: expected both (noise input w = B u, u ~ N(0, U)) or neither");
               if (Q) throw Error("Q: expected None when B and U are given (Q = B U B^T)");
               s = MakeStepWithNoiseInput(A, *B, *U, C, R);
             } else {
               if (!Q) throw Error("Q: expected the process-noise covariance (or B and U)");
               s = MakeStep(A, C, *Q, R);
             }
             return Model(std::move(s), std::move(m0), std::move(P0));
           }),
           py::arg("A"), py::arg("C"), py::arg("Q") = py::none(), py::arg("R"), py::arg("m0"), py::arg("P0"),
           py::arg("B") = py::none(), py::arg("U") = py::none(), "Time-invariant model.")
      .def(py::init<ModelStep, Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("step"), py::arg("m0"), py::arg("P0"))
      .def(py::init<std::vector<ModelStep>, Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("steps"), py::arg("m0"),
           py::arg("P0"), "Time-varying model over k = 1..len(steps) (steps[k-1] is step k).")
      .def_property_readonly("state_dim", &Model::state_dim)
      .def_property_readonly("meas_dim", &Model::meas_dim)
      .def_property_readonly("time_invariant", &Model::time_invariant)
      .def_property_readonly("horizon", &Model::horizon, "Steps defined (-1: unbounded).")
      .def_property_readonly("m0", &Model::m0)
      .def_property_readonly("P0", &Model::P0)
      .def(
          "step", [](const Model& mo, int k) { return *mo.step(k); }, py::arg("k"), "The matrices of step k >= 1.")
      .def("with_prior", &Model::WithPrior, py::arg("m0"), py::arg("P0"));

  m.def(
      "simulate",
      [](const Model& model, int steps, std::uint64_t seed, const py::object& progress) {
        LongCall call(progress);
        SimulationOptions o{steps, seed};
        o.progress = call.callback();
        Trajectory t = call.Run([&] { return Simulate(model, o); });
        return py::make_tuple(std::move(t.x), std::move(t.y));
      },
      py::arg("model"), py::arg("steps") = -1, py::arg("seed") = 1, py::arg("progress") = py::none(),
      (std::string("Draws x_0 ~ N(m0, P0), then x_k, y_k for k = 1..steps. Returns (x (T+1, n), y (T, m)); the "
                   "same seed gives the same numbers on every platform (and as `kfx simulate`).") +
       kProgressDoc)
          .c_str());
  m.def("matrix_exponential", &MatrixExponential, py::arg("M"), py::call_guard<py::gil_scoped_release>());
  m.def(
      "discretize_zoh",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, double dt) {
        ZohDiscretization d;
        {
          py::gil_scoped_release release;
          d = DiscretizeZoh(A, B, dt);
        }
        return py::make_tuple(d.Ad, d.Bd);
      },
      py::arg("A"), py::arg("B"), py::arg("dt"), "Zero-order hold: (Ad, Bd).");
  m.def(
      "discretize_process_noise",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& Qc, double dt) {
        NoiseDiscretization d;
        {
          py::gil_scoped_release release;
          d = DiscretizeProcessNoise(A, Qc, dt);
        }
        return py::make_tuple(d.Ad, d.Qd);
      },
      py::arg("A"), py::arg("Qc"), py::arg("dt"), "Van Loan: (Ad, Qd = int_0^dt e^{As} Qc e^{A^T s} ds).");
}

}  // namespace kfx::python
