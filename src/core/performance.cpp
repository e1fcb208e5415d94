#include "kfx/performance.hpp"
#include "core/performance_internal.hpp"

#include <chrono>
#include <cmath>
#include <limits>

#include "kfx/error.hpp"
#include "kfx/simulation.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace detail {

void CheckCompatible(const Model& truth, const LinearFilter& filter) {
  if (filter.meas_dim() != truth.meas_dim()) {
    throw Error("filter: expected a gain with " + std::to_string(truth.meas_dim()) +
                " columns (the model's measurement dimension), got " + std::to_string(filter.meas_dim()));
  }
  if (filter.output_dim() != truth.state_dim()) {
    throw Error("filter: expected an output map to the model's " + std::to_string(truth.state_dim()) + " states, got " +
                std::to_string(filter.output_dim()) + " outputs");
  }
  // The filter's known-input map Gamma takes the truth's input g (issue 22); a filter without Gamma ignores it.
  const Eigen::Index q = filter.input_dim();
  if (q > 0 && q != truth.input_dim()) {
    throw Error("filter: expected a known-input map Gamma with " + std::to_string(truth.input_dim()) +
                " columns (the true model's input length q; 0: the truth has no G, D, so give it G = 0 to "
                "evaluate a filter that assumes an input), got " +
                std::to_string(q));
  }
}

void CheckWeight(const Eigen::MatrixXd& weight, Eigen::Index n, const std::string& name) {
  if (weight.size() == 0) return;
  RequireShape(name, weight, n, n);
  RequirePositiveSemidefinite(name, weight);
}

double WeightedTrace(const Eigen::MatrixXd& weight, const Eigen::MatrixXd& E) {
  if (weight.size() == 0) return E.trace();
  return weight.cwiseProduct(E).sum();  // tr(W E) for symmetric E
}

// E[e e^T] with e = x - O z from second moments (Mxx, Mxz, Mzz include the means).
Eigen::MatrixXd ErrorMoment(const Eigen::MatrixXd& Mxx, const Eigen::MatrixXd& Mxz, const Eigen::MatrixXd& Mzz,
                            const Eigen::MatrixXd& O) {
  Eigen::MatrixXd E = Mxx;
  if (O.size() == 0) {
    E -= Mxz;
    E -= Mxz.transpose();
    E += Mzz;
  } else {
    const Eigen::MatrixXd OMzx = O * Mxz.transpose();  // n x n
    E -= OMzx;
    E -= OMzx.transpose();
    E.noalias() += O * Mzz * O.transpose();
  }
  Symmetrize(E);
  return E;
}

}  // namespace detail

