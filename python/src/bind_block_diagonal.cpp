// kfx._core, paper 004: many subsystems coupled by a low-dimensional input: the coupled system, the
// block-diagonal, banded and full filters, steady states and identical subsystems
// (include/kfx/block_diagonal.hpp).
#include <algorithm>
#include <cstdint>
#include <string>

#include "bindings.hpp"
#include "kfx/block_diagonal.hpp"
#include "kfx/enum_text.hpp"
#include "long_call.hpp"

namespace kfx::python {

namespace {

CoupledFilterKind ParseKind(const std::string& s) { return ParseEnum<CoupledFilterKind>("kind", s); }

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// A (rows, cols) array (one block for all filters) or an (n, rows, cols) one (a block per filter), packed
// rows x (n cols) as in include/kfx/block_diagonal.hpp.
Eigen::MatrixXd PackBlocks(const char* name, const Array& a, Eigen::Index n) {
  if (a.ndim() == 2) {
    Eigen::MatrixXd m(a.shape(0), a.shape(1));
    for (Eigen::Index p = 0; p < m.rows(); ++p)
      for (Eigen::Index q = 0; q < m.cols(); ++q) m(p, q) = a.at(p, q);
    return m;
  }
  if (a.ndim() != 3 || a.shape(0) != n) {
    throw Error(std::string(name) + ": expected a (rows, cols) array for all filters or (" + std::to_string(n) +
                ", rows, cols), one per filter; got " + std::to_string(a.ndim()) + " dimensions" +
                (a.ndim() == 3 ? " with " + std::to_string(a.shape(0)) + " blocks" : ""));
  }
  const Eigen::Index rows = a.shape(1), cols = a.shape(2);
  Eigen::MatrixXd m(rows, n * cols);
  const double* src = a.data();
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index p = 0; p < rows; ++p)
      for (Eigen::Index q = 0; q < cols; ++q) m(p, i * cols + q) = src[(i * rows + p) * cols + q];
  return m;
}

// filter_many's out=: the caller's array itself (no copy), checked: float64, C-contiguous, writeable,
// (T, n, c), apart from zs. None: a fresh array.
py::array OutputArray(const py::object& out, Eigen::Index T, Eigen::Index n, Eigen::Index c, const Array& zs) {
  if (out.is_none()) return py::array_t<double>({T, n, c});
  const std::string want = "a writeable C-contiguous float64 array of shape (" + std::to_string(T) + ", " +
                           std::to_string(n) + ", " + std::to_string(c) + ")";
  if (!py::isinstance<py::array>(out)) {
    throw Error("out: expected " + want + ", got " + py::str(py::type::of(out).attr("__name__")).cast<std::string>());
  }
  auto a = py::reinterpret_borrow<py::array>(out);
  if (!a.dtype().is(py::dtype::of<double>())) {
    throw Error("out: expected " + want + ", got dtype " + py::str(a.dtype()).cast<std::string>());
  }
  if (a.ndim() != 3 || a.shape(0) != T || a.shape(1) != n || a.shape(2) != c) {
    std::string shape;
    for (py::ssize_t k = 0; k < a.ndim(); ++k) shape += (k ? ", " : "") + std::to_string(a.shape(k));
    throw Error("out: expected " + want + ", got shape (" + shape + ")");
  }
  if (!(a.flags() & py::array::c_style)) throw Error("out: expected " + want + ", got a non-contiguous array");
  if (!a.writeable()) throw Error("out: expected " + want + ", got a read-only array");
  const auto* lo = static_cast<const char*>(a.data());
  const auto* zlo = reinterpret_cast<const char*>(zs.data());
  if (lo < zlo + zs.nbytes() && zlo < lo + a.nbytes()) {
    throw Error("out: expected memory apart from zs, got an array that overlaps it");
  }
  return a;
}

// kfx.filter_many: numpy in, numpy out; the estimates are written straight into the returned array (or
// into out=).
py::tuple FilterManyNumpy(const Array& F, const Array& H, const Array& Q, const Array& R, const Array& x0,
                          const Array& P0, const Array& zs, const py::object& out) {
  if (zs.ndim() != 2 && zs.ndim() != 3) {
    throw Error("zs: expected (T, n) or (T, n, d), got " + std::to_string(zs.ndim()) + " dimensions");
  }
  const Eigen::Index T = zs.shape(0), n = zs.shape(1), d = zs.ndim() == 3 ? zs.shape(2) : 1;
  ManyFilterModel model;
  model.F = PackBlocks("F", F, n);
  model.H = PackBlocks("H", H, n);
  model.Q = PackBlocks("Q", Q, n);
  model.R = PackBlocks("R", R, n);
  model.P0 = PackBlocks("P0", P0, n);
  const Eigen::Index c = model.F.rows();
  if (model.H.rows() != d) {
    throw Error("zs: expected " + std::to_string(model.H.rows()) + " measurements per filter (the rows of H), got " +
                std::to_string(d));
  }
  if (x0.ndim() == 1) {
    model.x0 = Eigen::Map<const Eigen::VectorXd>(x0.data(), x0.shape(0));
  } else if (x0.ndim() == 2 && x0.shape(0) == n) {
    model.x0 = Eigen::Map<const Eigen::MatrixXd>(x0.data(), x0.shape(1), n);  // (n, c) C order = c x n
  } else {
    throw Error("x0: expected (c,) for all filters or (" + std::to_string(n) + ", c)");
  }
  py::array xs = OutputArray(out, T, n, c, zs);
  py::array_t<double> P({n, c, c});
  const Eigen::Map<const TimeSeries> y(zs.data(), T, n * d);
  Eigen::Map<TimeSeries> x(static_cast<double*>(xs.mutable_data()), T, n * c);
  Eigen::MatrixXd P_last;
  {
    py::gil_scoped_release release;
    FilterMany(model, y, x, &P_last);
  }
  std::copy(P_last.data(), P_last.data() + P_last.size(), P.mutable_data());  // symmetric blocks: same layout
  return py::make_tuple(xs, P);
}

// kfx.blockdiag.run_coupled_filter (its own function: BindBlockDiagonal stays under the size limit).
void BindRunCoupledFilter(py::module_& m) {
  m.def(
      "run_coupled_filter",
      [](const CoupledSystem& sys, const std::string& kind, const TimeSeries& y, const py::object& progress,
         double steady_state_tolerance) {
        const CoupledFilterKind k = ParseKind(kind);
        LongCall call(progress);
        CoupledFilterOptions o;
        o.progress = call.callback();
        o.steady_state_tolerance = steady_state_tolerance;
        return call.Run([&] { return RunCoupledFilter(sys, k, y, o); });
      },
      py::arg("system"), py::arg("kind"), py::arg("y"), py::arg("progress") = py::none(),
      py::arg("steady_state_tolerance") = 0.0,
      (std::string("Runs a filter over y (T, n d). kind: 'block-diagonal' (004 eqs. (8)-(17), O(n r^2) per step), "
                   "'block-diagonal-naive', 'banded', 'full'. steady_state_tolerance > 0 (at most 1e-2; "
                   "block-diagonal, time-invariant systems): once a step changes the covariance blocks by at most "
                   "this (relative), the gain is frozen at the fixed point of 004 eq. (19) and the steady-state "
                   "filter runs (several steps per pass over the subsystems; a row of y with a missing value ends "
                   "the freeze); run.steady_state_steps counts its steps. Raises kfx.Error for a tolerance out of "
                   "range or y of the wrong shape.") +
       kProgressDoc)
          .c_str());
}

}  // namespace

