// kfx — command-line front end. Thin: parse, call the library, print. Any error becomes one line on
// stderr and exit code 2 (docs in README.md; file formats in docs/formats.md).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "blockdiag.hpp"
#include "cli_args.hpp"
#include "kfx/error.hpp"
#include "kfx/error_ranges_file.hpp"
#include "kfx/io.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/mismatch.hpp"
#include "kfx/performance.hpp"
#include "kfx/reproduce.hpp"
#include "kfx/riccati.hpp"
#include "kfx/simulation.hpp"
#include "kfx/validation.hpp"
#include "progress.hpp"

namespace fs = std::filesystem;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace kfx::cli {
namespace {

void MakeDir(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) throw Error("-o/--out: cannot create directory '" + dir + "': " + ec.message());
}

std::string Join(const std::string& dir, const std::string& name) { return (fs::path(dir) / name).string(); }

void WriteText(const std::string& path, const std::string& text) {
  AtomicOutputFile file(path);
  file.stream() << text << "\n";
  file.Commit();
}

std::string Fmt(const MatrixXd& m) {
  static const Eigen::IOFormat f(6, 0, "  ", "\n", "    [", "]");
  std::ostringstream os;
  os << m.format(f);
  return os.str();
}

void PrintMatrix(const std::string& name, const MatrixXd& m, Eigen::Index max_size = 4) {
  if (m.rows() <= max_size && m.cols() <= max_size) {
    std::cout << "  " << name << " (" << ShapeString(m) << "):\n" << Fmt(m) << "\n";
  } else {
    std::cout << "  " << name << " (" << ShapeString(m) << "), |.|_F = " << m.norm();
    if (m.rows() == m.cols()) {
      std::cout << ", trace " << m.trace() << ", diagonal:\n" << Fmt(m.diagonal().transpose()) << "\n";
    } else {
      std::cout << " (all entries with --json)\n";
    }
  }
}

nlohmann::ordered_json ToJson(const MatrixXd& m) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    nlohmann::ordered_json row = nlohmann::ordered_json::array();
    for (Eigen::Index j = 0; j < m.cols(); ++j) row.push_back(m(i, j));
    rows.push_back(row);
  }
  return rows;
}

// ---- simulate ------------------------------------------------------------------------------
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

