#pragma once
// For the distributed Monte Carlo (src/distributed/monte_carlo_sums.cpp): the evaluation checks of performance.cpp.
#include "kfx/performance.hpp"

namespace kfx::detail {
/// Validates options, dimensions and weight as MonteCarloPerformance does; returns the number of steps T.
int CheckMonteCarloEvaluation(const Model& truth, const LinearFilter& filter, const MonteCarloOptions& options);
}  // namespace kfx::detail
