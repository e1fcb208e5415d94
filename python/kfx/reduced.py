"""kfx.reduced: reduced-order filters: one- and two-step, with weights L_k or a subspace T.

Paper 001, Chandrasekar, Kim, Bernstein. Each name here was kfx.<name> before issue 21 (the old name
still works, with a DeprecationWarning, for one release). The C++ reference is
include/kfx/reduced_order.hpp, include/kfx/spring_mass_chain.hpp; the method's page is
docs/papers/001.
"""
from ._core import (  # noqa: F401
    InvariantSubspaceBasis, ReducedOrderOneStep, ReducedOrderTwoStep, SubspaceOneStep,
    SubspaceTwoStep, WeightSchedule, kalman_costs, least_damped_subspace, reduced_order_one_step,
    reduced_order_one_step_as_linear_filter, reduced_order_two_step,
    reduced_order_two_step_as_linear_filter, spring_mass_chain, subspace_one_step,
    subspace_one_step_as_linear_filter, subspace_two_step, subspace_two_step_as_linear_filter,
    triangularity_defect, weighted_cost,
)

__all__ = [
    "InvariantSubspaceBasis", "ReducedOrderOneStep", "ReducedOrderTwoStep", "SubspaceOneStep",
    "SubspaceTwoStep", "WeightSchedule", "kalman_costs", "least_damped_subspace",
    "reduced_order_one_step", "reduced_order_one_step_as_linear_filter", "reduced_order_two_step",
    "reduced_order_two_step_as_linear_filter", "spring_mass_chain", "subspace_one_step",
    "subspace_one_step_as_linear_filter", "subspace_two_step", "subspace_two_step_as_linear_filter",
    "triangularity_defect", "weighted_cost",
]
