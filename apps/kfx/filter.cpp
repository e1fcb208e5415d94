// `kfx filter` and `kfx smooth`: the Kalman filter (in the covariance form --form) and the RTS smoother on
// measurements from a file; estimates and covariance diagonals as .npy or CSV, and summary.json.
#include <cmath>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "filter_form.hpp"
#include "kfx/io.hpp"
#include "kfx/kalman_filter.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace kfx::cli {

namespace {

int RunFilterOrSmooth(const FilterArgs& a, bool smooth) {
  const Model model = LoadModel(a.model);
  const TimeSeries y = ReadTimeSeries(a.data);
  ProgressLine progress(smooth ? "smooth" : "filter");
  FilterRunOptions opt;
  opt.store_covariances = smooth;
  opt.monitor_health = a.health;
  opt.filter = ParseFilterForm(a.form);
  opt.progress = progress.callback();
  const FilterRun run = RunFilter(model, y, opt);
  progress.Finish();
  MakeDir(a.out);
  const std::string ext = a.csv ? ".csv" : ".npy";
  std::vector<std::string> written;
  auto write = [&](const std::string& name, const TimeSeries& ts) {
    WriteTimeSeries(Join(a.out, name + ext), ts);
    written.push_back(name + ext);
  };
  long missing = 0;
  for (Eigen::Index i = 0; i < y.size(); ++i) missing += std::isnan(y.data()[i]) ? 1 : 0;
  nlohmann::ordered_json summary;
  summary["steps"] = y.rows();
  summary["state_dim"] = model.state_dim();
  summary["meas_dim"] = model.meas_dim();
  summary["missing_entries"] = missing;
  summary["log_likelihood"] = run.log_likelihood;
  summary["form"] = a.form;
  if (a.health) {
    const FilterHealth& h = run.health;
    nlohmann::ordered_json hj;
    hj["healthy"] = h.healthy();
    hj["max_asymmetry"] = h.max_asymmetry;
    hj["min_eigenvalue"] = h.min_eigenvalue;
    hj["min_eigenvalue_step"] = h.min_eigenvalue_step;
    hj["cholesky_failures"] = h.cholesky_failures;
    hj["first_cholesky_failure"] = h.first_cholesky_failure;
    hj["nis_mean"] = h.nis_dof > 0 ? nlohmann::ordered_json(h.nis_mean) : nlohmann::ordered_json();
    hj["nis_dof"] = h.nis_dof;
    hj["nis_band_99"] = {h.nis_lower, h.nis_upper};
    hj["nis_consistent"] = h.nis_consistent;
    summary["health"] = hj;
  }
  if (!smooth) {
    write("x_filt", run.x_filt);
    write("P_filt_diag", run.P_filt_diag);
    write("x_pred", run.x_pred);
    write("P_pred_diag", run.P_pred_diag);
    write("innovations", run.innovations);
  } else {
    const SmootherRun sm = RtsSmooth(model, run);
    write("x_smooth", sm.x);
    write("P_smooth_diag", sm.P_diag);
  }
  summary["files"] = written;
  WriteText(Join(a.out, "summary.json"), summary.dump(2));
  std::cout << (smooth ? "smoothed " : "filtered ") << y.rows() << " steps (n = " << model.state_dim()
            << ", m = " << model.meas_dim() << ", " << missing << " missing entries)\n"
            << "  log-likelihood " << std::setprecision(10) << run.log_likelihood << "\n  wrote";
  for (const auto& w : written) std::cout << " " << w;
  std::cout << " summary.json to " << a.out << "\n";
  return 0;
}

}  // namespace

int RunFilterCommand(const FilterArgs& args) {
  return args.method.empty() ? RunFilterOrSmooth(args, false) : RunFilterMethod(args);
}

int RunSmoothCommand(const FilterArgs& args) { return RunFilterOrSmooth(args, true); }

}  // namespace kfx::cli
