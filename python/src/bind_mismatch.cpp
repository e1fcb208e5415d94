// kfx._core, paper 002: filters built on a wrong model: modeling errors, the exact true error, the
// Patel-Toda bounds and the worst case over an error box (include/kfx/mismatch.hpp).
#include <optional>

#include "bindings.hpp"
#include "kfx/mismatch.hpp"

namespace kfx::python {

namespace {

py::object OptionalFloat(const std::optional<double>& v) {
  return v ? py::object(py::float_(*v)) : py::object(py::none());
}

void BindMismatchBounds(py::module_& m);

}  // namespace

void BindMismatch(py::module_& m) {
  py::class_<ModelingErrors>(m, "ModelingErrors", "002: Delta = model - true; None = no error.")
      .def(py::init([](std::optional<Eigen::MatrixXd> A, std::optional<Eigen::MatrixXd> C,
                       std::optional<Eigen::MatrixXd> Q, std::optional<Eigen::MatrixXd> R,
                       std::optional<Eigen::MatrixXd> S) {
             return ModelingErrors{OrEmpty(A), OrEmpty(C), OrEmpty(Q), OrEmpty(R), OrEmpty(S)};
           }),
           py::arg("A") = py::none(), py::arg("C") = py::none(), py::arg("Q") = py::none(), py::arg("R") = py::none(),
           py::arg("S") = py::none(), "S: dS = S_M - S_t, the cross-covariance's error (n, m).")
      .def_readonly("S", &ModelingErrors::S)
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
      .def_readonly("trace", &StationaryMismatch::trace, "tr P = tr Cov(x~) + |E x~|^2, the MSE")
      .def_readonly("error_mean", &StationaryMismatch::error_mean, "E[x~] (zero without a known input)")
      .def_readonly("state_mean", &StationaryMismatch::state_mean, "E[x]")
      .def_readonly("true_spectral_radius", &StationaryMismatch::true_spectral_radius)
      .def_readonly("filter_spectral_radius", &StationaryMismatch::filter_spectral_radius);
  m.def(
      "stationary_mismatched_covariance",
      [](const ModelStep& design, const ModelStep& truth, std::optional<Eigen::MatrixXd> gain,
         std::optional<Eigen::VectorXd> input) {
        MismatchOptions o;
        o.filter_gain = OrEmpty(gain);
        if (input) o.input = *input;
        py::gil_scoped_release release;
        return StationaryMismatchedCovariance(design, truth, o);
      },
      py::arg("design"), py::arg("truth"), py::arg("filter_gain") = py::none(), py::arg("input") = py::none(),
      "002 (15)-(17): the stationary true error of the filter designed on `design`, run on `truth`. Without "
      "filter_gain the filter is the design's steady-state Kalman filter (with the design's S when it has "
      "one: the correlated-noise filter); either step may have S. With a constant known input g (input=, "
      "length q, required when design or truth has G or D) the error has a mean (error_mean; P and trace "
      "include it). Raises kfx.Error naming the step, filter_gain or options.input at fault.");
  m.def(
      "mismatched_covariance_sequence",
      [](const Model& design, const Model& truth, int steps, std::optional<TimeSeries> input) {
        MismatchSequenceOptions o;
        o.steps = steps;
        const TimeSeries g = input ? std::move(*input) : TimeSeries(0, 0);
        MismatchSequence s;
        {
          py::gil_scoped_release release;
          s = MismatchedCovarianceSequence(design, truth, g, o);
        }
        py::dict d;
        d["P"] = Stack(s.P);
        d["V"] = Stack(s.V);
        d["U"] = Stack(s.U);
        d["filter_gain"] = Stack(s.filter_gain, 1);
        d["trace"] = s.trace;
        d["error_mean"] = s.error_mean;
        d["state_mean"] = s.state_mean;
        return d;
      },
      py::arg("design"), py::arg("truth"), py::arg("steps"), py::arg("input") = py::none(),
      "002 (15)-(19) over k = 0..T: dict with P, V, U (T+1, n, n; second moments), filter_gain (T, n, m), trace "
      "(T+1,; the MSE), error_mean, state_mean (T+1, n). The truth may have S; input: the known input g (T, q), "
      "required when a model has G or D (the filter applies the design's G, D; none: it ignores the input). "
      "Raises kfx.Error on mismatched dimensions or steps, naming g when the input does not fit.");
  BindMismatchBounds(m);
}

namespace {

// The error ranges, the bounds of Theorems 1-6 and the error-box search.
void BindMismatchBounds(py::module_& m) {
  py::class_<ErrorRanges>(m, "ErrorRanges", "002 Sec. 6: |Delta X_ij| <= X(i, j); None = exact.")
      .def(py::init([](std::optional<Eigen::MatrixXd> A, std::optional<Eigen::MatrixXd> C,
                       std::optional<Eigen::MatrixXd> Q, std::optional<Eigen::MatrixXd> R,
                       std::optional<Eigen::MatrixXd> S, bool unmodelled_input) {
             return ErrorRanges{OrEmpty(A), OrEmpty(C), OrEmpty(Q), OrEmpty(R), OrEmpty(S), unmodelled_input};
           }),
           py::arg("A") = py::none(), py::arg("C") = py::none(), py::arg("Q") = py::none(), py::arg("R") = py::none(),
           py::arg("S") = py::none(), py::arg("unmodelled_input") = false,
           "S: range of the truth's cross-covariance (n, m); unmodelled_input: the truth has a known input the "
           "filter ignores or mis-models (patel_toda_bounds then refuses the bounds that do not hold).")
      .def_readonly("S", &ErrorRanges::S)
      .def_readonly("unmodelled_input", &ErrorRanges::unmodelled_input)
      .def_readonly("A", &ErrorRanges::A)
      .def_readonly("C", &ErrorRanges::C)
      .def_readonly("Q", &ErrorRanges::Q)
      .def_readonly("R", &ErrorRanges::R);
  m.def(
      "patel_toda_bounds",
      [](const ModelStep& design, const ErrorRanges& ranges, std::optional<Eigen::MatrixXd> gain) {
        MismatchOptions o;
        o.filter_gain = OrEmpty(gain);
        PatelTodaBounds b;
        {
          py::gil_scoped_release release;
          b = ComputePatelTodaBounds(design, ranges, o);
        }
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
        d["norm_S"] = b.norms.S;
        d["refused"] = b.refused;
        return d;
      },
      py::arg("design"), py::arg("ranges"), py::arg("filter_gain") = py::none(),
      "002 Theorems 3-6 for the ranges (pi3, pi4: plant exact; pi5, pi6: noise exact; None where a theorem "
      "does not apply). pi5 uses the corrected Lemma bound, pi5_printed (41) as printed. 'summary': a "
      "kfx.Summary (when the design's DARE fails, every bound is None and the summary says why). 'refused': "
      "the bounds left None because they do not hold with the ranges' S or unmodelled input, each 'piN: why'.");
  m.def(
      "theorem1_bound",
      [](const ModelStep& design, const ModelingErrors& errors) {
        Theorem1Result r;
        {
          py::gil_scoped_release release;
          r = Theorem1Bound(design, errors);
        }
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

}  // namespace

}  // namespace kfx::python
