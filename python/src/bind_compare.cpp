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

void AddFields(const std::vector<CompareField>& fields, py::dict* d) {
  for (const CompareField& f : fields) {
    py::object v;
    switch (f.kind) {
      case CompareField::Kind::kText:
        v = f.null_if_empty && f.text.empty() ? py::object(py::none()) : py::object(py::str(f.text));
        break;
      case CompareField::Kind::kInteger:
        v = py::int_(static_cast<long long>(f.number));
        break;
      case CompareField::Kind::kFlag:
        v = py::bool_(f.number != 0);
        break;
      case CompareField::Kind::kNumber:
        v = Value(f.number);
        break;
    }
    (*d)[py::str(f.name)] = v;
  }
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
                                          : ComparisonModel{model.cast<Model>(), std::nullopt, std::nullopt};
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
          py::dict d;
          AddFields(CompareRowFields(r, c.stationary), &d);
          AddFields(ComparisonFields(c), &d);
          d["mse_curve"] = r.mse;
          rows.append(d);
        }
        return rows;
      },
      py::arg("model"), py::arg("methods"), py::arg("steps") = 100, py::arg("stationary") = false,
      py::arg("weight") = py::none(), py::arg("monte_carlo") = 0, py::arg("seed") = 1, py::arg("progress") = py::none(),
      "The rows of `kfx compare` (docs/cli.md): model is a kfx.Model or a model-file path (a coupled model "
      "file for blockdiag/banded, a continuous-time model file for sampled); methods are specifications. Returns one "
      "dict per method "
      "(pandas.DataFrame(rows) takes the list), each with the comparison's fields (steps, stationary, "
      "kalman_final_mse, kalman_stationary_mse, kalman_bucy_mse, kalman_bucy_stationary_mse) and mse_curve; 'headline' "
      "is the stationary MSE with stationary=True, else the MSE at T. "
      "kfx.plots.compare_pareto(rows) and kfx.plots.compare_error_vs_time draw the figures. progress: None or "
      "progress(methods done, methods), "
      "as every long call takes it (docs/python.md); Ctrl-C stops the comparison between methods' steps with "
      "KeyboardInterrupt.");
}

}  // namespace kfx::python
