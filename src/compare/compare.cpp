// `kfx compare` / kfx.compare (include/kfx/compare.hpp): each method's true error from the one
// exact-performance engine, its online cost on its own implementation, its claimed error, Monte Carlo,
// beside the optimal Kalman filter on the true model.
#include "kfx/compare.hpp"

#include <cmath>

#include "compare/resolve_internal.hpp"
#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/riccati.hpp"
#include "kfx/simulation.hpp"

namespace kfx {

namespace {

using Eigen::MatrixXd;

double WeightedTrace(const MatrixXd& W, const MatrixXd& P) {
  if (P.size() == 0) return std::numeric_limits<double>::quiet_NaN();
  return W.size() == 0 ? P.trace() : (W * P).trace();
}

void Evaluate(const Model& model, const ResolvedMethod& m, const CompareOptions& o, const TimeSeries& y,
              CompareRow* row) {
  const LinearFilter& f = *m.filter;
  PerformanceOptions po;
  po.steps = o.steps;
  po.weight = o.weight;
  po.store_error_moments = false;
  const PerformanceResult exact = ExactPerformance(model, f, po);
  row->mse = exact.weighted_mse;
  row->final_mse = exact.weighted_mse(o.steps);
  if (!f.time_invariant()) {
    row->stationary_note = "time-varying filter (a schedule over the horizon)";
  } else if (!model.time_invariant()) {
    row->stationary_note = "time-varying model";
  } else {
    StationaryPerformanceOptions so;
    so.weight = o.weight;
    const StationaryPerformance sp = ExactStationaryPerformance(model, f, so);
    if (sp.summary.ok()) {
      row->stationary_mse = sp.weighted_mse;
    } else {
      row->stationary_note = sp.summary.BriefReport();
    }
  }
  row->claimed_final = WeightedTrace(o.weight, m.claimed_cov);
  row->claimed_stationary = WeightedTrace(o.weight, m.claimed_stationary_cov);
  // Online cost: the method's own implementation on one simulated run, best of a few repetitions.
  double best = std::numeric_limits<double>::infinity();
  for (int rep = 0; rep < 3; ++rep) {
    const detail::Stopwatch clock;
    const TimeSeries est = m.run(y);
    best = std::min(best, clock.Seconds());
    if (est.rows() != y.rows() + 1 || est.cols() != model.state_dim()) {
      throw InternalError(m.spec.text + ": online run returned " + std::to_string(est.rows()) + " x " +
                          std::to_string(est.cols()));
    }
    if (best * 3 > 1.0) break;  // slow enough to time once
  }
  row->online_seconds_per_step = best / o.steps;
  if (o.monte_carlo > 0) {
    MonteCarloOptions mo;
    mo.runs = o.monte_carlo;
    mo.seed = o.seed;
    mo.steps = o.steps;
    mo.weight = o.weight;
    const MonteCarloResult mc = MonteCarloPerformance(model, f, mo);
    row->mc_runs = mc.runs;
    row->mc_mse = mc.weighted_mse(o.steps);
    row->mc_std_error = mc.weighted_mse_std_error(o.steps);
  }
}

}  // namespace

bool CompareOptions::IsValid(std::string* error) const {
  std::string e;
  if (steps < 1) e = "steps: expected at least 1, got " + std::to_string(steps);
  if (e.empty() && (monte_carlo == 1 || monte_carlo < 0)) {
    e = "monte_carlo: expected 0 (none) or at least 2 runs, got " + std::to_string(monte_carlo);
  }
  if (e.empty()) {
    PerformanceOptions po;
    po.weight = weight;
    po.IsValid(&e);
  }
  if (error) *error = e;
  return e.empty();
}

Comparison Compare(const ComparisonModel& truth, const std::vector<MethodSpec>& methods,
                   const CompareOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw Error(error);
  const Model& model = truth.model;
  if (options.weight.size() != 0 &&
      (options.weight.rows() != model.state_dim() || options.weight.cols() != model.state_dim())) {
    throw Error("weight: expected a " + std::to_string(model.state_dim()) + "x" + std::to_string(model.state_dim()) +
                " matrix (n x n), got " + std::to_string(options.weight.rows()) + "x" +
                std::to_string(options.weight.cols()));
  }
  Comparison c;
  c.steps = options.steps;
  c.stationary = options.stationary;
  KalmanScheduleOptions ko;
  ko.steps = options.steps;
  c.kalman_final = WeightedTrace(options.weight, ComputeKalmanSchedule(model, ko).P_filt.back());
  if (model.time_invariant()) {
    const StepPtr step_ptr = model.step(1);
    const ModelStep& s = *step_ptr;
    const DareSolution dare = SolveFilterDare(s.A, s.C, s.Q, s.R);
    if (dare.summary.ok()) c.kalman_stationary = WeightedTrace(options.weight, dare.P_filt);
  }
  if (options.stationary && std::isnan(c.kalman_stationary)) {
    throw Error("--stationary: needs a time-invariant model whose filter DARE has a stabilizing solution");
  }
  SimulationOptions sim;
  sim.steps = options.steps;
  sim.seed = options.seed;
  const TimeSeries y = Simulate(model, sim).y;
  MethodOptions mo;
  mo.steps = options.steps;
  mo.stationary = options.stationary;
  long done = 0;
  for (const MethodSpec& spec : methods) {
    const ResolvedMethod m = ResolveMethod(spec, truth, mo);
    CompareRow row;
    row.spec = m.spec.text;
    row.description = m.description;
    row.online = m.online;
    row.state_dim = m.filter->state_dim();
    row.offline_seconds = m.offline_seconds;
    row.memory_bytes = m.memory_bytes;
    Evaluate(model, m, options, y, &row);
    const double headline = options.stationary ? row.stationary_mse : row.final_mse;
    const double reference = options.stationary ? c.kalman_stationary : c.kalman_final;
    row.ratio = headline / reference;
    c.rows.push_back(std::move(row));
    if (options.progress) options.progress(++done, static_cast<long>(methods.size()));
  }
  return c;
}

}  // namespace kfx
