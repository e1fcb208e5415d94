// kfx._core: the model (ModelStep, Model), seeded simulation and exact discretization
// (include/kfx/model.hpp, simulation.hpp, discretize.hpp).
#include <cstdint>
#include <optional>

#include "bindings.hpp"
#include "kfx/discretize.hpp"
#include "kfx/error.hpp"
#include "kfx/model.hpp"
#include "kfx/simulation.hpp"
#include "kfx/validation.hpp"
#include "long_call.hpp"

namespace kfx::python {

namespace {

using OptMatrix = std::optional<Eigen::MatrixXd>;

// The known-input matrices G, D and the cross-covariance S (issue 22), None = none.
void SetExtras(ModelStep& s, OptMatrix G, OptMatrix D, OptMatrix S) {
  if (G) s.G = std::move(*G);
  if (D) s.D = std::move(*D);
  if (S) s.S = std::move(*S);
}

}  // namespace

void BindModel(py::module_& m) {
  py::class_<ModelStep>(m, "ModelStep",
                        "The matrices of one step: x_k = A x_{k-1} + G g_k + w_k, w_k ~ N(0, Q) (or w_k = B u_k, u_k "
                        "~ N(0, U), Q = B U B^T); y_k = C x_k + D g_k + v_k, v_k ~ N(0, R), cov(w_k, v_k) = S. g_k is "
                        "a known input (G, D None: none); S None: 0.")
      .def(py::init([](Eigen::MatrixXd A, Eigen::MatrixXd C, OptMatrix Q, Eigen::MatrixXd R, OptMatrix B, OptMatrix U,
                       OptMatrix G, OptMatrix D, OptMatrix S) {
             ModelStep s;
             if (B || U) {
               if (!B || !U) throw Error("B, U: expected both (noise input w = B u, u ~ N(0, U)) or neither");
               if (Q) throw Error("Q: expected None when B and U are given (Q = B U B^T)");
               s = MakeStepWithNoiseInput(std::move(A), std::move(*B), std::move(*U), std::move(C), std::move(R));
             } else {
               if (!Q) throw Error("Q: expected the process-noise covariance (or B and U)");
               s = MakeStep(std::move(A), std::move(C), std::move(*Q), std::move(R));
             }
             SetExtras(s, std::move(G), std::move(D), std::move(S));
             RequireSquare("A", s.A);
             ValidateStep(s, s.A.rows(), s.C.rows());
             return s;
           }),
           py::arg("A"), py::arg("C"), py::arg("Q") = py::none(), py::arg("R"), py::arg("B") = py::none(),
           py::arg("U") = py::none(), py::arg("G") = py::none(), py::arg("D") = py::none(), py::arg("S") = py::none(),
           "Validated step (raises kfx.Error naming the matrix at fault).")
      .def_readonly("A", &ModelStep::A)
      .def_readonly("C", &ModelStep::C)
      .def_readonly("Q", &ModelStep::Q)
      .def_readonly("R", &ModelStep::R)
      .def_readonly("B", &ModelStep::B)
      .def_readonly("U", &ModelStep::U)
      .def_readonly("G", &ModelStep::G, "n x q known-input matrix (0 x 0: none)")
      .def_readonly("D", &ModelStep::D, "m x q feedthrough of the known input (0 x 0: none)")
      .def_readonly("S", &ModelStep::S, "n x m cross-covariance E[w_k v_k^T] (0 x 0: 0)")
      .def_property_readonly("input_dim", &ModelStep::input_dim)
      .def_property_readonly("state_dim", &ModelStep::state_dim)
      .def_property_readonly("meas_dim", &ModelStep::meas_dim);

  py::class_<Model>(m, "Model",
                    "A validated discrete-time model x_k = A_k x_{k-1} + G_k g_k + w_k, y_k = C_k x_k + D_k g_k + v_k, "
                    "cov(w_k, v_k) = S_k, x_0 ~ N(m0, P0); the first measurement is y_1; g_k a known input. "
                    "Time-invariant (one ModelStep) or time-varying (a list).")
      .def(py::init([](const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, OptMatrix Q, const Eigen::MatrixXd& R,
                       Eigen::VectorXd m0, Eigen::MatrixXd P0, OptMatrix B, OptMatrix U, OptMatrix G, OptMatrix D,
                       OptMatrix S) {
             ModelStep s;
             if (B || U) {
               if (!B || !U) throw Error("B, U: expected both (noise input w = B u, u ~ N(0, U)) or neither");
               if (Q) throw Error("Q: expected None when B and U are given (Q = B U B^T)");
               s = MakeStepWithNoiseInput(A, *B, *U, C, R);
             } else {
               if (!Q) throw Error("Q: expected the process-noise covariance (or B and U)");
               s = MakeStep(A, C, *Q, R);
             }
             SetExtras(s, std::move(G), std::move(D), std::move(S));
             return Model(std::move(s), std::move(m0), std::move(P0));
           }),
           py::arg("A"), py::arg("C"), py::arg("Q") = py::none(), py::arg("R"), py::arg("m0"), py::arg("P0"),
           py::arg("B") = py::none(), py::arg("U") = py::none(), py::arg("G") = py::none(), py::arg("D") = py::none(),
           py::arg("S") = py::none(), "Time-invariant model.")
      .def(py::init<ModelStep, Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("step"), py::arg("m0"), py::arg("P0"))
      .def(py::init<std::vector<ModelStep>, Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("steps"), py::arg("m0"),
           py::arg("P0"), "Time-varying model over k = 1..len(steps) (steps[k-1] is step k).")
      .def_property_readonly("state_dim", &Model::state_dim)
      .def_property_readonly("meas_dim", &Model::meas_dim)
      .def_property_readonly("time_invariant", &Model::time_invariant)
      .def_property_readonly("input_dim", &Model::input_dim, "q, the length of the known input g_k (0: none)")
      .def_property_readonly("horizon", &Model::horizon, "Steps defined (-1: unbounded).")
      .def_property_readonly("m0", &Model::m0)
      .def_property_readonly("P0", &Model::P0)
      .def(
          "step", [](const Model& mo, int k) { return *mo.step(k); }, py::arg("k"), "The matrices of step k >= 1.")
      .def("with_prior", &Model::WithPrior, py::arg("m0"), py::arg("P0"));

  m.def(
      "simulate",
      [](const Model& model, int steps, std::uint64_t seed, const py::object& progress,
         std::optional<TimeSeries> input) {
        LongCall call(progress);
        SimulationOptions o{steps, seed};
        o.progress = call.callback();
        Trajectory t = call.Run([&] { return Simulate(model, input ? *input : TimeSeries(0, 0), o); });
        return py::make_tuple(std::move(t.x), std::move(t.y));
      },
      py::arg("model"), py::arg("steps") = -1, py::arg("seed") = 1, py::arg("progress") = py::none(),
      py::arg("input") = py::none(),
      (std::string("Draws x_0 ~ N(m0, P0), then x_k, y_k for k = 1..steps. Returns (x (T+1, n), y (T, m)); the "
                   "same seed gives the same numbers on every platform (and as `kfx simulate`). input: the known "
                   "input g (T, q), row k-1 = g_k, for a model with G, D (required then).") +
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