// ---- filter / smooth -----------------------------------------------------------------------
int RunFilterCommand(const FilterArgs& a, bool smooth) {
  const Model model = LoadModel(a.model);
  const TimeSeries y = ReadTimeSeries(a.data);
  ProgressLine progress(smooth ? "smooth" : "filter");
  FilterRunOptions opt;
  opt.store_covariances = smooth;
  opt.monitor_health = a.health;
  if (a.form == "standard") opt.filter.update_form = CovarianceUpdateForm::kStandard;
  if (a.form == "sqrt") opt.filter.form = FilterForm::kSquareRoot;
  if (a.form == "ud") opt.filter.form = FilterForm::kUD;
  if (a.form == "information") opt.filter.form = FilterForm::kInformation;
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

// ---- analyze -------------------------------------------------------------------------------
int RunAnalyze(const AnalyzeArgs& a) {
  const Model truth = LoadModel(a.model);
  const Model design = a.design.empty() ? truth : LoadModel(a.design);
  if (design.state_dim() != truth.state_dim() || design.meas_dim() != truth.meas_dim()) {
    throw Error("--design: expected a model with the same dimensions as MODEL (" + std::to_string(truth.state_dim()) +
                " states, " + std::to_string(truth.meas_dim()) + " measurements)");
  }
  nlohmann::ordered_json j;
  j["model"] = a.model;
  std::cout << "model " << a.model << ": n = " << truth.state_dim() << ", m = " << truth.meas_dim()
            << (truth.time_invariant() ? ", time-invariant" : ", time-varying") << "\n";
  if (design.time_invariant()) {
    const StepPtr s = design.step(1);
    DareOptions dare_options;
    dare_options.exact_eigenvalues = true;  // the report prints rho(A - K_p C) itself, not a bound
    const DareSolution dare = SolveFilterDare(s->A, s->C, s->Q, s->R, dare_options);
    std::cout << "steady state (filter DARE" << (a.design.empty() ? "" : " of the design model")
              << "): " << dare.summary.BriefReport() << "\n";
    j["dare"] = {{"status", ToString(dare.summary.termination)},
                 {"method", ToString(dare.method_used)},
                 {"relative_residual", dare.summary.relative_residual},
                 {"closed_loop_spectral_radius", dare.closed_loop_spectral_radius},
                 {"iterations", dare.summary.iterations}};
    if (dare.summary.ok()) {
      std::cout << std::setprecision(6);
      PrintMatrix("P_pred  (a priori, P_{k|k-1})", dare.P_pred);
      PrintMatrix("P_filt  (a posteriori, P_{k|k})", dare.P_filt);
      PrintMatrix("filter gain K_f  (x_{k|k} = x_{k|k-1} + K_f nu_k)", dare.filter_gain);
      PrintMatrix("predictor gain K_p = A K_f  (x_{k+1|k} = A x_{k|k-1} + K_p nu_k)", dare.predictor_gain);
      std::cout << "  closed-loop spectral radius rho(A - K_p C) = " << dare.closed_loop_spectral_radius
                << "\n  DARE relative residual = " << dare.summary.relative_residual << "\n";
      j["P_pred"] = ToJson(dare.P_pred);
      j["P_filt"] = ToJson(dare.P_filt);
      j["filter_gain"] = ToJson(dare.filter_gain);
      j["predictor_gain"] = ToJson(dare.predictor_gain);
      if (truth.time_invariant()) {
        const LinearFilter f = ConstantGainAsLinearFilter(*s, dare.filter_gain, truth.m0());
        const StationaryPerformance st = ExactStationaryPerformance(truth, f);
        if (st.summary.ok()) {
          std::cout << "  true stationary MSE of the steady-state filter on MODEL: " << st.mse << " ("
                    << ToString(st.method) << ")\n";
          j["stationary_mse"] = st.mse;
        } else {
          std::cout << "  true stationary MSE of the steady-state filter on MODEL: none (" << st.summary.message
                    << ")\n";
        }
      }
    }
  }
  if (a.monte_carlo > 0) {
    const int T = a.steps;
    const KalmanSchedule design_schedule = ComputeKalmanSchedule(design, KalmanScheduleOptions{T});
    const LinearFilter f = KalmanAsLinearFilter(design, design_schedule);
    PerformanceOptions po;
    po.steps = T;
    po.store_error_moments = false;
    const PerformanceResult exact = ExactPerformance(truth, f, po);
    MonteCarloOptions mo;
    mo.runs = a.monte_carlo;
    mo.steps = T;
    mo.seed = a.seed;
    ProgressLine progress("monte carlo");
    mo.progress = progress.callback();
    const MonteCarloResult mc = MonteCarloPerformance(truth, f, mo);
    progress.Finish();
    const bool mismatch = !a.design.empty();
    KalmanSchedule optimal;
    if (mismatch) optimal = ComputeKalmanSchedule(truth, KalmanScheduleOptions{T});
    std::cout << "time-varying Kalman filter" << (mismatch ? " designed on " + a.design : "")
              << ", true MSE tr E[e_k e_k^T]: exact (engine) vs Monte Carlo (" << mc.runs << " runs, seed " << a.seed
              << ")\n     k        exact  monte carlo      std.err       z";
    if (mismatch) std::cout << "  filter claims  optimal (KF on MODEL)";
    std::cout << "\n";
    std::vector<int> ks;
    for (int k : {0, 1, 2, 5, 10, 20, 50, 100, 200, 500, 1000})
      if (k <= T) ks.push_back(k);
    if (ks.back() != T) ks.push_back(T);
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (int k : ks) {
      const double z = mc.mse_std_error(k) > 0 ? (mc.mse(k) - exact.mse(k)) / mc.mse_std_error(k) : 0.0;
      std::cout << std::setprecision(6) << std::setw(6) << k << "  " << std::setw(11) << exact.mse(k) << "  "
                << std::setw(11) << mc.mse(k) << "  " << std::setw(11) << mc.mse_std_error(k) << "  " << std::setw(6)
                << std::setprecision(2) << z;
      nlohmann::ordered_json row = {
          {"k", k}, {"exact", exact.mse(k)}, {"monte_carlo", mc.mse(k)}, {"std_error", mc.mse_std_error(k)}};
      if (mismatch) {
        const double claimed = design_schedule.P_filt[static_cast<size_t>(k)].trace();
        const double best = optimal.P_filt[static_cast<size_t>(k)].trace();
        std::cout << std::setprecision(6) << "  " << std::setw(13) << claimed << "  " << std::setw(13) << best;
        row["filter_claims"] = claimed;
        row["optimal"] = best;
      }
      std::cout << "\n";
      rows.push_back(row);
    }
    if (mismatch) {
      std::cout
          << "  (filter claims = trace of the mismatched filter's own P_{k|k}; the engine gives its true error)\n";
    }
    j["monte_carlo"] = {{"runs", mc.runs}, {"seed", a.seed}, {"rows", rows}};
  }
  if (!a.json.empty()) WriteText(a.json, j.dump(2));
  return 0;
}

// ---- mismatch ------------------------------------------------------------------------------
// "dA(1,2) = +0.1, dR(1,1) = -0.5" (1-based, nonzero entries; Delta = model - true).
std::string ErrorsString(const ModelingErrors& e) {
  std::ostringstream os;
  os << std::showpos << std::setprecision(6);
  const MatrixXd* mats[4] = {&e.A, &e.C, &e.Q, &e.R};
  const char* names[4] = {"dA", "dC", "dQ", "dR"};
  bool any = false;
  for (int w = 0; w < 4; ++w) {
    const MatrixXd& m = *mats[w];
    for (Eigen::Index i = 0; i < m.rows(); ++i)
      for (Eigen::Index j = 0; j < m.cols(); ++j) {
        if (m(i, j) == 0.0 || (w >= 2 && j < i)) continue;
        os << (any ? ", " : "") << names[w] << "(" << std::noshowpos << i + 1 << "," << j + 1 << std::showpos
           << ") = " << m(i, j);
        any = true;
      }
  }
  return any ? os.str() : "no error";
}

nlohmann::ordered_json ExtremeJson(const ErrorBoxExtreme& e) {
  nlohmann::ordered_json j;
  j["found"] = e.found;
  if (!e.found) return j;
  j["value"] = e.value;
  j["at_corner"] = e.at_corner;
  j["errors"] = {
      {"A", ToJson(e.errors.A)}, {"C", ToJson(e.errors.C)}, {"Q", ToJson(e.errors.Q)}, {"R", ToJson(e.errors.R)}};
  j["evaluations"] = e.evaluations;
  j["skipped"] = e.skipped;
  return j;
}

int RunMismatch(const MismatchArgs& a) {
  const Model model = LoadModel(a.model);
  if (!model.time_invariant()) throw Error(a.model + ": expected a time-invariant model (002 is stationary)");
  const ModelStep design = *model.step(1);
  const ErrorRanges ranges = LoadErrorRanges(a.ranges, design);
  const PatelTodaBounds b = ComputePatelTodaBounds(design, ranges);
  b.summary.RequireOk();
  ErrorBoxSearchOptions so;
  so.refine = !a.no_refine;
  const ErrorBoxSearch box = SearchErrorBox(design, ranges, MismatchOptions(), so);
  box.summary.RequireOk();
  const LinearFilter f = ConstantGainAsLinearFilter(design, b.terms.filter_gain, model.m0());
  const StationaryPerformance engine = ExactStationaryPerformance(model, f);
  const DareSolution dare = SolveFilterDare(design.A, design.C, design.Q, design.R);
  nlohmann::ordered_json j;
  j["model"] = a.model;
  j["ranges"] = a.ranges;
  std::cout << std::setprecision(6) << "filter designed on " << a.model
            << " (steady-state Kalman gain), n = " << model.state_dim() << ", m = " << model.meas_dim()
            << "\nerror ranges " << a.ranges << ": "
            << "free entries " << box.free_entries << "; |dA| <= " << b.norms.A << ", |dC| <= " << b.norms.C
            << ", |dQ| <= " << b.norms.Q << ", |dR| <= " << b.norms.R << " (Frobenius; Delta = model - true)\n"
            << "nominal (true system = model): true error tr P = " << b.terms.nominal_trace
            << " (the filter's own tr P_filt = " << dare.P_filt.trace() << ", engine " << engine.mse << ")\n";
  j["nominal_trace"] = b.terms.nominal_trace;
  auto extreme = [&](const char* what, const ErrorBoxExtreme& e) {
    std::cout << what;
    if (!e.found) {
      std::cout << ": no valid true system found in the box\n";
      return;
    }
    std::cout << e.value << " at " << ErrorsString(e.errors) << (e.at_corner ? " (corner)" : " (inside)") << "; "
              << e.evaluations << " evaluations, " << e.skipped << " skipped\n";
  };
  extreme("worst case over the box (corners, then refinement): max tr P = ", box.least_upper);
  extreme("best optimal filter over the box: min tr P_F = ", box.greatest_lower);
  j["least_upper"] = ExtremeJson(box.least_upper);
  j["greatest_lower"] = ExtremeJson(box.greatest_lower);
  const double worst = box.least_upper.found ? box.least_upper.value : NAN;
  const double best = box.greatest_lower.found ? box.greatest_lower.value : NAN;
  std::cout << "guaranteed bounds (Patel, Toda 1977; ratio = how conservative against the box search):\n";
  nlohmann::ordered_json bounds;
  auto upper = [&](const char* name, const std::optional<double>& v, const char* what) {
    if (!v) return;
    std::cout << "  " << name << ": tr P   <= " << std::setw(10) << *v << "   ratio to max tr P  " << *v / worst
              << "   " << what << "\n";
    bounds[name] = *v;
  };
  auto lower = [&](const char* name, const std::optional<double>& v, const char* what) {
    if (!v) return;
    std::cout << "  " << name << ": tr P_F >= " << std::setw(10) << *v << "   ratio min tr P_F to it " << best / *v
              << "   " << what << "\n";
    bounds[name] = *v;
  };
  upper("pi3", b.pi3, "(Theorem 3, noise covariance errors)");
  lower("pi4", b.pi4, "(Theorem 4, noise covariance errors)");
  upper("pi5", b.pi5, "(Theorem 5, plant errors; Lemma with the sound beta)");
  if (b.pi5_printed) {
    upper("pi5_printed", b.pi5_printed,
          b.lemma->printed_is_valid ? "(Theorem 5 with (41) as printed; valid here)"
                                    : "(Theorem 5 with (41) as printed: NOT guaranteed, x > 0.797)");
  }
  lower("pi6", b.pi6, "(Theorem 6, plant errors)");
  if (!b.pi3 && !b.pi5) {
    std::cout << "  none: the ranges include both plant (A, C) and noise (Q, R) errors; Theorems 3-4 need exact "
                 "A, C and Theorems 5-6 exact Q, R\n";
  }
  if (b.lemma) {
    std::cout << "  Lemma: |U|_s <= " << b.lemma->beta << " (x = " << b.lemma->x << ", kappa = " << b.lemma->kappa
              << ", sigma = " << b.lemma->sigma << ")" << (b.lemma->applies() ? "" : ": " + b.lemma->summary.message)
              << "\n";
    bounds["lemma"] = {{"beta", b.lemma->beta},
                       {"beta_printed", b.lemma->beta_printed},
                       {"x", b.lemma->x},
                       {"kappa", b.lemma->kappa},
                       {"sigma", b.lemma->sigma}};
  }
  j["bounds"] = bounds;
  if (!a.json.empty()) WriteText(a.json, j.dump(2));
  return 0;
}

// ---- reproduce -----------------------------------------------------------------------------
// The figures of `reproduce --out DIR` are drawn by kfx.plots (python/kfx/plots.py, matplotlib) when a
// Python with matplotlib is there; otherwise the CLI says so and leaves the CSV data. Interpreter:
// $KFX_PYTHON, else the one CMake chose (Debian's /usr/bin/python3); script: $KFX_PLOTS, else the
// source tree's python/kfx/plots.py, else the installed share/kfx/plots.py.
std::string ShellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

void DrawFigures(const std::string& out_dir) {
  const char* env_python = std::getenv("KFX_PYTHON");
  const char* env_script = std::getenv("KFX_PLOTS");
  const std::string python = env_python ? env_python : KFX_PYTHON_DEFAULT;
  std::string script = env_script ? env_script : KFX_PLOTS_SCRIPT;
  if (!env_script && !fs::exists(script)) script = KFX_PLOTS_INSTALLED;
  const std::string manual = "; the CSV data are in " + out_dir +
                             " (to draw them: install python3-matplotlib, then python3 python/kfx_figures.py " +
                             out_dir + ")";
  if (!fs::exists(script)) {
    std::cout << "figures: not drawn: the plotting script " << script << " is missing" << manual << "\n";
    return;
  }
  const std::string probe = ShellQuote(python) + " -c 'import matplotlib' > /dev/null 2>&1";
  if (std::system(probe.c_str()) != 0) {
    std::cout << "figures: not drawn: no Python with matplotlib (tried " << python << ")" << manual << "\n";
    return;
  }
  const std::string list = Join(out_dir, "figures.txt");
  const std::string cmd =
      ShellQuote(python) + " " + ShellQuote(script) + " " + ShellQuote(out_dir) + " > " + ShellQuote(list);
  std::cout << std::flush;
  if (std::system(cmd.c_str()) != 0) {
    std::cout << "figures: not drawn: " << python << " " << script << " failed (messages above)" << manual << "\n";
    return;
  }
  std::ifstream in(list);
  int count = 0;
  for (std::string line; std::getline(in, line);) count += !line.empty();
  if (count == 0) {
    std::cout << "figures: none to draw for this output (kfx.plots found no figure data)\n";
    return;
  }
  std::cout << "figures: " << count << " files (PNG and SVG) drawn with " << python << " (kfx.plots), listed in "
            << list << "\n";
}

int RunReproduce(const ReproduceArgs& a) {
  std::vector<std::string> ids;
  const bool all = a.paper == "all";
  if (all) {
    ids = PaperIds();
  } else {
    ids.push_back(a.paper);
  }
  std::vector<PaperReport> reports;
  for (const auto& id : ids) {
    ReproduceOptions opt;
    opt.quick = a.quick;
    if (!a.out.empty()) {
      opt.out_dir = Join(a.out, id);
      MakeDir(opt.out_dir);
    }
    ProgressLine progress("reproduce " + id);
    opt.progress = progress.callback();
    reports.push_back(Reproduce(id, opt));
    progress.Finish();
    std::cout << FormatReportTable(reports.back()) << std::flush;
  }
  if (!a.json.empty()) WriteText(a.json, ReportsToJson(reports, all));
  if (!a.out.empty()) DrawFigures(a.out);
  return 0;
}

int Main(int argc, char** argv) {
  CommandLine cl;
  std::vector<std::string> papers = PaperIds();
  papers.push_back("all");
  const int rc = CommandLineParser(papers).Parse(argc, argv, &cl);
  if (rc >= 0) return rc;
  if (cl.command == "simulate") return RunSimulate(cl.sim);
  if (cl.command == "filter") return RunFilterCommand(cl.flt, false);
  if (cl.command == "smooth") return RunFilterCommand(cl.smo, true);
  if (cl.command == "analyze") return RunAnalyze(cl.ana);
  if (cl.command == "mismatch") return RunMismatch(cl.mis);
  if (cl.command == "reproduce") return RunReproduce(cl.rep);
  if (cl.command == "blockdiag") return RunBlockDiag(argc, argv, cl.bd);
  return 2;
}

}  // namespace
}  // namespace kfx::cli

int main(int argc, char** argv) {
  auto one_line = [](std::string msg) {
    for (auto& ch : msg)
      if (ch == '\n' || ch == '\r') ch = ' ';
    return msg;
  };
  try {
    return kfx::cli::Main(argc, argv);
  } catch (const kfx::Error& e) {
    std::fprintf(stderr, "kfx: error: %s\n", one_line(e.what()).c_str());
  } catch (const kfx::NumericalError& e) {
    std::fprintf(stderr, "kfx: numerical error: %s\n", one_line(e.what()).c_str());
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "kfx: error: out of memory\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kfx: error: %s\n", one_line(e.what()).c_str());
  } catch (...) {
    std::fprintf(stderr, "kfx: error: unknown exception\n");
  }
  return 2;
}
