// `kfx filter` and `kfx smooth`: the Kalman filter (in the covariance form --form) and the RTS smoother on
// measurements from a file; estimates and covariance diagonals as .npy or CSV, and summary.json.
#include <cmath>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "commands.hpp"
#include "filter_form.hpp"
#include "kfx/continuous_model_file.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/kalman_filter.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace kfx::cli {

namespace {

int RunFilterOrSmooth(const FilterArgs& a, bool smooth) {
  const Model model = LoadModelOrSampled(a.model);  // a continuous-time file: its sampled equivalent
  const TimeSeries y = ReadTimeSeries(a.data);
  ProgressLine progress(smooth ? "smooth (forward pass)" : "filter");
  FilterRunOptions opt;
  opt.store_covariances = smooth;
  // Health checks by default (docs/robustness.md, class 8): a wrong covariance is never silent.
  opt.monitor_health = !a.no_health;
  opt.monitor_eigenvalues = a.health;
  opt.filter = ParseFilterForm(a.form);
  opt.progress = progress.callback();
  const TimeSeries g = ReadKnownInput(a.input, model, static_cast<int>(y.rows()));
  const FilterRun run = RunFilter(model, y, g, opt);
  progress.Finish();
  std::optional<SmootherRun> sm;
  if (smooth) {
    ProgressLine backward("smooth (backward pass)");  // on a terminal only, as the forward pass
    SmootherOptions so;
    so.progress = backward.callback();
    sm = RtsSmooth(model, run, so);
  }
  // Estimates and covariances that overflowed are an error, not files (innovations may hold NaN: missing data).
  auto require_finite = [](const char* name, const TimeSeries& ts) {
    if (!ts.allFinite()) {
      throw NumericalError(std::string(name) +
                           ": not finite (the filter overflowed; try --form sqrt or check the "
                           "model's scaling); nothing written");
    }
  };
  if (smooth) {
    require_finite("x_smooth", sm->x);
    require_finite("P_smooth_diag", sm->P_diag);
  } else {
    require_finite("x_filt", run.x_filt);
    require_finite("P_filt_diag", run.P_filt_diag);
    require_finite("x_pred", run.x_pred);
    require_finite("P_pred_diag", run.P_pred_diag);
  }
  OutputDirectory out(a.out, "summary.json");
  const std::string ext = a.csv ? ".csv" : ".npy";
  std::vector<std::string> written;
  auto write = [&](const std::string& name, const TimeSeries& ts) {
    WriteTimeSeries(out.Path(name + ext), ts);
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
  const std::string& warning = run.health_warning;
  if (!warning.empty()) std::cerr << "kfx: warning: " << warning << "\n";
  if (opt.monitor_health) {
    const FilterHealth& h = run.health;
    nlohmann::ordered_json hj;
    hj["healthy"] = h.healthy();
    hj["eigenvalues_checked"] = opt.monitor_eigenvalues ? "every step" : "steps where Cholesky failed";
    hj["warning"] = warning;
    hj["max_asymmetry"] = h.max_asymmetry;
    hj["min_eigenvalue"] =
        std::isfinite(h.min_eigenvalue) ? nlohmann::ordered_json(h.min_eigenvalue) : nlohmann::ordered_json();
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
    write("x_smooth", sm->x);
    write("P_smooth_diag", sm->P_diag);
  }
  summary["files"] = written;
  out.Commit(summary.dump(2));  // the completion marker, last
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
