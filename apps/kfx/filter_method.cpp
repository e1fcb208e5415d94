// `kfx filter MODEL --method SPEC --data Y -o DIR`: any method kfx has (a method specification, docs/cli.md)
// on measurements from a file, run by the method's own online implementation (ResolveMethod). `kalman`
// specs are today's `kfx filter` (its form from the spec); the others write the estimates x_filt and
// summary.json.
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "kfx/compare.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace kfx::cli {

int RunFilterMethod(const FilterArgs& a) {
  const MethodSpec spec = ParseMethodSpec(a.method);
  if (spec.name == "kalman") {
    FilterArgs plain = a;
    plain.method.clear();
    plain.form = spec.Get("form", a.form);
    return RunFilterCommand(plain);
  }
  if (!a.input.empty()) throw Error("--input: method '" + a.method + "' takes no known input (the Kalman filter does)");
  const ComparisonModel truth = LoadComparisonModel(a.model);
  const TimeSeries y = ReadTimeSeries(a.data);
  if (y.rows() < 1) throw Error("--data: expected at least one row of measurements, got none");
  if (!y.allFinite()) {
    throw Error("--data: method '" + a.method +
                "' needs every measurement (missing entries are for the Kalman filter)");
  }
  MethodOptions mo;
  mo.steps = static_cast<int>(y.rows());
  const ResolvedMethod m = ResolveMethod(spec, truth, mo);
  const TimeSeries x = m.run(y);
  // Estimates that overflowed are an error, not files (docs/robustness.md, class 4).
  if (!x.allFinite()) throw NumericalError("x_filt: not finite (method '" + a.method + "' diverged); nothing written");
  OutputDirectory out(a.out, "summary.json");  // the completion marker goes last (class 5)
  const std::string file = std::string("x_filt") + (a.csv ? ".csv" : ".npy");
  WriteTimeSeries(out.Path(file), x);
  nlohmann::ordered_json summary;
  summary["steps"] = y.rows();
  summary["state_dim"] = truth.model.state_dim();
  summary["meas_dim"] = truth.model.meas_dim();
  summary["method"] = spec.text;
  summary["description"] = m.description;
  summary["online"] = m.online;
  summary["filter_state_dim"] = m.filter->state_dim();
  summary["files"] = {file};
  out.Commit(summary.dump(2));
  std::cout << "filtered " << y.rows() << " steps with " << spec.text << " (" << m.description
            << ", n_z = " << m.filter->state_dim() << ")\n  wrote " << file << " summary.json to " << a.out << "\n";
  return 0;
}

}  // namespace kfx::cli
