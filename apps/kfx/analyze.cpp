// `kfx analyze`: the steady state of a model's filter DARE (covariances, both gains, closed-loop spectral
// radius, residual, true stationary MSE) and, with --monte-carlo, the exact against the Monte Carlo MSE of
// the time-varying Kalman filter, designed on MODEL or on --design (a mismatched filter), on MODEL driven by
// the known input --input (a design without G, D ignores it: its error is biased).
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <vector>

#include "commands.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/performance.hpp"
#include "kfx/riccati.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace kfx::cli {

int RunAnalyze(const AnalyzeArgs& a) {
  const Model truth = LoadModel(a.model);
  const Model design = a.design.empty() ? truth : LoadModel(a.design);
  if (design.state_dim() != truth.state_dim() || design.meas_dim() != truth.meas_dim()) {
    throw Error("--design: expected a model with the same dimensions as MODEL (" + std::to_string(truth.state_dim()) +
                " states, " + std::to_string(truth.meas_dim()) + " measurements)");
  }
  if (design.input_dim() > 0 && design.input_dim() != truth.input_dim()) {
    throw Error("--design: expected fields G, D with the " + std::to_string(truth.input_dim()) +
                " columns of MODEL's known input (or none: a filter that ignores it), got " +
                std::to_string(design.input_dim()));
  }
  if (!a.input.empty() && a.monte_carlo == 0) {
    throw Error("--input: expected with --monte-carlo (the known input drives the exact and Monte Carlo comparison)");
  }
  nlohmann::ordered_json j;
  j["model"] = a.model;
  std::cout << "model " << a.model << ": n = " << truth.state_dim() << ", m = " << truth.meas_dim()
            << (truth.time_invariant() ? ", time-invariant" : ", time-varying") << "\n";
  if (design.time_invariant()) {
    const StepPtr s = design.step(1);
    DareOptions dare_options;
    dare_options.exact_eigenvalues = true;  // the report prints rho(A - K_p C) itself, not a bound
    const DareSolution dare = SteadyStateDare(*s, dare_options);
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
      if (truth.input_dim() > 0) {
        std::cout << "  true stationary MSE of the steady-state filter on MODEL: none (MODEL has a known input: "
                     "the error's mean depends on the input; use --monte-carlo with --input)\n";
      } else if (truth.time_invariant()) {
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
    const TimeSeries g = ReadKnownInput(a.input, truth, T);
    const KalmanSchedule design_schedule = ComputeKalmanSchedule(design, KalmanScheduleOptions{T});
    const LinearFilter f = KalmanAsLinearFilter(design, design_schedule);
    PerformanceOptions po;
    po.steps = T;
    po.store_error_moments = false;
    const PerformanceResult exact = ExactPerformance(truth, f, g, po);
    MonteCarloOptions mo;
    mo.runs = a.monte_carlo;
    mo.steps = T;
    mo.seed = a.seed;
    ProgressLine progress("monte carlo");
    mo.progress = progress.callback();
    const MonteCarloResult mc = MonteCarloPerformance(truth, f, g, mo);
    progress.Finish();
    const bool mismatch = !a.design.empty();
    KalmanSchedule optimal;
    if (mismatch) optimal = ComputeKalmanSchedule(truth, KalmanScheduleOptions{T});
    std::cout << "time-varying Kalman filter" << (mismatch ? " designed on " + a.design : "")
              << (a.input.empty() ? "" : ", input " + a.input)
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
      if (!a.input.empty()) {  // the error's mean E[e_k] (0 for a filter that models the input exactly)
        std::vector<double> bias(static_cast<size_t>(exact.bias.cols()));
        for (Eigen::Index i = 0; i < exact.bias.cols(); ++i) bias[static_cast<size_t>(i)] = exact.bias(k, i);
        row["exact_bias"] = bias;
      }
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

}  // namespace kfx::cli
