// The block-diagonal filter of 004 at its fixed point against the running filter and the machine's
// memory bandwidth, all in the same run; c = 2, d = 1, r = 20, random time-invariant subsystems:
//   BM_RunningStep/n  one step of the running filter (CoupledFilter::Step: covariance + estimate)
//   BM_SteadyStep/n   the steady-state filter (gain frozen at the fixed point, RunCoupledFilter's
//                     steady state), per step, run in groups of CoupledFilterOptions::kSteadyStateGroup;
//                     counter freeze_s: the one-time cost of freezing (gain, Fc, M_m)
//   BM_Triad/n        a[i] = b[i] + s c[i] over three arrays of n c r doubles (the size of G): the
//                     bandwidth the other two are measured against (counter GBps, 24 bytes per element)
// Counter bytes: the bytes each step must move (formulas below), so bytes / GBps is its memory-traffic
// bound; bench/run.sh prints the ratios. Times and rates are process CPU time (the machine may be shared). The
// estimates of both filters are checked against each other.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "coupled_bench_system.hpp"
#include "kfx/block_diagonal.hpp"
#include "methods/block_diagonal/block_diagonal_shared.hpp"

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

using kfx::bench::kC;
using kfx::bench::kD;
using kfx::bench::kR;
constexpr int kGroup = kfx::CoupledFilterOptions::kSteadyStateGroup;

kfx::CoupledStep MakeSystem(Index n) {
  std::mt19937_64 gen(1);
  return kfx::bench::MakeCoupledBenchSystem(n, gen);
}

kfx::TimeSeries Measurements(Index rows, Index n) {
  std::mt19937_64 gen(2);
  std::normal_distribution<double> N01;
  kfx::TimeSeries y(rows, n * kD);
  for (Index i = 0; i < y.size(); ++i) y.data()[i] = N01(gen);
  return y;
}

// Bytes per step. Running: G twice (pass 1 and pass 2), P read and written, F, H, V, R, the gain blocks
// J written and read, x, y, the prediction and innovation written and read, x written.
double RunningBytes(double n) {
  const double c = kC, d = kD, r = kR;
  return 8 * n * (2 * c * r + 2 * c * c + c * c + d * c + c * c + d * d + 2 * c * d + c + d + 2 * (c + d) + c);
}
// Steady, per step of a group of L: Y^T, E^T, F, H, J, Fc once per group; y; x_filt written by sweep 1
// and read and written by sweep 2.
double SteadyBytes(double n) {
  const double c = kC, d = kD, r = kR, L = kGroup;
  return 8 * n * ((d * r + c * r + 2 * c * c + 2 * c * d) / L + d + 3 * c);
}

// A filter at its fixed point: P the block-diagonal steady state (SolveBlockDiagonalSteadyState).
// Cached per n: Google Benchmark calls a benchmark function more than once.
const MatrixXd& SteadyP(const kfx::CoupledStep& s) {
  static std::map<Index, MatrixXd> cache;
  auto it = cache.find(s.n());
  if (it == cache.end()) {
    kfx::SteadyStateOptions o;
    // The frozen filter's distance to the running one is proportional to this tolerance (measured at n = 10^4:
    // 9.3e-10, 1.1e-11, 1.2e-13, 1.2e-14 for 1e-10, 1e-12, 1e-14, 1e-15; the running filter on the subsystems in
    // reversed order differs from itself by 3e-16), so the check x_vs_running needs P well inside 1e-10.
    o.tolerance = 1e-14;
    it = cache.emplace(s.n(), kfx::SolveBlockDiagonalSteadyState(s, o).P_filt).first;
  }
  return it->second;
}

void BM_RunningStep(benchmark::State& state) {
  const Index n = state.range(0);
  const kfx::CoupledStep s = MakeSystem(n);
  const kfx::TimeSeries y = Measurements(1, n);
  kfx::CoupledFilter filter(kfx::CoupledFilterKind::kBlockDiagonal, VectorXd::Zero(n * kC),
                            MatrixXd::Identity(kC, kC).replicate(1, n));
  const VectorXd y0 = y.row(0).transpose();
  filter.Step(s, y0);  // allocates the reused buffers (page faults are not per-step cost)
  for (auto _ : state) {
    filter.Step(s, y0);
    benchmark::DoNotOptimize(filter.x().data());
  }
  state.counters["n"] = static_cast<double>(n);
  state.counters["bytes"] = RunningBytes(static_cast<double>(n));
}

void BM_SteadyStep(benchmark::State& state) {
  const Index n = state.range(0);
  const kfx::CoupledStep s = MakeSystem(n);
  const MatrixXd& P = SteadyP(s);
  const kfx::TimeSeries y = Measurements(kGroup, n);
  const auto t0 = std::chrono::steady_clock::now();
  const kfx::detail::FrozenBlockDiagonal frozen(s, P, kGroup);
  const double freeze = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  kfx::TimeSeries x(kGroup + 1, n * kC), coupling(kGroup, kR);
  x.setZero();
  // Check: the same group by the running filter's step from P with its gain (after convergence the
  // running filter's gain is the frozen one to rounding).
  frozen.Run(y, 0, kGroup, &x, &coupling);
  kfx::CoupledFilter running(kfx::CoupledFilterKind::kBlockDiagonal, VectorXd::Zero(n * kC), P);
  double diff = 0.0;
  for (int j = 1; j <= kGroup; ++j) {
    running.Step(s, y.row(j - 1).transpose());
    diff =
        std::max(diff, (x.row(j).transpose() - running.x()).cwiseAbs().maxCoeff() / running.x().cwiseAbs().maxCoeff());
  }
  for (auto _ : state) {
    x.row(0) = x.row(kGroup);
    frozen.Run(y, 0, kGroup, &x, &coupling);
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["n"] = static_cast<double>(n);
  state.counters["group"] = kGroup;
  state.counters["bytes"] = SteadyBytes(static_cast<double>(n)) * kGroup;  // per iteration = one group
  state.counters["freeze_s"] = freeze;
  state.counters["x_vs_running"] = diff;
}

void BM_Triad(benchmark::State& state) {
  const Index m = state.range(0) * kC * kR;
  std::vector<double> a(m, 0.0), b(m, 1.0), c(m, 2.0);
  const double s = 0.5;
  for (auto _ : state) {
    double* __restrict pa = a.data();
    const double* __restrict pb = b.data();
    const double* __restrict pc = c.data();
    for (Index i = 0; i < m; ++i) pa[i] = pb[i] + s * pc[i];
    benchmark::DoNotOptimize(a.data());
    benchmark::ClobberMemory();
  }
  state.counters["n"] = static_cast<double>(state.range(0));
  state.counters["GBps"] =
      benchmark::Counter(24.0 * static_cast<double>(m) * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

BENCHMARK(BM_Triad)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RunningStep)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SteadyStep)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);
