// `kfx compare` / kfx.compare (include/kfx/compare.hpp): each method's true error from the one
// exact-performance engine, its online cost on its own implementation, its claimed error, Monte Carlo,
// beside the optimal Kalman filter on the true model.
#include "kfx/compare.hpp"

#include <cmath>

#include "compare/resolve_internal.hpp"
#include "kfx/continuous.hpp"
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

namespace {

// A continuous-time model's weight is p x p on z (empty: I_p); the engine's is 2p x 2p on [z; int z].
MatrixXd EmbeddedWeight(const ComparisonModel& truth, const MatrixXd& weight) {
  const Eigen::Index p = truth.continuous->model.state_dim();
  if (weight.size() != 0 && (weight.rows() != p || weight.cols() != p)) {
    throw Error("weight: expected a " + std::to_string(p) + "x" + std::to_string(p) +
                " matrix (the continuous state z of a continuous-time model), got " + std::to_string(weight.rows()) +
                "x" + std::to_string(weight.cols()));
  }
  MatrixXd W = MatrixXd::Zero(2 * p, 2 * p);
  W.topLeftCorner(p, p) = weight.size() == 0 ? MatrixXd::Identity(p, p) : weight;
  return W;
}

// The Kalman-Bucy filter's error at T dt and its CARE (continuous-time models).
void KalmanBucyReference(const ContinuousModelFile& c, const MatrixXd& W, int steps, Comparison* out) {
  const Eigen::Index p = c.model.state_dim();
  const MatrixXd Wz = W.topLeftCorner(p, p);
  out->kalman_bucy_final = (Wz * KalmanBucyCovariance(c.model, steps * c.dt)).trace();
  const CareSolution care = SolveFilterCare(c.model);
  if (care.summary.ok()) out->kalman_bucy_stationary = (Wz * care.P).trace();
}

}  // namespace

Comparison Compare(const ComparisonModel& truth, const std::vector<MethodSpec>& methods, const CompareOptions& given) {
  CompareOptions options = given;
  if (truth.continuous) options.weight = EmbeddedWeight(truth, given.weight);
  std::string error;
  if (!options.IsValid(&error)) throw Error(error);
  const Model& model = truth.model;
  // A known input would have to reach every method's online run and the timing simulation (issue 22: the engine
  // takes it, ExactPerformance with g; `kfx analyze --input`); refused here rather than failing inside.
  if (model.input_dim() > 0) {
    throw Error(
        "model: expected a model without a known input (fields G, D): compare does not take the input yet; "
        "evaluate a filter on it with the exact-performance engine and the input (kfx analyze --input, "
        "kfx.exact_performance(..., input=))");
  }
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
    const DareSolution dare = SteadyStateDare(s);
    if (dare.summary.ok()) c.kalman_stationary = WeightedTrace(options.weight, dare.P_filt);
  }
  if (truth.continuous) KalmanBucyReference(*truth.continuous, options.weight, options.steps, &c);
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

namespace {

CompareField Text(const std::string& name, const std::string& text, bool null_if_empty = false) {
  CompareField f{name, CompareField::Kind::kText, text, 0.0, null_if_empty};
  return f;
}
CompareField Of(const std::string& name, CompareField::Kind kind, double v) {
  return CompareField{name, kind, std::string(), v, false};
}

}  // namespace

std::vector<CompareField> CompareRowFields(const CompareRow& r, bool stationary) {
  using K = CompareField::Kind;
  return {Text("method", r.spec),
          Text("description", r.description),
          Text("online", r.online),
          Of("state_dim", K::kInteger, static_cast<double>(r.state_dim)),
          Of("offline_seconds", K::kNumber, r.offline_seconds),
          Of("online_seconds_per_step", K::kNumber, r.online_seconds_per_step),
          Of("memory_bytes", K::kNumber, r.memory_bytes),
          Of("mse", K::kNumber, r.final_mse),
          Of("stationary_mse", K::kNumber, r.stationary_mse),
          Text("stationary_note", r.stationary_note, /*null_if_empty=*/true),
          Of("headline", K::kNumber, stationary ? r.stationary_mse : r.final_mse),
          Of("ratio_to_kalman", K::kNumber, r.ratio),
          Of("claimed_mse", K::kNumber, r.claimed_final),
          Of("claimed_stationary_mse", K::kNumber, r.claimed_stationary),
          Of("monte_carlo_runs", K::kInteger, r.mc_runs),
          Of("monte_carlo_mse", K::kNumber, r.mc_mse),
          Of("monte_carlo_std_error", K::kNumber, r.mc_std_error)};
}

std::vector<CompareField> ComparisonFields(const Comparison& c) {
  using K = CompareField::Kind;
  return {Of("steps", K::kInteger, c.steps),
          Of("stationary", K::kFlag, c.stationary ? 1.0 : 0.0),
          Of("kalman_final_mse", K::kNumber, c.kalman_final),
          Of("kalman_stationary_mse", K::kNumber, c.kalman_stationary),
          Of("kalman_bucy_mse", K::kNumber, c.kalman_bucy_final),
          Of("kalman_bucy_stationary_mse", K::kNumber, c.kalman_bucy_stationary)};
}

}  // namespace kfx