void BindBlockDiagonal(py::module_& m) {
  py::class_<CoupledStep>(
      m, "CoupledStep",
      "004: one step of n coupled subsystems, per block (packed: a block-diagonal matrix with "
      "a x b blocks is an a x (n b) array, block i in columns [i b, (i+1) b)). G is (n c, r). Raises kfx.Error "
      "naming the matrix (and block) at fault: shapes, non-finite entries, V_i, U not symmetric "
      "PSD, R_i not symmetric PD.")
      .def(py::init([](Eigen::MatrixXd F, Eigen::MatrixXd H, Eigen::MatrixXd V, Eigen::MatrixXd R, Eigen::MatrixXd G,
                       Eigen::MatrixXd U) {
             CoupledStep s{std::move(F), std::move(H), std::move(V), std::move(R), std::move(G), std::move(U)};
             ValidateCoupledStep(s, s.n(), s.c(), s.d(), s.r());
             return s;
           }),
           py::arg("F"), py::arg("H"), py::arg("V"), py::arg("R"), py::arg("G"), py::arg("U"))
      .def_readonly("F", &CoupledStep::F)
      .def_readonly("H", &CoupledStep::H)
      .def_readonly("V", &CoupledStep::V)
      .def_readonly("R", &CoupledStep::R)
      .def_readonly("G", &CoupledStep::G)
      .def_readonly("U", &CoupledStep::U)
      .def_property_readonly("n", &CoupledStep::n)
      .def_property_readonly("c", &CoupledStep::c)
      .def_property_readonly("d", &CoupledStep::d)
      .def_property_readonly("r", &CoupledStep::r)
      .def("to_dense", &ToDenseStep, "The stacked system as a dense kfx.ModelStep (moderate n).");
  m.def("make_identical_coupled_step", &MakeIdenticalCoupledStep, py::arg("n"), py::arg("F"), py::arg("H"),
        py::arg("V"), py::arg("R"), py::arg("g"), py::arg("U"), "n identical subsystems, G = 1_n (x) g.");
  py::class_<CoupledSystem>(m, "CoupledSystem", "004: a coupled system with prior x_0 ~ N(m0, blockdiag(P0_blocks)).")
      .def(py::init<CoupledStep, Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("step"), py::arg("m0"),
           py::arg("P0_blocks"))
      .def(py::init<std::vector<CoupledStep>, Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("steps"), py::arg("m0"),
           py::arg("P0_blocks"))
      .def_property_readonly("n", &CoupledSystem::n)
      .def_property_readonly("c", &CoupledSystem::c)
      .def_property_readonly("d", &CoupledSystem::d)
      .def_property_readonly("r", &CoupledSystem::r)
      .def_property_readonly("state_dim", &CoupledSystem::state_dim)
      .def_property_readonly("meas_dim", &CoupledSystem::meas_dim)
      .def("to_dense_model", &ToDenseModel);
  py::class_<CoupledRun>(m, "CoupledRun")
      .def_readonly("x_filt", &CoupledRun::x_filt, "(T+1, n c)")
      .def_readonly("coupling", &CoupledRun::coupling, "(T, r): posterior mean of the coupling input")
      .def_readonly("trace", &CoupledRun::trace, "trace of the filter's own covariance, k = 0..T")
      .def_readonly("steady_state_steps", &CoupledRun::steady_state_steps,
                    "steps done on the frozen gain (steady_state_tolerance > 0)")
      .def_readonly("P_filt", &CoupledRun::P_filt,
                    "the filter's own covariance after the last step (packed (c, n c); (n c, n c) for 'full')")
      .def_readonly("coupling_cov", &CoupledRun::coupling_cov, "(r, r): Sigma_u of the last step");
  BindRunCoupledFilter(m);
  m.def(
      "coupled_filter_as_linear_filter",
      [](const CoupledSystem& sys, const std::string& kind, int steps) {
        CoupledFilterOptions o;
        o.steps = steps;
        const CoupledFilterKind k = ParseKind(kind);
        py::gil_scoped_release release;
        return CoupledFilterAsLinearFilter(sys, k, o);
      },
      py::arg("system"), py::arg("kind"), py::arg("steps"),
      "The filter as a kfx.LinearFilter (dense; moderate n) for exact_performance. Raises kfx.Error for an unknown "
      "kind or steps beyond the system's horizon.");
  m.def(
      "simulate_coupled",
      [](const CoupledSystem& sys, int steps, std::uint64_t seed) {
        CoupledTrajectory t;
        {
          py::gil_scoped_release release;
          t = SimulateCoupled(sys, SimulationOptions{steps, seed});
        }
        return py::make_tuple(t.x, t.y, t.u);
      },
      py::arg("system"), py::arg("steps"), py::arg("seed") = 1, "Returns (x (T+1, n c), y (T, n d), u (T, r)).");
  py::class_<BlockDiagonalSteadyState>(m, "BlockDiagonalSteadyState")
      .def_readonly("P_filt", &BlockDiagonalSteadyState::P_filt, "c x (n c) packed P~_+ (004 eq. (19))")
      .def_property_readonly(
          "gain", [](const BlockDiagonalSteadyState& s) { return s.gain.ToDense(); }, "dense (n c, n d) limiting gain")
      .def_readonly("summary", &BlockDiagonalSteadyState::summary);
  m.def(
      "solve_block_diagonal_steady_state",
      [](const CoupledStep& s, int max_iterations, double tolerance) {
        SteadyStateOptions o;
        o.max_iterations = max_iterations;
        o.tolerance = tolerance;
        py::gil_scoped_release release;
        return SolveBlockDiagonalSteadyState(s, o);
      },
      py::arg("step"), py::arg("max_iterations") = 100000, py::arg("tolerance") = 1e-13);
  m.def("block_diagonal_to_dense", &BlockDiagonalToDense, py::arg("blocks"), py::arg("block_cols"));
  m.def("diagonal_blocks", &DiagonalBlocks, py::arg("M"), py::arg("a"), "D{M}: the a x a diagonal blocks, packed.");

  py::class_<KroneckerStructured>(m, "KroneckerStructured", "I_n (x) X + 1 1^T (x) Y")
      .def_readonly("n", &KroneckerStructured::n)
      .def_readonly("X", &KroneckerStructured::X)
      .def_readonly("Y", &KroneckerStructured::Y)
      .def("dense", &KroneckerStructured::Dense)
      .def("diagonal_block", &KroneckerStructured::DiagonalBlock)
      .def("mean_mode", &KroneckerStructured::MeanMode);
  m.def("frobenius_distance", &FrobeniusDistance, py::arg("a"), py::arg("b"));
  py::class_<IdenticalSubsystems>(m, "IdenticalSubsystems")
      .def(py::init([](Eigen::MatrixXd F, Eigen::MatrixXd H, Eigen::MatrixXd V, Eigen::MatrixXd R, Eigen::MatrixXd g,
                       Eigen::MatrixXd U) {
             return IdenticalSubsystems{std::move(F), std::move(H), std::move(V),
                                        std::move(R), std::move(g), std::move(U)};
           }),
           py::arg("F"), py::arg("H"), py::arg("V"), py::arg("R"), py::arg("g"), py::arg("U"))
      .def_readonly("F", &IdenticalSubsystems::F)
      .def_readonly("H", &IdenticalSubsystems::H)
      .def_readonly("V", &IdenticalSubsystems::V)
      .def_readonly("R", &IdenticalSubsystems::R)
      .def_readonly("g", &IdenticalSubsystems::g)
      .def_readonly("U", &IdenticalSubsystems::U);
  py::class_<IdenticalAnalysis>(m, "IdenticalAnalysis")
      .def_readonly("full_P", &IdenticalAnalysis::full_P)
      .def_readonly("uncoupled_P", &IdenticalAnalysis::uncoupled_P)
      .def_readonly("block_P", &IdenticalAnalysis::block_P)
      .def_readonly("banded_P", &IdenticalAnalysis::banded_P)
      .def_readonly("block_gain", &IdenticalAnalysis::block_gain)
      .def_readonly("banded_gain", &IdenticalAnalysis::banded_gain)
      .def_readonly("full_gain", &IdenticalAnalysis::full_gain)
      .def_readonly("block_true", &IdenticalAnalysis::block_true)
      .def_readonly("banded_true", &IdenticalAnalysis::banded_true)
      .def_readonly("full_true", &IdenticalAnalysis::full_true)
      .def_readonly("block_summary", &IdenticalAnalysis::block_summary)
      .def_readonly("summary", &IdenticalAnalysis::summary);
  m.def(
      "analyze_identical_subsystems",
      [](const IdenticalSubsystems& sys, Eigen::Index n) { return AnalyzeIdenticalSubsystems(sys, n); },
      py::arg("system"), py::arg("n"), py::call_guard<py::gil_scoped_release>(),
      "004 Sec. 3.1 for n identical subsystems, exactly, in O(c^3) per iteration for any n.");
  m.def("unknown_input_spectral_radius", &UnknownInputSpectralRadius, py::arg("system"));
  m.def("filter_many", &FilterManyNumpy, py::arg("F"), py::arg("H"), py::arg("Q"), py::arg("R"), py::arg("x0"),
        py::arg("P0"), py::arg("zs"), py::kw_only(), py::arg("out") = py::none(),
        "n independent Kalman filters (004's subsystems with U = 0; docs/python.md). F (c, c) or (n, c, c), H (d, c) "
        "or (n, d, c), Q (c, c) or (n, c, c), R (d, d) or (n, d, d), x0 (c,) or (n, c), P0 (c, c) or (n, c, c): "
        "one for all filters or one per filter; zs (T, n) (d = 1) or (T, n, d), NaN = missing. Returns (xs, P): "
        "xs (T, n, c) the filtered means x_k|k, P (n, c, c) the last P_T|T. out: None (a new xs), or a writeable "
        "C-contiguous float64 (T, n, c) array apart from zs that xs is written into and returned as (no new "
        "allocation and its page faults when the filters run again).");
}

}  // namespace kfx::python