namespace {

using detail::CheckCompatible;
using detail::CheckWeight;
using detail::ErrorMoment;
using detail::WeightedTrace;

int ResolveHorizon(const Model& truth, const LinearFilter& filter, int steps) {
  if (steps >= 0) {
    truth.ResolveSteps(steps, "steps");
    if (filter.horizon() >= 0 && steps > filter.horizon()) {
      throw Error("steps: expected at most " + std::to_string(filter.horizon()) + " (the filter's horizon), got " +
                  std::to_string(steps));
    }
    return steps;
  }
  int T = -1;
  if (truth.horizon() >= 0) T = truth.horizon();
  if (filter.horizon() >= 0) T = T < 0 ? filter.horizon() : std::min(T, filter.horizon());
  if (T < 0) throw Error("steps: expected a number of steps (model and filter both have no horizon)");
  return T;
}

// Validates options, dimensions, weight and the known input g of an evaluation; returns the number of steps T.
template <typename Options>
int CheckEvaluation(const Model& truth, const LinearFilter& filter, const TimeSeries& g, const Options& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  CheckCompatible(truth, filter);
  CheckWeight(options.weight, truth.state_dim(), "options.weight");
  const int T = ResolveHorizon(truth, filter, options.steps);
  RequireKnownInput(truth, g, T);
  return T;
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

const char* ToString(StationaryMethod method) {
  switch (method) {
    case StationaryMethod::kJoint:
      return "joint";
    case StationaryMethod::kErrorCoordinates:
      return "error-coordinates";
  }
  return "?";
}

bool StationaryPerformanceOptions::IsValid(std::string* error) const {
  if (weight.size() > 0 && weight.rows() != weight.cols()) {
    if (error) *error = "weight: expected a square matrix";
    return false;
  }
  return true;
}

bool PerformanceOptions::IsValid(std::string* error) const {
  if (weight.size() > 0 && weight.rows() != weight.cols()) {
    if (error) *error = "weight: expected a square matrix";
    return false;
  }
  return true;
}

bool MonteCarloOptions::IsValid(std::string* error) const {
  if (runs < 2) {
    if (error) *error = "runs: expected at least 2 runs, got " + std::to_string(runs);
    return false;
  }
  if (weight.size() > 0 && weight.rows() != weight.cols()) {
    if (error) *error = "weight: expected a square matrix";
    return false;
  }
  return true;
}

PerformanceResult ExactPerformance(const Model& truth, const LinearFilter& filter, const PerformanceOptions& options) {
  return ExactPerformance(truth, filter, TimeSeries(0, 0), options);
}

PerformanceResult ExactPerformance(const Model& truth, const LinearFilter& filter, const TimeSeries& g,
                                   const PerformanceOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const int T = CheckEvaluation(truth, filter, g, options);
  const Eigen::Index n = truth.state_dim();

  PerformanceResult res;
  res.mse.resize(T + 1);
  res.weighted_mse.resize(T + 1);
  res.bias.resize(T + 1, n);
  if (options.store_error_moments) res.error_moment.reserve(static_cast<size_t>(T) + 1);

  // Joint state: covariances Sxx, Sxz, Szz and means mx, mz; z_0 is deterministic.
  const Eigen::Index nz = filter.state_dim();
  Eigen::MatrixXd Sxx = truth.P0();
  Eigen::MatrixXd Sxz = Eigen::MatrixXd::Zero(n, nz);
  Eigen::MatrixXd Szz = Eigen::MatrixXd::Zero(nz, nz);
  Eigen::VectorXd mx = truth.m0();
  Eigen::VectorXd mz = filter.z0();

  // E[e e^T] = Cov e + b b^T with b = E[e] = mx - O mz: the mean part is added to the error's covariance, not
  // formed from the second moments of x and z (whose means a known input makes large: no cancellation).
  auto record = [&](int k, const Eigen::MatrixXd& O) {
    const Eigen::VectorXd b = mx - ApplyOutput(O, mz);
    Eigen::MatrixXd E = ErrorMoment(Sxx, Sxz, Szz, O);
    E.noalias() += b * b.transpose();
    res.mse(k) = E.trace();
    res.weighted_mse(k) = WeightedTrace(options.weight, E);
    res.bias.row(k) = b.transpose();
    if (options.store_error_moments) res.error_moment.push_back(E);
  };
  record(0, filter.O0());

  Eigen::MatrixXd ASxz, CASxz, Sxy, Syy, KSyy, tmp;
  for (int k = 1; k <= T; ++k) {
    const StepPtr s = truth.step(k);
    const LinearFilterStepPtr f = filter.step(k);
    // x' = A x + G g + w;  y' = C x' + D g + v;  z' = K y' + Phi z + Gamma g (g moves the means only).
    ASxz.noalias() = s->A * Sxz;  // E[x' z^T]
    tmp.noalias() = s->A * Sxx;
    Sxx = s->Q;
    Sxx.noalias() += tmp * s->A.transpose();  // E[x' x'^T]
    Symmetrize(Sxx);
    Sxy.noalias() = Sxx * s->C.transpose();  // E[x' y'^T] (+ S = E[w v^T])
    if (s->has_cross_covariance()) Sxy += s->S;
    Syy = s->R;
    Syy.noalias() += s->C * Sxy;  // E[y' y'^T] = R + C Sxx C^T (+ C S + S^T C^T)
    if (s->has_cross_covariance()) Syy.noalias() += s->S.transpose() * s->C.transpose();
    CASxz.noalias() = s->C * ASxz;  // E[y' z^T]
    // Szz' = K Syy K^T + K E[y'z^T] Phi^T + Phi E[z y'^T] K^T + Phi Szz Phi^T
    Eigen::MatrixXd KCASxzPhit = f->K * CASxz * f->Phi.transpose();
    Eigen::MatrixXd Szz_new = f->Phi * Szz * f->Phi.transpose();
    Szz_new.noalias() += f->K * Syy * f->K.transpose();
    Szz_new += KCASxzPhit;
    Szz_new += KCASxzPhit.transpose();
    Symmetrize(Szz_new);
    Szz.swap(Szz_new);
    // Sxz' = E[x' y'^T] K^T + E[x' z^T] Phi^T
    Sxz.noalias() = Sxy * f->K.transpose();
    Sxz.noalias() += ASxz * f->Phi.transpose();
    // Means.
    const KnownInputTerms input = KnownInputAt(*s, g, k);
    mx = s->A * mx;
    if (input.state.size() > 0) mx += input.state;
    Eigen::VectorXd my = s->C * mx;
    if (input.measurement.size() > 0) my += input.measurement;
    mz = (f->Phi * mz + f->K * my).eval();
    if (f->Gamma.size() > 0) mz.noalias() += f->Gamma * g.row(k - 1).transpose();
    record(k, f->O);
    if (options.progress) options.progress(k, T);
  }
  res.summary.computation = "exact performance";
  res.summary.method = "joint second moments";
  res.summary.termination = Termination::kConverged;
  res.summary.iterations = T;
  res.summary.seconds = SecondsSince(start);
  return res;
}

MonteCarloResult MonteCarloPerformance(const Model& truth, const LinearFilter& filter,
                                       const MonteCarloOptions& options) {
  return MonteCarloPerformance(truth, filter, TimeSeries(0, 0), options);
}

MonteCarloResult MonteCarloPerformance(const Model& truth, const LinearFilter& filter, const TimeSeries& g,
                                       const MonteCarloOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const int T = CheckEvaluation(truth, filter, g, options);
  const TimeSeries no_input(0, 0);
  const TimeSeries& filter_input = filter.input_dim() > 0 ? g : no_input;  // a filter without Gamma ignores g
  const Eigen::Index n = truth.state_dim();
  const int R = options.runs;

  // Welford accumulators per time step.
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(T + 1), m2 = Eigen::VectorXd::Zero(T + 1);
  Eigen::VectorXd wmean = Eigen::VectorXd::Zero(T + 1), wm2 = Eigen::VectorXd::Zero(T + 1);
  TimeSeries bias = TimeSeries::Zero(T + 1, n);
  std::vector<Eigen::MatrixXd> moments;
  if (options.store_error_moments) moments.assign(static_cast<size_t>(T) + 1, Eigen::MatrixXd::Zero(n, n));

  for (int r = 0; r < R; ++r) {
    Rng rng(Rng::StreamSeed(options.seed, static_cast<std::uint64_t>(r)));
    const Trajectory tr = Simulate(truth, g, SimulationOptions{T, options.seed}, rng);
    const TimeSeries est = RunLinearFilter(filter, tr.y, filter_input);
    const TimeSeries err = tr.x - est;
    const double cnt = r + 1.0;
    for (int k = 0; k <= T; ++k) {
      const Eigen::VectorXd e = err.row(k).transpose();
      const double v = e.squaredNorm();
      const double wv = options.weight.size() == 0 ? v : e.dot(options.weight * e);
      double d = v - mean(k);
      mean(k) += d / cnt;
      m2(k) += d * (v - mean(k));
      d = wv - wmean(k);
      wmean(k) += d / cnt;
      wm2(k) += d * (wv - wmean(k));
      if (options.store_error_moments) moments[static_cast<size_t>(k)].noalias() += e * e.transpose();
    }
    bias += err;
    if (options.progress) options.progress(r + 1, R);
  }
  MonteCarloResult res;
  res.runs = R;
  res.mse = mean;
  res.weighted_mse = wmean;
  res.mse_std_error = (m2 / (R - 1.0) / static_cast<double>(R)).cwiseSqrt();
  res.weighted_mse_std_error = (wm2 / (R - 1.0) / static_cast<double>(R)).cwiseSqrt();
  res.bias = bias / static_cast<double>(R);
  if (options.store_error_moments) {
    for (auto& M : moments) M /= static_cast<double>(R);
    res.error_moment = std::move(moments);
  }
  res.summary.computation = "Monte Carlo performance";
  res.summary.method = "simulation with RunLinearFilter";
  res.summary.termination = Termination::kConverged;
  res.summary.iterations = R;
  res.summary.seconds = SecondsSince(start);
  return res;
}

}  // namespace kfx

namespace kfx::detail {
int CheckMonteCarloEvaluation(const Model& truth, const LinearFilter& filter, const MonteCarloOptions& options) {
  return CheckEvaluation(truth, filter, TimeSeries(0, 0), options);
}
}  // namespace kfx::detail
