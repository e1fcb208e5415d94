// Monte Carlo spread over ranks: the compensated partial sums of a range of runs and the result from the
// sums over all runs (include/kfx/distributed.hpp).
#include "kfx/distributed.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/performance_internal.hpp"
#include "distributed/compensated_sum.hpp"
#include "kfx/error.hpp"
#include "kfx/simulation.hpp"

namespace kfx {

using detail::TwoSum;
using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

std::vector<double> MonteCarloPartialSums(const Model& truth, const LinearFilter& filter,
                                          const MonteCarloOptions& options, int first_run, int count) {
  const int T = detail::CheckMonteCarloEvaluation(truth, filter, options);
  if (first_run < 0 || count < 0 || count > options.runs - first_run) {
    throw Error("runs: expected a range within [0, " + std::to_string(options.runs) + "), got [" +
                std::to_string(first_run) + ", " + std::to_string(first_run + count) + ")");
  }
  const Index n = truth.state_dim();
  const Index steps = T + 1;
  const Index size = 4 * steps + steps * n + (options.store_error_moments ? steps * n * n : 0);
  std::vector<double> sums(static_cast<size_t>(2 * size), 0.0);
  double* s = sums.data();
  for (int run = first_run; run < first_run + count; ++run) {
    Rng rng(Rng::StreamSeed(options.seed, static_cast<std::uint64_t>(run)));
    const Trajectory tr = Simulate(truth, SimulationOptions{T, options.seed}, rng);
    const TimeSeries err = tr.x - RunLinearFilter(filter, tr.y);
    for (Index k = 0; k < steps; ++k) {
      const VectorXd e = err.row(k).transpose();
      const double v = e.squaredNorm();
      const double wv = options.weight.size() == 0 ? v : e.dot(options.weight * e);
      CompensatedAccumulate(v, s + 2 * k);
      CompensatedAccumulate(v * v, s + 2 * (steps + k));
      CompensatedAccumulate(wv, s + 2 * (2 * steps + k));
      CompensatedAccumulate(wv * wv, s + 2 * (3 * steps + k));
      double* b = s + 2 * (4 * steps + k * n);
      for (Index i = 0; i < n; ++i) CompensatedAccumulate(e(i), b + 2 * i);
      if (options.store_error_moments) {
        double* m = s + 2 * (4 * steps + steps * n + k * n * n);
        for (Index j = 0; j < n; ++j) {
          for (Index i = 0; i < n; ++i) CompensatedAccumulate(e(i) * e(j), m + 2 * (j * n + i));
        }
      }
    }
    if (options.progress) options.progress(run - first_run + 1, count);
  }
  return sums;
}

namespace {

// (S2 - S1^2 / R) from compensated S1, S2, with the products and the difference in double-double.
double CenteredSum(const double* s1, const double* s2, double R) {
  const double qh = s1[0] / R;
  const double ql = (std::fma(-qh, R, s1[0]) + s1[1]) / R;  // S1 / R = qh + ql
  const double p = s1[0] * qh;
  const double pe = std::fma(s1[0], qh, -p) + s1[0] * ql + s1[1] * qh;  // S1^2 / R = p + pe
  double t, e;
  TwoSum(s2[0], -p, &t, &e);
  return t + (e + s2[1] - pe);
}

}  // namespace

MonteCarloResult MonteCarloFromSums(const Model& truth, const LinearFilter& filter, const MonteCarloOptions& options,
                                    const std::vector<double>& sums) {
  const int T = detail::CheckMonteCarloEvaluation(truth, filter, options);
  const Index n = truth.state_dim(), steps = T + 1;
  const Index size = 4 * steps + steps * n + (options.store_error_moments ? steps * n * n : 0);
  if (static_cast<Index>(sums.size()) != 2 * size) {
    throw Error("sums: expected " + std::to_string(2 * size) + " numbers, got " + std::to_string(sums.size()));
  }
  const double R = options.runs;
  const double* s = sums.data();
  MonteCarloResult res;
  res.runs = options.runs;
  res.mse.resize(steps);
  res.weighted_mse.resize(steps);
  res.mse_std_error.resize(steps);
  res.weighted_mse_std_error.resize(steps);
  res.bias.resize(steps, n);
  for (Index k = 0; k < steps; ++k) {
    res.mse(k) = CompensatedValue(s + 2 * k) / R;
    res.weighted_mse(k) = CompensatedValue(s + 2 * (2 * steps + k)) / R;
    const double m2 = std::max(0.0, CenteredSum(s + 2 * k, s + 2 * (steps + k), R));
    const double wm2 = std::max(0.0, CenteredSum(s + 2 * (2 * steps + k), s + 2 * (3 * steps + k), R));
    res.mse_std_error(k) = std::sqrt(m2 / (R - 1.0) / R);
    res.weighted_mse_std_error(k) = std::sqrt(wm2 / (R - 1.0) / R);
    for (Index i = 0; i < n; ++i) res.bias(k, i) = CompensatedValue(s + 2 * (4 * steps + k * n + i)) / R;
    if (options.store_error_moments) {
      MatrixXd M(n, n);
      const double* m = s + 2 * (4 * steps + steps * n + k * n * n);
      for (Index j = 0; j < n; ++j) {
        for (Index i = 0; i < n; ++i) M(i, j) = CompensatedValue(m + 2 * (j * n + i)) / R;
      }
      res.error_moment.push_back(std::move(M));
    }
  }
  return res;
}

}  // namespace kfx
