// Paper 000's stationary analysis at scale (issue 24's "paper-000 analysis at N_f = 1000 in <= 20 s of Lyapunov
// + build"): the damped wave with N_f = 1000 fine nodes (state N = 2000, rho(A) = 0.9975) and N_c = 12 coarse ones,
// the coarse Galerkin model's steady-state Kalman filter (n_z = 24, estimate = prolongation z) as a LinearFilter,
// and its exact stationary error through the engine. One iteration per repetition, three parts timed:
//   build_s   BuildDampedWave (the fine and coarse models, the subspace)
//   truth_s   StationaryTruth: the true model's part of the joint equation (DGEES of A and S^xx on its Schur form),
//             computed once per model and shared by every filter evaluated on it
//   filter_s  the coarse filter's DARE and its blocks of the joint equation (ExactStationaryPerformance)
// Counters also: the residual of S^xx and the filter's stationary MSE. bench/run.sh prints build + truth against
// the 20 s target, with the DGEMM rate of the same run.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <chrono>

#include "kfx/damped_wave.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/performance.hpp"

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

double Since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void BM_Paper000Stationary(benchmark::State& state) {
  kfx::DampedWaveOptions o;
  o.fine_nodes = static_cast<int>(state.range(0));
  o.coarse_nodes = static_cast<int>(state.range(1));
  double build = 0, truth_s = 0, filter_s = 0, residual = 0, mse = 0;
  Index N = 0;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    const kfx::DampedWaveProblem p = kfx::BuildDampedWave(o);
    build = Since(t0);
    N = p.fine.step.state_dim();
    t0 = std::chrono::steady_clock::now();
    const kfx::StationaryTruth truth(kfx::Model(p.fine.step, VectorXd::Zero(N), MatrixXd::Identity(N, N)));
    truth_s = Since(t0);
    t0 = std::chrono::steady_clock::now();
    const kfx::ModelStep& c = p.coarse.step;
    const kfx::DareSolution dare = kfx::SteadyStateDare(c);
    kfx::LinearFilterStep f;
    f.K = dare.filter_gain;
    f.Phi = (MatrixXd::Identity(c.state_dim(), c.state_dim()) - f.K * c.C) * c.A;
    f.O = p.prolongation;
    const kfx::StationaryPerformance perf =
        kfx::ExactStationaryPerformance(truth, kfx::LinearFilter(f, VectorXd::Zero(c.state_dim()), p.prolongation));
    filter_s = Since(t0);
    if (!truth.summary().ok() || !perf.summary.ok()) {
      state.SkipWithError((truth.summary().BriefReport() + "; " + perf.summary.BriefReport()).c_str());
      break;
    }
    residual = truth.summary().relative_residual;
    mse = perf.mse;
  }
  state.counters["N"] = static_cast<double>(N);
  state.counters["build_s"] = build;
  state.counters["truth_s"] = truth_s;
  state.counters["filter_s"] = filter_s;
  state.counters["residual"] = residual;
  state.counters["mse"] = mse;
}

}  // namespace

BENCHMARK(BM_Paper000Stationary)->Args({1000, 12})->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();
