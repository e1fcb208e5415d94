// `kfx simulate`: states and measurements of one seeded run of a model, written as .npy or CSV, and
// summary.json (the completion marker, written last: kfx::OutputDirectory).
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "kfx/continuous_model_file.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/simulation.hpp"
#include "output.hpp"

namespace kfx::cli {

int RunSimulate(const SimulateArgs& a) {
  const Model model = LoadModelOrSampled(a.model);  // a continuous-time file: its sampled equivalent
  const TimeSeries g = ReadKnownInput(a.input, model, a.steps);
  const Trajectory tr = Simulate(model, g, SimulationOptions{a.steps, a.seed});  // finite, or it throws
  OutputDirectory out(a.out, "summary.json");
  const std::string ext = a.csv ? ".csv" : ".npy";
  WriteTimeSeries(out.Path("x" + ext), tr.x);
  WriteTimeSeries(out.Path("y" + ext), tr.y);
  nlohmann::ordered_json summary;
  summary["steps"] = a.steps;
  summary["seed"] = a.seed;
  summary["state_dim"] = model.state_dim();
  summary["meas_dim"] = model.meas_dim();
  summary["files"] = {"x" + ext, "y" + ext};
  out.Commit(summary.dump(2));
  std::cout << "simulated " << a.steps << " steps (n = " << model.state_dim() << ", m = " << model.meas_dim()
            << ", seed " << a.seed << ")\n  " << out.Path("x" + ext) << "  states x_0..x_T, shape (" << tr.x.rows()
            << ", " << tr.x.cols() << ")\n  " << out.Path("y" + ext) << "  measurements y_1..y_T, shape ("
            << tr.y.rows() << ", " << tr.y.cols() << ")\n  " << out.Path("summary.json") << "  written last\n";
  return 0;
}

}  // namespace kfx::cli
