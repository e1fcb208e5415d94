// kfx._core: the paper methods. 004 block-diagonal (coupled subsystems), 002 mismatch / Patel-Toda
// bounds, 003 continuous time and sampling convergence, 001 reduced-order and subspace estimators,
// 000 subspace filter and the damped wave equation. Every filter here is also available as a
// kfx.LinearFilter so that kfx.exact_performance gives its true error.
#include <cstdint>

#include "bindings.hpp"
#include "kfx/block_diagonal.hpp"
#include "kfx/continuous.hpp"
#include "kfx/damped_wave.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/error.hpp"
#include "kfx/mismatch.hpp"
#include "kfx/reduced_order.hpp"
#include "kfx/sampling_convergence.hpp"
#include "kfx/spring_mass_chain.hpp"
#include "kfx/subspace_filter.hpp"

namespace kfx::python {

namespace {

py::object OptionalFloat(const std::optional<double>& v) {
  return v ? py::object(py::float_(*v)) : py::object(py::none());
}

CoupledFilterKind ParseKind(const std::string& s) { return ParseEnum<CoupledFilterKind>("kind", s); }

TwoStepOutput ParseTwoStepOutput(const std::string& s) { return ParseEnum<TwoStepOutput>("output", s); }

WeightSchedule MakeWeights(const py::object& L) {
  if (py::isinstance<py::array>(L) && L.cast<py::array>().ndim() == 2) return WeightSchedule(L.cast<Eigen::MatrixXd>());
  if (py::isinstance<py::array>(L) || py::isinstance<py::list>(L) || py::isinstance<py::tuple>(L))
    return WeightSchedule(MatrixList(L, "L"));
  return WeightSchedule(L.cast<Eigen::MatrixXd>());
}

void BindBlockDiagonal(py::module_& m) {
  py::class_<CoupledStep>(m, "CoupledStep",
                          "004: one step of n coupled subsystems, per block (packed: a block-diagonal matrix with "
                          "a x b blocks is an a x (n b) array, block i in columns [i b, (i+1) b)). G is (n c, r).")
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
      .def_readonly("trace", &CoupledRun::trace, "trace of the filter's own covariance, k = 0..T");
  m.def(
      "run_coupled_filter",
      [](const CoupledSystem& sys, const std::string& kind, const TimeSeries& y) {
        const CoupledFilterKind k = ParseKind(kind);
        py::gil_scoped_release release;
        return RunCoupledFilter(sys, k, y);
      },
      py::arg("system"), py::arg("kind"), py::arg("y"),
      "Runs a filter over y (T, n d). kind: 'block-diagonal' (004 eqs. (8)-(17), O(n r^2) per step), "
      "'block-diagonal-naive', 'banded', 'full'.");
  m.def(
      "coupled_filter_as_linear_filter",
      [](const CoupledSystem& sys, const std::string& kind, int steps) {
        CoupledFilterOptions o;
        o.steps = steps;
        return CoupledFilterAsLinearFilter(sys, ParseKind(kind), o);
      },
      py::arg("system"), py::arg("kind"), py::arg("steps"),
      "The filter as a kfx.LinearFilter (dense; moderate n) for exact_performance.");
  m.def(
      "simulate_coupled",
      [](const CoupledSystem& sys, int steps, std::uint64_t seed) {
        CoupledTrajectory t = SimulateCoupled(sys, SimulationOptions{steps, seed});
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
      py::arg("system"), py::arg("n"),
      "004 Sec. 3.1 for n identical subsystems, exactly, in O(c^3) per iteration for any n.");
  m.def("unknown_input_spectral_radius", &UnknownInputSpectralRadius, py::arg("system"));
}

void BindMismatch(py::module_& m) {
  py::class_<ModelingErrors>(m, "ModelingErrors", "002: Delta = model - true; None = no error.")
      .def(py::init([](std::optional<Eigen::MatrixXd> A, std::optional<Eigen::MatrixXd> C,
                       std::optional<Eigen::MatrixXd> Q, std::optional<Eigen::MatrixXd> R) {
             return ModelingErrors{OrEmpty(A), OrEmpty(C), OrEmpty(Q), OrEmpty(R)};
           }),
           py::arg("A") = py::none(), py::arg("C") = py::none(), py::arg("Q") = py::none(), py::arg("R") = py::none())
      .def_readonly("A", &ModelingErrors::A)
      .def_readonly("C", &ModelingErrors::C)
      .def_readonly("Q", &ModelingErrors::Q)
      .def_readonly("R", &ModelingErrors::R);
  m.def("apply_modeling_errors", &ApplyModelingErrors, py::arg("design"), py::arg("errors"),
        "The true step: A = A_M - dA, C = C_M - dC, Q = Q_M - dQ, R = R_M - dR.");
  m.def("modeling_errors_between", &ModelingErrorsBetween, py::arg("design"), py::arg("truth"));
  py::class_<StationaryMismatch>(m, "StationaryMismatch")
      .def_readonly("summary", &StationaryMismatch::summary,
                    "termination 'converged', 'unstable' (true system or filter), the design DARE's, or 'failed'")
      .def_readonly("filter_gain", &StationaryMismatch::filter_gain)
      .def_readonly("P", &StationaryMismatch::P, "E[x~ x~^T], the true error covariance")
      .def_readonly("V", &StationaryMismatch::V)
      .def_readonly("U", &StationaryMismatch::U)
      .def_readonly("trace", &StationaryMismatch::trace)
      .def_readonly("true_spectral_radius", &StationaryMismatch::true_spectral_radius)
      .def_readonly("filter_spectral_radius", &StationaryMismatch::filter_spectral_radius);
  m.def(
      "stationary_mismatched_covariance",
      [](const ModelStep& design, const ModelStep& truth, std::optional<Eigen::MatrixXd> gain) {
        MismatchOptions o;
        o.filter_gain = OrEmpty(gain);
        return StationaryMismatchedCovariance(design, truth, o);
      },
      py::arg("design"), py::arg("truth"), py::arg("filter_gain") = py::none(),
      "002 (15)-(17): the stationary true error of the filter designed on `design`, run on `truth`.");
  m.def(
      "mismatched_covariance_sequence",
      [](const Model& design, const Model& truth, int steps) {
        MismatchSequenceOptions o;
        o.steps = steps;
        MismatchSequence s = MismatchedCovarianceSequence(design, truth, o);
        py::dict d;
        d["P"] = Stack(s.P);
        d["V"] = Stack(s.V);
        d["U"] = Stack(s.U);
        d["filter_gain"] = Stack(s.filter_gain, 1);
        d["trace"] = s.trace;
        return d;
      },
      py::arg("design"), py::arg("truth"), py::arg("steps"),
      "002 (15)-(19) over k = 0..T: dict with P, V, U (T+1, n, n), filter_gain (T, n, m), trace (T+1,).");
  py::class_<ErrorRanges>(m, "ErrorRanges", "002 Sec. 6: |Delta X_ij| <= X(i, j); None = exact.")
      .def(py::init([](std::optional<Eigen::MatrixXd> A, std::optional<Eigen::MatrixXd> C,
                       std::optional<Eigen::MatrixXd> Q, std::optional<Eigen::MatrixXd> R) {
             return ErrorRanges{OrEmpty(A), OrEmpty(C), OrEmpty(Q), OrEmpty(R)};
           }),
           py::arg("A") = py::none(), py::arg("C") = py::none(), py::arg("Q") = py::none(), py::arg("R") = py::none())
      .def_readonly("A", &ErrorRanges::A)
      .def_readonly("C", &ErrorRanges::C)
      .def_readonly("Q", &ErrorRanges::Q)
      .def_readonly("R", &ErrorRanges::R);
  m.def(
      "patel_toda_bounds",
      [](const ModelStep& design, const ErrorRanges& ranges, std::optional<Eigen::MatrixXd> gain) {
        MismatchOptions o;
        o.filter_gain = OrEmpty(gain);
        PatelTodaBounds b = ComputePatelTodaBounds(design, ranges, o);
        py::dict d;
        d["summary"] = b.summary;
        d["pi3"] = OptionalFloat(b.pi3);
        d["pi4"] = OptionalFloat(b.pi4);
        d["pi5"] = OptionalFloat(b.pi5);
        d["pi5_printed"] = OptionalFloat(b.pi5_printed);
        d["pi6"] = OptionalFloat(b.pi6);
        d["nominal_trace"] = b.terms.nominal_trace;
        d["adjoint_norm"] = b.terms.adjoint_norm;
        d["filter_gain"] = b.terms.filter_gain;
        d["norm_A"] = b.norms.A;
        d["norm_C"] = b.norms.C;
        d["norm_Q"] = b.norms.Q;
        d["norm_R"] = b.norms.R;
        return d;
      },
      py::arg("design"), py::arg("ranges"), py::arg("filter_gain") = py::none(),
      "002 Theorems 3-6 for the ranges (pi3, pi4: plant exact; pi5, pi6: noise exact; None where a theorem "
      "does not apply). pi5 uses the corrected Lemma bound, pi5_printed (41) as printed. 'summary': a "
      "kfx.Summary (when the design's DARE fails, every bound is None and the summary says why).");
  m.def(
      "theorem1_bound",
      [](const ModelStep& design, const ModelingErrors& errors) {
        Theorem1Result r = Theorem1Bound(design, errors);
        py::dict d;
        d["summary"] = r.summary;
        d["pi1"] = r.pi1;
        d["D_norm"] = r.D_norm;
        d["identity_trace"] = r.identity_trace;
        d["trace"] = r.exact.trace;
        return d;
      },
      py::arg("design"), py::arg("errors"),
      "002 Theorem 1: tr P <= pi1 for known errors (26 corrected); 'summary' says whether it exists.");
  m.def("theorem2_bound", &Theorem2Bound, py::arg("truth"), "002 Theorem 2: tr P_F >= pi2 (optimal filter).");
  m.def(
      "search_error_box",
      [](const ModelStep& design, const ErrorRanges& ranges, bool refine) {
        ErrorBoxSearchOptions so;
        so.refine = refine;
        ErrorBoxSearch s;
        {
          py::gil_scoped_release release;
          s = SearchErrorBox(design, ranges, MismatchOptions(), so);
        }
        py::dict d;
        d["summary"] = s.summary;
        d["free_entries"] = s.free_entries;
        d["least_upper"] = s.least_upper.found ? py::object(py::float_(s.least_upper.value)) : py::object(py::none());
        d["greatest_lower"] =
            s.greatest_lower.found ? py::object(py::float_(s.greatest_lower.value)) : py::object(py::none());
        d["least_upper_truth"] = s.least_upper.truth;
        d["greatest_lower_truth"] = s.greatest_lower.truth;
        return d;
      },
      py::arg("design"), py::arg("ranges"), py::arg("refine") = true,
      "002 Sec. 6: the largest true tr P of the design's filter and the smallest optimal tr P_F over the box.");
}

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
      py::arg("T"), py::arg("n"), "P_{T,n}: the sampled filter's error covariance of z(T).");
  m.def("kalman_bucy_covariance", &KalmanBucyCovariance, py::arg("model"), py::arg("T"),
        "P_c(T) of the Kalman-Bucy filter (Hamiltonian exponential and doubling).");
  py::class_<CareSolution>(m, "CareSolution")
      .def_readonly("P", &CareSolution::P)
      .def_readonly("closed_loop_max_real", &CareSolution::closed_loop_max_real)
      .def_readonly("refinement_steps", &CareSolution::refinement_steps)
      .def_readonly("summary", &CareSolution::summary);
  m.def("solve_filter_care", &SolveFilterCare, py::arg("model"),
        "CARE A P + P A^T + B Q B^T - P C^T R^{-1} C P = 0 (SLICOT SB02OD); Kalman-Bucy gain K = P C^T R^{-1}.");
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
      [](const ContinuousModel& cm, double T, std::vector<int> n_values, int rate_min_n) {
        ConvergenceStudyOptions o;
        o.n_values = std::move(n_values);
        o.rate_min_n = rate_min_n;
        py::gil_scoped_release release;
        return StudyConvergence(cm, T, o);
      },
      py::arg("model"), py::arg("T"), py::arg("n_values") = std::vector<int>{1, 2, 4, 8, 16, 32, 64, 128, 256},
      py::arg("rate_min_n") = 16,
      "003: err(n) = tr P_{T,n} - tr P_c(T) for each n, the bounds of Theorems 1-4 and the fitted rate.");
  m.def("wave_modal_model", &WaveModalModel, py::arg("sigma2"), py::arg("d"), py::arg("R"),
        "003 Example 1: the wave equation in dyadic modes.");
  m.def("log_log_slope", &LogLogSlope, py::arg("x"), py::arg("y"), py::arg("x_min"));
}

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
      "001 Sec. II: the one-step reduced-order filter (offline part).");
  m.def("reduced_order_one_step_as_linear_filter", &ReducedOrderOneStepAsLinearFilter, py::arg("schedule"),
        py::arg("L"), "The one-step filter as a kfx.LinearFilter (output L_k^+ xi_k).");
  m.def(
      "reduced_order_two_step",
      [opts](const Model& model, const WeightSchedule& L, int steps, double tol) {
        return ComputeReducedOrderTwoStep(model, L, opts(steps, tol));
      },
      py::arg("model"), py::arg("L"), py::arg("steps") = -1, py::arg("rank_tolerance") = 1e-10,
      "001 Sec. III: the two-step (data assimilation + forecast) filter.");
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
      py::arg("truth"), py::arg("filter"), py::arg("L"), py::arg("steps"),
      "J_k = E|L_k x_k - L_k O_k z_k|^2, k = 0..T, from the exact-performance engine.");
  m.def(
      "kalman_costs",
      [](const Model& model, const WeightSchedule& L, int steps) {
        ReducedOrderOptions o;
        o.steps = steps;
        KalmanWeightedCosts c = KalmanCosts(model, L, o);
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
      py::arg("rank_tolerance") = 1e-10, "001 Sec. IV (4.10)-(4.13): the one-step subspace estimator.");
  m.def("subspace_one_step_as_linear_filter", &SubspaceOneStepAsLinearFilter, py::arg("schedule"), py::arg("T"),
        py::arg("n_r"));
  m.def(
      "subspace_two_step",
      [opts](const Model& model, const Eigen::MatrixXd& T, Eigen::Index n_r, const WeightSchedule& L, int steps,
             double tol) { return ComputeSubspaceTwoStep(model, T, n_r, L, opts(steps, tol)); },
      py::arg("model"), py::arg("T"), py::arg("n_r"), py::arg("L"), py::arg("steps") = -1,
      py::arg("rank_tolerance") = 1e-10, "001 (4.16)-(4.20): the two-step subspace estimator.");
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
         double tolerance, bool rde_check, bool stationary_prior) {
        SubspaceFilterOptions o;
        o.steps = steps;
        o.max_steps = max_steps;
        o.tolerance = tolerance;
        o.rde_check = rde_check;
        o.stationary_prior = stationary_prior;
        py::gil_scoped_release release;
        return ComputeSubspaceFilterSchedule(truth, S0, sub, o);
      },
      py::arg("truth"), py::arg("S0"), py::arg("subspace"), py::arg("steps") = -1, py::arg("max_steps") = 20000,
      py::arg("tolerance") = 1e-11, py::arg("rde_check") = false, py::arg("stationary_prior") = false,
      "000 Algorithm 2.3 (offline part): gains K_k and output maps Q_k until convergence (or `steps`).");
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

}  // namespace

void BindPapers(py::module_& m) {
  BindBlockDiagonal(m);
  BindMismatch(m);
  BindContinuous(m);
  BindReducedOrder(m);
  BindSubspaceFilter(m);
}

}  // namespace kfx::python
