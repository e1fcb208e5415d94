// Paper 000 at scale: the offline schedule of Algorithm 2.3 for the damped wave equation (state
// dimension N = 2 N_f), from the stationary prior S_0 = S (discrete Lyapunov, SLICOT SB03MD) until K_k
// and Q_k S~_k change by <= 1e-10 (relative, the library default; pinv threshold 1e-8) or 20000 steps, with A applied
// through the band LU of the implicit-Euler matrix. One iteration per size. Counters: the Lyapunov solve's seconds,
// steps to convergence, milliseconds per step, peak resident memory of the process (monotone over the run: sizes
// ascend).
//   OPENBLAS_NUM_THREADS=1 ./build/bench/bench_subspace_filter --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <chrono>

#include "kfx/damped_wave.hpp"
#include "kfx/riccati.hpp"
#include "kfx/subspace_filter.hpp"

namespace {

double PeakRssMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

void BM_SubspaceScheduleToConvergence(benchmark::State& state) {
  kfx::DampedWaveOptions o;
  o.fine_nodes = static_cast<int>(state.range(0));
  o.coarse_nodes = static_cast<int>(state.range(1));
  const kfx::DampedWaveProblem p = kfx::BuildDampedWave(o);
  const Eigen::Index N = p.fine.step.state_dim();
  kfx::SubspaceFilterOptions so;
  so.store_schedule = false;
  so.apply_A = p.fine.apply_A;
  so.max_steps = 20000;
  so.stationary_prior = true;
  kfx::SubspaceFilterSchedule s;
  double lyap_seconds = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    Eigen::MatrixXd S = kfx::SolveDiscreteLyapunov(p.fine.step.A, p.fine.step.Q).X;
    S = 0.5 * (S + S.transpose());
    lyap_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    s = kfx::ComputeSubspaceFilterSchedule(p.fine.step, S, p.subspace, so);
    benchmark::DoNotOptimize(s.K.data());
  }
  state.counters["lyapunov_s"] = lyap_seconds;
  state.counters["schedule_s"] = s.summary.seconds;
  state.counters["N"] = static_cast<double>(N);
  state.counters["n"] = static_cast<double>(p.subspace.reduced_dim());
  state.counters["steps"] = s.steps;
  state.counters["converged"] = s.summary.ok() ? 1 : 0;
  state.counters["last_change"] = s.summary.relative_change;
  state.counters["rank_S~"] = s.pinv_rank.back();
  state.counters["ms_per_step"] = 1e3 * s.summary.seconds / std::max(1, s.steps);
  state.counters["peak_rss_MB"] = PeakRssMb();
}

BENCHMARK(BM_SubspaceScheduleToConvergence)
    ->Args({65, 5})
    ->Args({251, 20})
    ->Args({1000, 12})
    ->Args({1028, 20})
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

}  // namespace
