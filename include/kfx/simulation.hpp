#pragma once
// Seeded, reproducible simulation of a Model. The generator is specified exactly (mt19937_64 with
// a 53-bit uniform and Box-Muller normals, seeds split by SplitMix64), so a seed gives the same
// trajectory on every platform and in every thread: run i of a batch uses StreamSeed(seed, i),
// independent of how runs are spread over threads or processes.
#include <Eigen/Dense>
#include <cstdint>
#include <random>
#include <vector>

#include "kfx/model.hpp"
#include "kfx/progress.hpp"

namespace kfx {

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  /// Uniform on (0, 1) with 53 random bits.
  double Uniform();
  /// Standard normal (Box-Muller, both values used).
  double Normal();
  /// A vector of n independent standard normals.
  Eigen::VectorXd Normal(Eigen::Index n);
  /// The seed of stream `stream` derived from `seed` (SplitMix64 mixing).
  static std::uint64_t StreamSeed(std::uint64_t seed, std::uint64_t stream);

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

/// A factor F with F F^T = M for a symmetric PSD matrix M (pivoted LDL^T; eigen-decomposition
/// fallback when pivots are not clean). Used to draw N(0, M) samples as F * normal.
Eigen::MatrixXd PsdFactor(const Eigen::Ref<const Eigen::MatrixXd>& M);

struct Trajectory {
  TimeSeries x;  ///< (T+1) x n: row k is x_k, row 0 the initial state.
  TimeSeries y;  ///< T x m: row k-1 is y_k.
};

struct SimulationOptions {
  int steps = -1;               ///< number of steps T (negative: the model's horizon)
  std::uint64_t seed = 1;       ///< the generator's seed (not used by the overload that takes an Rng)
  ProgressCallback progress{};  ///< (k, T) after step k of one trajectory
};

/// Draws x_0 ~ N(m0, P0) and then x_k, y_k for k = 1..T.
/// @throws kfx::Error if options.steps exceeds the model's horizon; kfx::NumericalError naming the step if the
/// trajectory stops being finite (a diverging model overflows): never a trajectory holding inf or NaN.
Trajectory Simulate(const Model& model, const SimulationOptions& options = SimulationOptions());

/// With the known input g (T x q, row k-1 = g_k; issue 22): x_k gets G_k g_k, y_k gets D_k g_k; with a
/// cross-covariance S, (w_k, v_k) is drawn jointly. @throws kfx::Error naming g when it does not fit the
/// model's G, D (kfx::RequireKnownInput), and as above.
Trajectory Simulate(const Model& model, const TimeSeries& g, const SimulationOptions& options);
Trajectory Simulate(const Model& model, const TimeSeries& g, const SimulationOptions& options, Rng& rng);
/// Draws the trajectory with an Rng the caller owns (used by batch and Monte Carlo runners);
/// options.seed is not used.
Trajectory Simulate(const Model& model, const SimulationOptions& options, Rng& rng);

/// `runs` independent trajectories; run i uses Rng(Rng::StreamSeed(options.seed, i)).
std::vector<Trajectory> SimulateBatch(const Model& model, int runs, const SimulationOptions& options);

}  // namespace kfx
