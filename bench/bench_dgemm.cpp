// Single-thread DGEMM throughput through Eigen with EIGEN_USE_BLAS (i.e. OpenBLAS dgemm): the
// reference speed against which the O(n^3) solvers in bench_riccati.cpp can be judged.
// Run with OPENBLAS_NUM_THREADS=1. Counter GFLOP (shown per second) = 2 n^3 * iterations / time.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>

namespace {

void BM_Dgemm(benchmark::State& state) {
  const Eigen::Index n = state.range(0);
  Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n);
  Eigen::MatrixXd b = Eigen::MatrixXd::Random(n, n);
  Eigen::MatrixXd c(n, n);
  for (auto _ : state) {
    c.noalias() = a * b;
    benchmark::DoNotOptimize(c.data());
    benchmark::ClobberMemory();
  }
  const double flops = 2.0 * static_cast<double>(n) * static_cast<double>(n) * static_cast<double>(n);
  // Displayed as "GFLOP=<x>/s": x GFLOP per second of (real) time.
  state.counters["GFLOP"] = benchmark::Counter(flops * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

BENCHMARK(BM_Dgemm)->Arg(1000)->Unit(benchmark::kMillisecond)->UseRealTime();
