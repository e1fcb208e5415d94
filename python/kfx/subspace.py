"""kfx.subspace: the subspace (projection) filter of infinite-dimensional systems.

Paper 000, Aalto. Each name here was kfx.<name> before issue 21 (the old name still works, with a
DeprecationWarning, for one release). The C++ reference is include/kfx/subspace_filter.hpp,
include/kfx/damped_wave.hpp; the method's page is docs/papers/000.
"""
from ._core import (  # noqa: F401
    ApproximateSubspaceFilter, DampedWaveProblem, DiscretizationBounds, Subspace,
    SubspaceFilterSchedule, WaveDiscretization, approximate_subspace_filter,
    approximate_subspace_filter_as_linear_filter, converged_subspace_filter_as_linear_filter,
    damped_wave, discretization_bounds, projection_adjoint, subspace_filter_as_linear_filter,
    subspace_filter_schedule, subspace_from_basis,
)

__all__ = [
    "ApproximateSubspaceFilter", "DampedWaveProblem", "DiscretizationBounds", "Subspace",
    "SubspaceFilterSchedule", "WaveDiscretization", "approximate_subspace_filter",
    "approximate_subspace_filter_as_linear_filter", "converged_subspace_filter_as_linear_filter",
    "damped_wave", "discretization_bounds", "projection_adjoint",
    "subspace_filter_as_linear_filter", "subspace_filter_schedule", "subspace_from_basis",
]
