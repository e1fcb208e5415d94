#pragma once
// The exact-performance engine (mathematics in docs/exact-performance.md): the true mean-square error of
// any linear filter z_k = Phi_k z_{k-1} + K_k y_k + Gamma_k g_k, estimate O_k z_k, run on any true model
// x_k = A_k x_{k-1} + G_k g_k + w_k, y_k = C_k x_k + D_k g_k + v_k. The joint second moments of (x_k, z_k) obey
//   [x_k]   [ A_k          0    ] [x_{k-1}]   [ G_k                      ]       [ I        0  ] [w_k]
//   [z_k] = [ K_k C_k A_k  Phi_k] [z_{k-1}] + [ K_k (C_k G_k + D_k) + Gamma_k ] g_k + [ K_k C_k  K_k] [v_k]
// propagated here block by block (Sxx, Sxz, Szz and the means), so the cost per step is that of a
// few products of the block sizes. With e_k = x_k - O_k z_k:
//   E[e_k e_k^T] = [I, -O_k] (Sigma_k + mu_k mu_k^T) [I, -O_k]^T,  MSE_k = tr E[e e^T],
//   weighted MSE_k = tr(W E[e e^T]) = tr(W Cov e_k) + E[e_k]^T W E[e_k].
// A true model with a cross-covariance S = E[w_k v_k^T] (kfx/model.hpp) enters through the noise term:
// its covariance is [[I, 0], [K C, K]] [[Q, S], [S^T, R]] [[I, 0], [K C, K]]^T. The known input g (deterministic)
// moves the means only: a filter that models it exactly (the Kalman filter's Gamma = (I - K C) G - K D) has a
// zero-mean error and the MSE of the model without input; one that ignores it (no Gamma) or mis-models it has
// a bias, E[e_k] != 0 (issue 22). The stationary engine refuses a true model with a known input (`truth`).
// Every method of kfx reports its true error through this one engine.
#include <Eigen/Dense>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "kfx/linear_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/progress.hpp"
#include "kfx/summary.hpp"

namespace kfx {

struct PerformanceOptions {
  /// Number of steps T (negative: the shorter horizon of model and filter; error if both unbounded).
  int steps = -1;
  /// n x n symmetric PSD weight W of the weighted MSE (e.g. a Sobolev Gram matrix); empty = I.
  Eigen::MatrixXd weight{};
  /// Keep E[e_k e_k^T] for every k (n^2 (T+1) doubles).
  bool store_error_moments = true;
  ProgressCallback progress{};
  bool IsValid(std::string* error) const;
};

struct PerformanceResult {       ///< The exact error statistics of a linear filter against a true model, k = 0..T.
  Eigen::VectorXd mse;           ///< length T+1: tr E[e_k e_k^T], k = 0..T
  Eigen::VectorXd weighted_mse;  ///< length T+1: tr(W E[e_k e_k^T])
  TimeSeries bias;               ///< (T+1) x n: E[e_k]
  std::vector<Eigen::MatrixXd> error_moment;  ///< E[e_k e_k^T], k = 0..T (if stored)
  Summary summary;                            ///< kConverged; iterations = T; seconds
};

/// Exact finite-horizon performance of `filter` on `truth` (z_0 deterministic, x_0 ~ N(m0, P0)).
/// @throws kfx::Error if the filter's measurement dimension differs from the model's, its output
///         dimension from the state dimension, or on an invalid weight/options; naming g when the truth has a
///         known input (G, D): use the overload with g.
PerformanceResult ExactPerformance(const Model& truth, const LinearFilter& filter,
                                   const PerformanceOptions& options = PerformanceOptions());
/// The same on a true model driven by the known input g (T x q, row k-1 = g_k, as RunFilter's; 0 columns when
/// the truth has no G, D): the means move by G_k g_k, D_k g_k and the filter's Gamma_k g_k.
/// @throws kfx::Error as above; naming g when it does not fit the truth's G, D (kfx::RequireKnownInput: q
///         columns, at least T rows, finite); naming filter when its Gamma has columns other than the truth's q.
PerformanceResult ExactPerformance(const Model& truth, const LinearFilter& filter, const TimeSeries& g,
                                   const PerformanceOptions& options = PerformanceOptions());

enum class StationaryMethod {
  kJoint,             ///< Lyapunov equation of the joint (x, z) system: true system and filter stable.
  kErrorCoordinates,  ///< consistent filter (Phi = (I - K C) A, O = I): Lyapunov equation of the error.
};
const char* ToString(StationaryMethod method);
template <>
struct EnumValues<StationaryMethod> {
  static constexpr StationaryMethod kAll[] = {StationaryMethod::kJoint, StationaryMethod::kErrorCoordinates};
};

struct StationaryPerformanceOptions {
  /// n x n symmetric PSD weight W of the weighted MSE (empty = I), as in PerformanceOptions.
  Eigen::MatrixXd weight{};
  bool IsValid(std::string* error) const;
};

struct StationaryPerformance {  ///< Stationary error covariance of a time-invariant filter and truth.
  StationaryMethod method = StationaryMethod::kJoint;             ///< the equation solved (when summary.ok())
  Eigen::MatrixXd error_cov;                                      ///< stationary E[e e^T] (empty unless summary.ok())
  double mse = std::numeric_limits<double>::infinity();           ///< tr error_cov (inf when none)
  double weighted_mse = std::numeric_limits<double>::infinity();  ///< tr(W error_cov)
  /// kConverged; kUnstable when the error has no stationary value (the filter is unstable, or the true
  /// system is unstable and the filter is not consistent with it: the message says which; use
  /// ExactPerformance over a finite horizon); kSingular / kFailed from the Lyapunov solve.
  /// relative_residual: of the Lyapunov solve.
  Summary summary;
};

/// The true model's part of the stationary joint equation, computed once and shared by every filter
/// evaluated on it (ExactStationaryPerformance below): the real Schur form A = U T U^T (LAPACK DGEES),
/// rho(A) from it, and, when rho(A) < 1, the stationary state covariance S^xx = A S^xx A^T + Q (the
/// x-block of (4) in docs/exact-performance.md) with its residual. Copies share the computed parts.
/// Cost: the Schur form (about 25 n^3 flops) and the blocked Schur solve (about 9 n^3) once.
/// @throws kfx::Error if the model is time-varying.
class StationaryTruth {
 public:
  explicit StationaryTruth(const Model& truth);
  const Model& model() const;
  double spectral_radius() const;  ///< rho(A)
  /// S^xx (n x n) when rho(A) < 1 and its solve succeeded; empty otherwise.
  const Eigen::MatrixXd& state_covariance() const;
  /// The outcome of the S^xx solve (kUnstable when rho(A) >= 1; relative_residual of X = A X A^T + Q).
  const Summary& summary() const;
  struct Impl;  ///< opaque (src/core/stationary_performance.cpp)

