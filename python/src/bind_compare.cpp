// kfx._core: method specifications and the comparison of methods (include/kfx/method_spec.hpp,
// compare.hpp): kfx.compare(model, methods, ...) returns one dict per method (pandas.DataFrame takes the
// list), kfx.parse_method checks a specification.
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "kfx/compare.hpp"
#include "kfx/method_spec.hpp"
#include "kfx/model.hpp"
#include "long_call.hpp"

namespace kfx::python {

namespace {

py::object Value(double v) { return std::isfinite(v) ? py::object(py::float_(v)) : py::object(py::none()); }

py::dict RowDict(const CompareRow& r, bool stationary) {
  py::dict d;
  d["method"] = r.spec;
  d["description"] = r.description;
  d["online"] = r.online;
  d["state_dim"] = r.state_dim;
  d["offline_seconds"] = r.offline_seconds;
  d["online_seconds_per_step"] = r.online_seconds_per_step;
  d["memory_bytes"] = r.memory_bytes;
  d["mse"] = Value(r.final_mse);
  d["stationary_mse"] = Value(r.stationary_mse);
  d["stationary"] = stationary;
  d["headline"] = Value(stationary ? r.stationary_mse : r.final_mse);
  d["ratio_to_kalman"] = Value(r.ratio);
  d["claimed_mse"] = Value(r.claimed_final);
  d["claimed_stationary_mse"] = Value(r.claimed_stationary);
  d["monte_carlo_runs"] = r.mc_runs;
  d["monte_carlo_mse"] = Value(r.mc_mse);
  d["monte_carlo_std_error"] = Value(r.mc_std_error);
  d["mse_curve"] = r.mse;
  return d;
}

}  // namespace

void BindCompare(py::module_& m) {
  m.def(
      "parse_method",
      [](const std::string& text) {
        const MethodSpec s = ParseMethodSpec(text);
        py::dict params;
        for (const auto& [k, v] : s.params) params[py::str(k)] = v;
        return py::make_tuple(s.name, params);
      },
      py::arg("spec"),
      "Checks a method specification (docs/cli.md) and returns (name, {key: value}); raises kfx.Error.");
  m.def(
      "compare",
      [](const py::object& model, const std::vector<std::string>& methods, int steps, bool stationary,
         std::optional<Eigen::MatrixXd> weight, int monte_carlo, std::uint64_t seed, const py::object& progress) {
        std::vector<MethodSpec> specs;
        for (const std::string& t : methods) specs.push_back(ParseMethodSpec(t));
        const ComparisonModel truth = py::isinstance<py::str>(model)
                                          ? LoadComparisonModel(model.cast<std::string>())
                                          : ComparisonModel{model.cast<Model>(), std::nullopt};
        CompareOptions o;
        o.steps = steps;
        o.stationary = stationary;
        o.weight = OrEmpty(weight);
        o.monte_carlo = monte_carlo;
        o.seed = seed;
        LongCall call(progress);
        o.progress = call.callback();
        const Comparison c = call.Run([&] { return Compare(truth, specs, o); });
        py::list rows;
        for (const CompareRow& r : c.rows) {
          py::dict d = RowDict(r, stationary);
          d["kalman_mse"] = Value(c.kalman_final);
          d["kalman_stationary_mse"] = Value(c.kalman_stationary);
          rows.append(d);
        }
        return rows;
      },
      py::arg("model"), py::arg("methods"), py::arg("steps") = 100, py::arg("stationary") = false,
      py::arg("weight") = py::none(), py::arg("monte_carlo") = 0, py::arg("seed") = 1, py::arg("progress") = py::none(),
      "The rows of `kfx compare` (docs/cli.md): model is a kfx.Model or a model-file path (a coupled model "
      "file for blockdiag/banded); methods are specifications. Returns one dict per method "
      "(pandas.DataFrame(rows) takes the list), each with the optimal Kalman filter's kalman_mse and "
      "kalman_stationary_mse; 'headline' is the stationary MSE with stationary=True, else the MSE at T. "
      "kfx.plots.compare_pareto(rows) and kfx.plots.compare_error_vs_time draw the figures. progress: None or "
      "progress(methods done, methods), as every long call takes it (docs/python.md); Ctrl-C stops the "
      "comparison between methods' steps with KeyboardInterrupt.");
}

}  // namespace kfx::python
