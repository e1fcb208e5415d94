// One Kalman filter step (predict + Joseph-form update) at n = 10, 100, 1000 with m = max(1, n/10).
// Counter GFLOP (a rate: GFLOP/s) counts the flops the step needs (not a naive count):
//   predict  A P A^T: 2 n^3 + 2 n^3 = 4 n^3 (two GEMMs)
//   update   U = P C^T: 2 n^2 m, S = C U + R: 2 n m^2, Cholesky m^3/3, K = U S^-1: 2 n m^2,
//            Joseph (I - K C) P (I - K C)^T + K R K^T in O(n^2 m): 8 n^2 m + 2 n m^2
// bench/run.sh divides the rate by the DGEMM rate measured in the same run (bench_dgemm).
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <random>

#include "kfx/kalman_filter.hpp"

namespace {

Eigen::MatrixXd Gaussian(Eigen::Index r, Eigen::Index c, std::mt19937_64& gen) {
  std::normal_distribution<double> d;
  Eigen::MatrixXd m(r, c);
  for (Eigen::Index j = 0; j < c; ++j)
    for (Eigen::Index i = 0; i < r; ++i) m(i, j) = d(gen);
  return m;
}

double StepFlops(double n, double m) { return 4 * n * n * n + 10 * n * n * m + 6 * n * m * m + m * m * m / 3; }

void BM_KalmanStep(benchmark::State& state) {
  const Eigen::Index n = state.range(0), m = std::max<Eigen::Index>(1, n / 10);
  std::mt19937_64 gen(1);
  kfx::ModelStep s;
  s.A = Gaussian(n, n, gen) / std::sqrt(static_cast<double>(n)) * 0.9;
  s.C = Gaussian(m, n, gen);
  const Eigen::MatrixXd G = Gaussian(n, n, gen);
  s.Q = G * G.transpose() / static_cast<double>(n);
  s.R = Eigen::MatrixXd::Identity(m, m);
  const Eigen::MatrixXd H = Gaussian(n, n, gen);
  kfx::Estimate e{Eigen::VectorXd::Zero(n), H * H.transpose() / static_cast<double>(n)};
  const Eigen::VectorXd y = Gaussian(m, 1, gen);
  for (auto _ : state) {
    kfx::UpdateResult u = kfx::Update(kfx::Predict(e, s), s, y);
    e = std::move(u.estimate);
    benchmark::DoNotOptimize(e.P.data());
  }
  state.counters["n"] = static_cast<double>(n);
  state.counters["m"] = static_cast<double>(m);
  state.counters["GFLOP"] = benchmark::Counter(StepFlops(static_cast<double>(n), static_cast<double>(m)) * 1e-9,
                                               benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

BENCHMARK(BM_KalmanStep)->Arg(10)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond)->UseRealTime();
