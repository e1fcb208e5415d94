#pragma once
// The random time-invariant coupled system of the block-diagonal benchmarks (bench_block_diagonal,
// bench_block_diagonal_steady): n subsystems of c = 2 states, d = 1 measurement, r = 20 shared inputs.
#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "kfx/block_diagonal.hpp"

namespace kfx::bench {

constexpr Eigen::Index kC = 2, kD = 1, kR = 20;

inline CoupledStep MakeCoupledBenchSystem(Eigen::Index n, std::mt19937_64& gen) {
  using Eigen::Index;
  using Eigen::MatrixXd;
  std::normal_distribution<double> N01;
  CoupledStep s;
  s.F.resize(kC, n * kC);
  s.H.resize(kD, n * kC);
  s.V.resize(kC, n * kC);
  s.R.resize(kD, n * kD);
  s.G.resize(n * kC, kR);
  for (Index i = 0; i < n; ++i) {
    s.F.middleCols(i * kC, kC) << 0.95, 0.1 * N01(gen), 0.0, 0.95;
    s.H.middleCols(i * kC, kC) << 1.0 + 0.1 * N01(gen), 0.5 * N01(gen);
    s.V.middleCols(i * kC, kC) = 1e-2 * MatrixXd::Identity(kC, kC);
    s.R.middleCols(i * kD, kD).setConstant(1.0);
  }
  for (Index j = 0; j < kR; ++j)
    for (Index i = 0; i < n * kC; ++i) s.G(i, j) = N01(gen) / std::sqrt(static_cast<double>(kR));
  s.U = MatrixXd::Identity(kR, kR);
  return s;
}

}  // namespace kfx::bench
