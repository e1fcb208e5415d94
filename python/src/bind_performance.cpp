// kfx._core: the linear filter every method becomes (LinearFilterStep, LinearFilter) and the
// exact-performance engine with its Monte Carlo check (include/kfx/linear_filter.hpp, performance.hpp).
#include <cstdint>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/linear_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/performance.hpp"
#include "long_call.hpp"

namespace kfx::python {

void BindPerformance(py::module_& m) {
  py::class_<LinearFilterStep>(m, "LinearFilterStep")
      .def(py::init([](Eigen::MatrixXd Phi, Eigen::MatrixXd K, std::optional<Eigen::MatrixXd> O,
                       std::optional<Eigen::MatrixXd> Gamma) {
             return LinearFilterStep{std::move(Phi), std::move(K), OrEmpty(O), OrEmpty(Gamma)};
           }),
           py::arg("Phi"), py::arg("K"), py::arg("O") = py::none(), py::arg("Gamma") = py::none())
      .def_readonly("Phi", &LinearFilterStep::Phi)
      .def_readonly("K", &LinearFilterStep::K)
      .def_readonly("O", &LinearFilterStep::O)
      .def_readonly("Gamma", &LinearFilterStep::Gamma, "(n_z, q) known-input map (empty: none)");
  py::class_<LinearFilter>(m, "LinearFilter",
                           "Any kfx filter as a linear recursion z_k = Phi_k z_{k-1} + K_k y_k + Gamma_k g_k, estimate "
                           "O_k z_k (O empty = identity; Gamma empty = the filter ignores the known input g). "
                           "Evaluate it with exact_performance.")
      .def(py::init([](const Eigen::MatrixXd& Phi, const Eigen::MatrixXd& K, Eigen::VectorXd z0,
                       std::optional<Eigen::MatrixXd> O, std::optional<Eigen::MatrixXd> O0,
                       std::optional<Eigen::MatrixXd> Gamma) {
             return LinearFilter(LinearFilterStep{Phi, K, OrEmpty(O), OrEmpty(Gamma)}, std::move(z0), OrEmpty(O0));
           }),
           py::arg("Phi"), py::arg("K"), py::arg("z0"), py::arg("O") = py::none(), py::arg("O0") = py::none(),
           py::arg("Gamma") = py::none(), "Time-invariant filter.")
      .def(py::init<std::vector<LinearFilterStep>, Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("steps"), py::arg("z0"),
           py::arg("O0") = Eigen::MatrixXd(), "Time-varying filter over k = 1..len(steps).")
      .def_property_readonly("state_dim", &LinearFilter::state_dim)
      .def_property_readonly("meas_dim", &LinearFilter::meas_dim)
      .def_property_readonly("output_dim", &LinearFilter::output_dim)
      .def_property_readonly("input_dim", &LinearFilter::input_dim, "q of Gamma (0: ignores any known input)")
      .def_property_readonly("time_invariant", &LinearFilter::time_invariant)
      .def_property_readonly("horizon", &LinearFilter::horizon)
      .def_property_readonly("z0", &LinearFilter::z0)
      .def(
          "step", [](const LinearFilter& f, int k) { return *f.step(k); }, py::arg("k"))
      .def(
          "run",
          [](const LinearFilter& f, const TimeSeries& y, std::optional<TimeSeries> input) {
            return RunLinearFilter(f, y, input ? std::move(*input) : TimeSeries(0, 0));
          },
          py::arg("y"), py::arg("input") = py::none(), py::call_guard<py::gil_scoped_release>(),
          "The online part on y (T, m) and the known input g (T, q) for a filter with Gamma: estimates O_k z_k, "
          "k = 0..T, as (T+1, n_out). Raises kfx.Error if y does not have m columns, has a non-finite entry, or "
          "has more rows than the filter's horizon, or (naming g) when input does not fit the filter's Gamma.");

  py::class_<PerformanceResult>(m, "PerformanceResult")
      .def_readonly("mse", &PerformanceResult::mse, "tr E[e_k e_k^T], k = 0..T")
      .def_readonly("weighted_mse", &PerformanceResult::weighted_mse)
      .def_readonly("bias", &PerformanceResult::bias, "(T+1, n): E[e_k]")
      .def_property_readonly(
          "error_moment", [](const PerformanceResult& r) { return Stack(r.error_moment); }, "(T+1, n, n)")
      .def_readonly("summary", &PerformanceResult::summary);
  m.def(
      "exact_performance",
      [](const Model& truth, const LinearFilter& filter, int steps, std::optional<Eigen::MatrixXd> weight,
         bool store_error_moments, const py::object& progress, std::optional<TimeSeries> input) {
        PerformanceOptions o;
        o.steps = steps;
        o.weight = OrEmpty(weight);
        o.store_error_moments = store_error_moments;
        LongCall call(progress);
        o.progress = call.callback();
        const TimeSeries g = input ? std::move(*input) : TimeSeries(0, 0);
        return call.Run([&] { return ExactPerformance(truth, filter, g, o); });
      },
      py::arg("truth"), py::arg("filter"), py::arg("steps") = -1, py::arg("weight") = py::none(),
      py::arg("store_error_moments") = true, py::arg("progress") = py::none(), py::arg("input") = py::none(),
      (std::string("The exact mean-square error of any linear filter on any true model (the one engine every kfx "
                   "method reports through), e_k = x_k - O_k z_k. input: the known input g (T, q), row k-1 = g_k, "
                   "required for a truth with G or D (it moves the means: .bias). Raises kfx.Error naming the "
                   "argument: filter (dimensions, a Gamma of another q), g (input missing or not (T, q), "
                   "non-finite), weight, steps.") +
       kProgressDoc)
          .c_str());
  py::class_<StationaryPerformance>(m, "StationaryPerformance")
      .def_property_readonly(
          "method", [](const StationaryPerformance& s) { return std::string(ToString(s.method)); },
          "'joint' or 'error-coordinates': the equation solved")
      .def_readonly("error_cov", &StationaryPerformance::error_cov)
      .def_readonly("mse", &StationaryPerformance::mse)
      .def_readonly("weighted_mse", &StationaryPerformance::weighted_mse)
      .def_readonly("summary", &StationaryPerformance::summary,
                    "termination 'converged', or 'unstable' when the error has no stationary value");
  m.def(
      "exact_stationary_performance",
      [](const Model& truth, const LinearFilter& filter, std::optional<Eigen::MatrixXd> weight) {
        StationaryPerformanceOptions o;
        o.weight = OrEmpty(weight);
        py::gil_scoped_release release;
        return ExactStationaryPerformance(truth, filter, o);
      },
      py::arg("truth"), py::arg("filter"), py::arg("weight") = py::none());
  py::class_<MonteCarloResult>(m, "MonteCarloResult")
      .def_readonly("runs", &MonteCarloResult::runs)
      .def_readonly("mse", &MonteCarloResult::mse)
      .def_readonly("mse_std_error", &MonteCarloResult::mse_std_error)
      .def_readonly("weighted_mse", &MonteCarloResult::weighted_mse)
      .def_readonly("weighted_mse_std_error", &MonteCarloResult::weighted_mse_std_error)
      .def_readonly("bias", &MonteCarloResult::bias)
      .def_property_readonly("error_moment", [](const MonteCarloResult& r) { return Stack(r.error_moment); })
      .def_readonly("summary", &MonteCarloResult::summary);
  m.def(
      "monte_carlo_performance",
      [](const Model& truth, const LinearFilter& filter, int runs, std::uint64_t seed, int steps,
         std::optional<Eigen::MatrixXd> weight, bool store_error_moments, const py::object& progress,
         std::optional<TimeSeries> input) {
        MonteCarloOptions o;
        o.runs = runs;
        o.seed = seed;
        o.steps = steps;
        o.weight = OrEmpty(weight);
        o.store_error_moments = store_error_moments;
        LongCall call(progress);
        o.progress = call.callback();
        const TimeSeries g = input ? std::move(*input) : TimeSeries(0, 0);
        return call.Run([&] { return MonteCarloPerformance(truth, filter, g, o); });
      },
      py::arg("truth"), py::arg("filter"), py::arg("runs") = 1000, py::arg("seed") = 1, py::arg("steps") = -1,
      py::arg("weight") = py::none(), py::arg("store_error_moments") = false, py::arg("progress") = py::none(),
      py::arg("input") = py::none(),
      (std::string("Monte Carlo estimate of the same quantities (run i uses stream seed i of `seed`); progress "
                   "counts runs. input: the known input g (T, q), as exact_performance's. Raises kfx.Error as "
                   "exact_performance, and naming runs (fewer than 2).") +
       kProgressDoc)
          .c_str());
}

}  // namespace kfx::python
