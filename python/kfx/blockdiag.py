"""kfx.blockdiag: block-diagonal filters of coupled subsystems.

Paper 004, Pogorelyuk, Rowley, Kasdin. Each name here was kfx.<name> before issue 21 (the old name
still works, with a DeprecationWarning, for one release). The C++ reference is
include/kfx/block_diagonal.hpp; the method's page is docs/papers/004.
"""
from ._core import (  # noqa: F401
    BlockDiagonalSteadyState, CoupledRun, CoupledStep, CoupledSystem, IdenticalAnalysis,
    IdenticalSubsystems, KroneckerStructured, analyze_identical_subsystems, block_diagonal_to_dense,
    coupled_filter_as_linear_filter, diagonal_blocks, frobenius_distance,
    make_identical_coupled_step, run_coupled_filter, simulate_coupled,
    solve_block_diagonal_steady_state, unknown_input_spectral_radius,
)

__all__ = [
    "BlockDiagonalSteadyState", "CoupledRun", "CoupledStep", "CoupledSystem", "IdenticalAnalysis",
    "IdenticalSubsystems", "KroneckerStructured", "analyze_identical_subsystems",
    "block_diagonal_to_dense", "coupled_filter_as_linear_filter", "diagonal_blocks",
    "frobenius_distance", "make_identical_coupled_step", "run_coupled_filter", "simulate_coupled",
    "solve_block_diagonal_steady_state", "unknown_input_spectral_radius",
]
