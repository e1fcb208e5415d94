#pragma once
// Every method on one model, and the exact account of what each costs (`kfx compare`, kfx.compare):
// a method specification (method_spec.hpp) is resolved against the true model into the method's
// LinearFilter (through the method's own *AsLinearFilter adapter) for the exact-performance engine,
// and into the method's own online implementation for data (the Kalman filter's RunFilter, the
// coupled filters' RunCoupledFilter, RunLinearFilter for the others). Compare puts one row per method
// beside the optimal Kalman filter on the true model.
#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "kfx/block_diagonal.hpp"
#include "kfx/continuous_model_file.hpp"
#include "kfx/linear_filter.hpp"
#include "kfx/method_spec.hpp"
#include "kfx/model.hpp"
#include "kfx/performance.hpp"
#include "kfx/progress.hpp"

namespace kfx {

/// The true model of a comparison: a plain model, a coupled one (its dense form in `model`), or a
/// continuous-time one (in `model` its exact discrete-time equivalent at the data's grid, state
/// x_k = [z(t_k); int z over the last step], 2p numbers: SampledAtFileGrid).
struct ComparisonModel {
  Model model;
  std::optional<CoupledSystem> coupled;           ///< set for coupled models (blockdiag and banded need it)
  std::optional<ContinuousModelFile> continuous;  ///< set for continuous-time models (sampled needs it)
};

/// Reads a model file ("kfx-model"), a coupled model file ("kfx-coupled-model") or a continuous-time
/// model file ("kfx-continuous-model"), by its "format".
/// @throws kfx::Error naming the file and the field.
ComparisonModel LoadComparisonModel(const std::string& path);

struct MethodOptions {
  /// Horizon T of time-varying schedules (>= 1).
  int steps = 100;
  /// Build the time-invariant (stationary) form where a method has one: `kalman` becomes its steady
  /// state, `subspace` its converged schedule.
  bool stationary = false;
};

/// A method ready to run: its LinearFilter for the engine, its own online implementation, and what it
/// claims about its own error.
struct ResolvedMethod {
  MethodSpec spec;
  std::string description;                     ///< e.g. "Kalman filter (joseph form)"
  std::shared_ptr<const LinearFilter> filter;  ///< what the exact-performance engine evaluates
  /// The method's own online implementation: measurements (T x m) -> estimates of x_k, (T+1) x n.
  std::function<TimeSeries(const TimeSeries& y)> run;
  std::string online;            ///< the function `run` calls ("RunFilter", "RunCoupledFilter", ...)
  double offline_seconds = 0.0;  ///< the offline part (schedules, DAREs, bases)
  /// Bytes the online part holds: its state and the matrices it applies (all steps of a stored schedule).
  double memory_bytes = 0.0;
  /// The filter's own error covariance of x at step T and in the stationary limit (n x n, empty when
  /// the method claims none).
  Eigen::MatrixXd claimed_cov, claimed_stationary_cov;
};

/// Resolves `spec` against `truth`. File parameters are read relative to the working directory.
/// @throws kfx::Error "method 'SPEC': ..." for an order larger than the state, a basis or weight of
///         the wrong shape, a coupled method on a plain model, a stationary form of a time-varying
///         model, a file that cannot be read; kfx::NumericalError when the method's offline part fails.
ResolvedMethod ResolveMethod(const MethodSpec& spec, const ComparisonModel& truth,
                             const MethodOptions& options = MethodOptions());

struct CompareOptions {
  int steps = 100;          ///< horizon T of the finite-horizon MSE and of the timing run (>= 1)
  bool stationary = false;  ///< also (and as the headline) the stationary MSE; see MethodOptions
  /// n x n symmetric PSD W of the weighted MSE tr(W E[e e^T]); empty = I. For a continuous-time model
  /// W is p x p and weighs the error of z(t_k) only (empty: I_p): the error of the continuous state at
  /// the sampling instants (paper 003's P_{T,n}).
  Eigen::MatrixXd weight{};
  int monte_carlo = 0;          ///< Monte Carlo runs (0: none; else >= 2)
  std::uint64_t seed = 1;       ///< of the timing run and the Monte Carlo runs
  ProgressCallback progress{};  ///< (methods done, methods)
  bool IsValid(std::string* error) const;
};

struct CompareRow {
  std::string spec, description, online;
  Eigen::Index state_dim = 0;  ///< n_z, the filter's own state
  double offline_seconds = 0.0, online_seconds_per_step = 0.0, memory_bytes = 0.0;
  Eigen::VectorXd mse;     ///< weighted MSE k = 0..T from the engine (the error-vs-time curve)
  double final_mse = 0.0;  ///< mse(T)
  double stationary_mse = std::numeric_limits<double>::quiet_NaN();  ///< NaN: none (time-varying, unstable)
  std::string stationary_note;                                       ///< why there is no stationary value
  /// The headline (stationary_mse with --stationary, else final_mse) over the Kalman filter's.
  double ratio = std::numeric_limits<double>::quiet_NaN();
  double claimed_final = std::numeric_limits<double>::quiet_NaN();       ///< tr(W claimed_cov)
  double claimed_stationary = std::numeric_limits<double>::quiet_NaN();  ///< tr(W claimed_stationary_cov)
  int mc_runs = 0;
  double mc_mse = std::numeric_limits<double>::quiet_NaN();        ///< Monte Carlo weighted MSE at T
  double mc_std_error = std::numeric_limits<double>::quiet_NaN();  ///< its standard error
};

struct Comparison {
  int steps = 0;
  bool stationary = false;
  /// The optimal Kalman filter on the true model: tr(W P_{T|T}) of its schedule, tr(W P_filt) of the DARE
  /// (NaN for a time-varying model or when the DARE fails).
  double kalman_final = 0.0;
  double kalman_stationary = std::numeric_limits<double>::quiet_NaN();
  /// Continuous-time models only (else NaN): the Kalman-Bucy filter, which observes y continuously, a lower
  /// bound for every row: tr(W P_c(T dt)) (KalmanBucyCovariance) and tr(W P) of the filter CARE.
  double kalman_bucy_final = std::numeric_limits<double>::quiet_NaN();
  double kalman_bucy_stationary = std::numeric_limits<double>::quiet_NaN();
  std::vector<CompareRow> rows;
};

/// One named value of a comparison, as `kfx compare --json` and kfx.compare show it: text, an integer, a
/// flag or a number (a number that does not exist, NaN, is shown as null / None).
struct CompareField {
  enum class Kind { kText, kInteger, kFlag, kNumber };
  std::string name;
  Kind kind = Kind::kNumber;
  std::string text;   ///< kText; empty text with `null_if_empty` is null
  double number = 0;  ///< kInteger, kFlag (0 or 1), kNumber
  bool null_if_empty = false;
};

/// The fields of one row, in order (docs/cli.md, `--json`): method, description, online, state_dim,
/// offline_seconds, online_seconds_per_step, memory_bytes, mse, stationary_mse, stationary_note, headline,
/// ratio_to_kalman, claimed_mse, claimed_stationary_mse, monte_carlo_runs, monte_carlo_mse,
/// monte_carlo_std_error. The one list the CLI's JSON and Python's dicts are made from.
std::vector<CompareField> CompareRowFields(const CompareRow& row, bool stationary);
/// The fields of the comparison itself: steps, stationary, kalman_final_mse, kalman_stationary_mse,
/// kalman_bucy_mse, kalman_bucy_stationary_mse.
std::vector<CompareField> ComparisonFields(const Comparison& comparison);

/// One row per method (in the order given).
/// @throws kfx::Error on invalid options or specs (ResolveMethod); naming model when it has a known input
///         (fields G, D: not taken by compare yet; the engine takes it, ExactPerformance with g).
Comparison Compare(const ComparisonModel& truth, const std::vector<MethodSpec>& methods,
                   const CompareOptions& options = CompareOptions());

}  // namespace kfx
