"""kfx.mismatch: filters designed on a wrong model: the true error covariance and its bounds.

Paper 002, Patel, Toda. Each name here was kfx.<name> before issue 21 (the old name still works,
with a DeprecationWarning, for one release). The C++ reference is include/kfx/mismatch.hpp; the
method's page is docs/papers/002.
"""
from ._core import (  # noqa: F401
    ErrorRanges, ModelingErrors, StationaryMismatch, apply_modeling_errors,
    mismatched_covariance_sequence, modeling_errors_between, patel_toda_bounds, search_error_box,
    stationary_mismatched_covariance, theorem1_bound, theorem2_bound,
)

__all__ = [
    "ErrorRanges", "ModelingErrors", "StationaryMismatch", "apply_modeling_errors",
    "mismatched_covariance_sequence", "modeling_errors_between", "patel_toda_bounds",
    "search_error_box", "stationary_mismatched_covariance", "theorem1_bound", "theorem2_bound",
]
