// Filter DARE: kfx structure-preserving doubling vs the generalized Schur method (kfx kSchur,
// which is SLICOT SB02OD), for n = 50, 100, 200, 400, m = n / 2, a seeded random A with spectral
// radius 0.95 and SPD Q, R. Counters: relative residual of the result, doubling steps, refinement
// steps (DareOptions::refine, on by default for both methods). BM_DareDoublingIteration times the
// doubling iteration alone (no refinement, gains or certificate) with its flop count as a rate.
// Run with OPENBLAS_NUM_THREADS=1.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "kfx/riccati.hpp"
#include "riccati/dare_internal.hpp"

namespace {

struct Problem {
  Eigen::MatrixXd A, C, Q, R;
};

Eigen::MatrixXd Gaussian(std::mt19937_64& gen, Eigen::Index r, Eigen::Index c) {
  std::normal_distribution<double> dist;
  Eigen::MatrixXd m(r, c);
  for (Eigen::Index j = 0; j < c; ++j)
    for (Eigen::Index i = 0; i < r; ++i) m(i, j) = dist(gen);
  return m;
}

Eigen::MatrixXd Spd(std::mt19937_64& gen, Eigen::Index n) {
  const Eigen::MatrixXd g = Gaussian(gen, n, n);
  Eigen::MatrixXd s = g * g.transpose() / static_cast<double>(n);
  s.diagonal().array() += 0.1;
  return 0.5 * (s + s.transpose());
}

Problem MakeProblem(Eigen::Index n) {
  std::mt19937_64 gen(20240 + static_cast<unsigned>(n));
  Problem p;
  p.A = Gaussian(gen, n, n);
  p.A *= 0.95 / p.A.eigenvalues().cwiseAbs().maxCoeff();
  p.C = Gaussian(gen, n / 2, n);
  p.Q = Spd(gen, n);
  p.R = Spd(gen, n / 2);
  return p;
}

void RunDare(benchmark::State& state, kfx::DareMethod method) {
  const Problem p = MakeProblem(state.range(0));
  kfx::DareOptions options;
  options.method = method;
  kfx::DareSolution sol;
  for (auto _ : state) {
    sol = kfx::SolveFilterDare(p.A, p.C, p.Q, p.R, options);
    benchmark::DoNotOptimize(sol.P_pred.data());
  }
  if (!sol.summary.ok()) state.SkipWithError(sol.summary.BriefReport().c_str());
  state.counters["residual"] = sol.summary.relative_residual;
  state.counters["steps"] = sol.summary.iterations;
  state.counters["refine"] = sol.refinement_steps;
}

void BM_DareDoubling(benchmark::State& state) { RunDare(state, kfx::DareMethod::kDoubling); }

// The doubling iteration of SolveFilterDare alone (detail::SolveDareByDoubling, a fresh buffer pool per solve as
// in SolveFilterDare). Counter GFLOP: its flop count over its time, (44/3 (k - 1) + 23/3) n^3 flops for k steps:
// per step W = G H (2 n^3), DGETRF (2/3), W^{-1} A and W^{-1} G (DGETRS, 2 + 2), H Y1 (2), the lower triangle of
// A^T (H Y1) (1), the congruence (DTRMM + DSYR2K, 3) and A_{k+1} (2); the last step stops after the increment
// of H (dare_doubling.cpp). bench/run.sh prints it as a fraction of the DGEMM rate of the same run.
void BM_DareDoublingIteration(benchmark::State& state) {
  const Problem p = MakeProblem(state.range(0));
  const kfx::DareOptions options;
  kfx::detail::DareCandidate c;
  for (auto _ : state) {
    kfx::detail::MatrixPool pool;
    c = kfx::detail::SolveDareByDoubling(p.A, p.C, p.Q, p.R, options, &pool);
    benchmark::DoNotOptimize(c.P.data());
  }
  if (c.termination != kfx::Termination::kConverged) state.SkipWithError(c.message.c_str());
  const double n3 = std::pow(static_cast<double>(state.range(0)), 3);
  state.counters["steps"] = c.iterations;
  state.counters["GFLOP"] = benchmark::Counter((44.0 / 3 * (c.iterations - 1) + 23.0 / 3) * n3 * 1e-9,
                                               benchmark::Counter::kIsIterationInvariantRate);
}
void BM_DareSchurSb02od(benchmark::State& state) { RunDare(state, kfx::DareMethod::kSchur); }

}  // namespace

BENCHMARK(BM_DareDoubling)->Arg(50)->Arg(100)->Arg(200)->Arg(400)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DareDoublingIteration)
    ->Arg(50)
    ->Arg(100)
    ->Arg(200)
    ->Arg(400)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_DareSchurSb02od)->Arg(50)->Arg(100)->Arg(200)->Arg(400)->Unit(benchmark::kMillisecond)->UseRealTime();
