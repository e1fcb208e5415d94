// One step (covariance + estimate update) of the coupled-subsystem filters of 004, c = 2, d = 1,
// r = 20, random time-invariant subsystems:
//   BM_BlockDiagonalStep/n  the O(n r^2) block-diagonal filter, eqs. (8)-(17), n = 1e3 .. 1e6
//   BM_BandedStep/n         the banded filter (process noise blocks precomputed, as in a banded EKF)
//   BM_FullStep/n           the full Kalman filter on the stacked system (structured, dense P)
// Counter GFLOP (a rate) counts the flops each step needs (formulas below); bench/run.sh prints the
// per-step times, the ratios (linearity in n, full / block-diagonal at n = 2088) and the GFLOP/s.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <random>

#include "coupled_bench_system.hpp"
#include "kfx/block_diagonal.hpp"

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

using kfx::bench::kC;
using kfx::bench::kD;
using kfx::bench::kR;

kfx::CoupledStep MakeSystem(Index n, std::mt19937_64& gen) { return kfx::bench::MakeCoupledBenchSystem(n, gen); }

double BlockFlops(double n) {
  const double c = kC, d = kD, r = kR;
  // Pass 1: Z = R_c^{-T} H G 2ncdr, N += Z^T Z (lower triangle) n d r(r+1), Y^T nu 2ndr; pass 2:
  // W = G Fc with Fc triangular n c r(r+1), Gram blocks n c(c+1) r, G mu_u 2ncr; the per-block
  // kernels about 4c^3 + 6c^2d + 4cd^2 + d^3 and the prediction 2nc(c+d).
  return n * (2 * c * d * r + d * r * (r + 1) + 2 * d * r + c * r * (r + 1) + c * (c + 1) * r + 2 * c * r +
              4 * c * c * c + 6 * c * c * d + 4 * c * d * d + d * d * d + 2 * c * (c + d));
}
double BandedFlops(double n) {
  const double c = kC, d = kD;
  return n * (4 * c * c * c + 6 * c * c * d + 4 * c * d * d + d * d * d + 4 * c * d);
}
double FullFlops(double n) {
  const double N = n * kC, m = n * kD;
  // predict 4 c N^2 + N^2 r, H P 2 d N^2 ... dominated by L^{-1} H P (m^2 N) and P -= W^T W (N^2 m).
  return 4 * kC * N * N + N * N * kR + 2 * kD * N * N + 2 * m * m * kC + m * m * m / 3 + m * m * N + N * N * m;
}

template <kfx::CoupledFilterKind Kind>
void BM_Step(benchmark::State& state) {
  const Index n = state.range(0);
  std::mt19937_64 gen(1);
  const kfx::CoupledStep s = MakeSystem(n, gen);
  const MatrixXd P0 = MatrixXd::Identity(kC, kC).replicate(1, n);
  kfx::CoupledFilter filter(Kind, VectorXd::Zero(n * kC), P0);
  const MatrixXd Qb = kfx::BandedProcessNoise(s);
  std::normal_distribution<double> N01;
  VectorXd y(n * kD);
  for (Index i = 0; i < y.size(); ++i) y(i) = N01(gen);
  // The banded step with its process noise precomputed, as a banded EKF would (V, G, U fixed).
  MatrixXd Pb = P0;
  VectorXd xb = VectorXd::Zero(n * kC);
  // One untimed step first: it allocates the filter's reused buffers (P, J, x, innovation: 0.1 GB at
  // n = 1e6), whose first-touch page faults are not part of a running filter's per-step cost.
  if (Kind != kfx::CoupledFilterKind::kBanded) filter.Step(s, y);
  for (auto _ : state) {
    if (Kind == kfx::CoupledFilterKind::kBanded) {
      const VectorXd nu = y - kfx::CoupledPredictMeasurement(s, xb);
      kfx::BandedCovarianceStep st = kfx::BandedCovarianceUpdate(s, Pb, Qb);
      xb = kfx::CoupledPropagate(s, xb) + kfx::BlockDiagonalApply(st.K, kD, nu);
      Pb = std::move(st.P_filt);
      benchmark::DoNotOptimize(xb.data());
    } else {
      filter.Step(s, y);
      benchmark::DoNotOptimize(filter.x().data());
    }
  }
  const double nn = static_cast<double>(n);
  const double flops = Kind == kfx::CoupledFilterKind::kFull     ? FullFlops(nn)
                       : Kind == kfx::CoupledFilterKind::kBanded ? BandedFlops(nn)
                                                                 : BlockFlops(nn);
  state.counters["n"] = nn;
  state.counters["GFLOP"] = benchmark::Counter(flops * 1e-9, benchmark::Counter::kIsIterationInvariantRate);
}

void BM_BlockDiagonalStep(benchmark::State& s) { BM_Step<kfx::CoupledFilterKind::kBlockDiagonal>(s); }
void BM_BandedStep(benchmark::State& s) { BM_Step<kfx::CoupledFilterKind::kBanded>(s); }
void BM_FullStep(benchmark::State& s) { BM_Step<kfx::CoupledFilterKind::kFull>(s); }

}  // namespace

BENCHMARK(BM_BlockDiagonalStep)
    ->Arg(1000)
    ->Arg(2088)
    ->Arg(10000)
    ->Arg(100000)
    ->Arg(1000000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_BandedStep)->Arg(1000)->Arg(2088)->Arg(1000000)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_FullStep)->Arg(250)->Arg(500)->Arg(1000)->Arg(2088)->Unit(benchmark::kMillisecond)->UseRealTime();
