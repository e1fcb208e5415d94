// `kfx simulate`: states and measurements of one seeded run of a model, written as .npy or CSV.
#include <iostream>

#include "commands.hpp"
#include "kfx/io.hpp"
#include "kfx/simulation.hpp"
#include "output.hpp"

namespace kfx::cli {

int RunSimulate(const SimulateArgs& a) {
  const Model model = LoadModel(a.model);
  const Trajectory tr = Simulate(model, SimulationOptions{a.steps, a.seed});
  MakeDir(a.out);
  const std::string ext = a.csv ? ".csv" : ".npy";
  WriteTimeSeries(Join(a.out, "x" + ext), tr.x);
  WriteTimeSeries(Join(a.out, "y" + ext), tr.y);
  std::cout << "simulated " << a.steps << " steps (n = " << model.state_dim() << ", m = " << model.meas_dim()
            << ", seed " << a.seed << ")\n  " << Join(a.out, "x" + ext) << "  states x_0..x_T, shape (" << tr.x.rows()
            << ", " << tr.x.cols() << ")\n  " << Join(a.out, "y" + ext) << "  measurements y_1..y_T, shape ("
            << tr.y.rows() << ", " << tr.y.cols() << ")\n";
  return 0;
}

}  // namespace kfx::cli
