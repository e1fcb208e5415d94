#pragma once
// For the distributed Monte Carlo (src/distributed/monte_carlo_sums.cpp): the evaluation checks of performance.cpp.
#include "kfx/performance.hpp"

namespace kfx::detail {
/// Validates options, dimensions and weight as MonteCarloPerformance does; returns the number of steps T.
int CheckMonteCarloEvaluation(const Model& truth, const LinearFilter& filter, const MonteCarloOptions& options);
}  // namespace kfx::detail

namespace kfx::detail {
/// Shared by the finite-horizon and the stationary engine (performance.cpp, stationary_performance.cpp).
/// @throws kfx::Error unless the filter takes the model's measurements and outputs its n states.
void CheckCompatible(const Model& truth, const LinearFilter& filter);
/// @throws kfx::Error unless weight is empty or n x n symmetric PSD.
void CheckWeight(const Eigen::MatrixXd& weight, Eigen::Index n, const std::string& name);
/// tr(W E) for symmetric E (tr E for an empty W).
double WeightedTrace(const Eigen::MatrixXd& weight, const Eigen::MatrixXd& E);
/// E[e e^T] with e = x - O z from second moments (Mxx, Mxz, Mzz include the means); O empty = I.
Eigen::MatrixXd ErrorMoment(const Eigen::MatrixXd& Mxx, const Eigen::MatrixXd& Mxz, const Eigen::MatrixXd& Mzz,
                            const Eigen::MatrixXd& O);
}  // namespace kfx::detail