 private:
  friend StationaryPerformance ExactStationaryPerformance(const StationaryTruth& truth, const LinearFilter& filter,
                                                          const StationaryPerformanceOptions& options);
  std::shared_ptr<const Impl> impl_;
};

/// Stationary error of a time-invariant filter on a time-invariant model.
/// Uses the joint Lyapunov equation when both the true system (rho(A) < 1) and the filter
/// (rho(Phi) < 1) are stable; otherwise, for a consistent filter (n_z = n, O = I,
/// Phi = (I - K C) A) with rho((I - K C) A) < 1, the error-coordinates equation
///   E = F E F^T + (I - K C) Q (I - K C)^T + K R K^T,  F = (I - K C) A;
/// otherwise summary.termination is kUnstable (the error is not stationary; use ExactPerformance).
/// The joint equation is solved block by block on the real Schur forms of A and Phi (recursive blocked
/// Bartels-Stewart), the error-coordinates equation by SolveDiscreteLyapunov (LyapunovMethod::kSchur).
/// @throws kfx::Error if either is time-varying, dimensions differ, or the weight is not n x n PSD; naming truth
///         when it has a known input (G, D): the stationary mean depends on the input sequence (use ExactPerformance
///         with g; the error covariance is that of the model without G, D).
StationaryPerformance ExactStationaryPerformance(
    const Model& truth, const LinearFilter& filter,
    const StationaryPerformanceOptions& options = StationaryPerformanceOptions());

/// The same with the true model's part computed once (StationaryTruth): evaluating many filters on one
/// model solves only the filter's blocks of (4) per filter: the cross block S^xz = A S^xz Phi^T +
/// (A S^xx A^T + Q) C^T K^T (a Stein equation on the Schur forms of A and Phi) and the filter block
/// S^zz = Phi S^zz Phi^T + K (C S^xx C^T + R) K^T + H + H^T, H = K C A S^xz Phi^T (docs/exact-performance.md,
/// section 4). Same results and contract as the overload above.
StationaryPerformance ExactStationaryPerformance(
    const StationaryTruth& truth, const LinearFilter& filter,
    const StationaryPerformanceOptions& options = StationaryPerformanceOptions());

struct MonteCarloOptions {
  int runs = 1000;                   ///< number of independent runs, >= 2
  std::uint64_t seed = 1;            ///< run i uses Rng::StreamSeed(seed, i)
  int steps = -1;                    ///< as in PerformanceOptions
  Eigen::MatrixXd weight{};          ///< as in PerformanceOptions
  bool store_error_moments = false;  ///< average e_k e_k^T over runs
  ProgressCallback progress{};
  bool IsValid(std::string* error) const;
};

struct MonteCarloResult {                     ///< Monte Carlo error statistics of a filter over `runs` runs, k = 0..T.
  int runs = 0;                               ///< number of simulated runs
  Eigen::VectorXd mse;                        ///< sample mean of |e_k|^2, k = 0..T
  Eigen::VectorXd mse_std_error;              ///< its standard error (sample std / sqrt(runs))
  Eigen::VectorXd weighted_mse;               ///< sample mean of e_k^T W e_k
  Eigen::VectorXd weighted_mse_std_error;     ///< its standard error
  TimeSeries bias;                            ///< sample mean of e_k
  std::vector<Eigen::MatrixXd> error_moment;  ///< sample mean of e_k e_k^T (if stored)
  Summary summary;                            ///< kConverged; iterations = runs; seconds
};

/// Monte Carlo estimate of the same quantities: simulate the true model, run the filter online
/// (RunLinearFilter), average the errors. Results do not depend on how runs are scheduled.
/// @throws kfx::Error as ExactPerformance, for runs < 2, or for steps beyond a horizon (or not given when
///         model and filter have none).
MonteCarloResult MonteCarloPerformance(const Model& truth, const LinearFilter& filter,
                                       const MonteCarloOptions& options = MonteCarloOptions());
/// The same with the known input g (as ExactPerformance's): Simulate(truth, g, ...) and RunLinearFilter(filter,
/// y, g) (a filter without Gamma runs without g). @throws kfx::Error as ExactPerformance with g and as above.
MonteCarloResult MonteCarloPerformance(const Model& truth, const LinearFilter& filter, const TimeSeries& g,
                                       const MonteCarloOptions& options = MonteCarloOptions());

}  // namespace kfx
