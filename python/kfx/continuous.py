"""kfx.continuous: continuous-time models, the Kalman-Bucy filter, the filter CARE and sampled filters.

Paper 003, Aalto. Each name here was kfx.<name> before issue 21 (the old name still works, with a
DeprecationWarning, for one release). The C++ reference is include/kfx/continuous.hpp,
include/kfx/sampling_convergence.hpp; the method's page is docs/papers/003.
"""
from ._core import (  # noqa: F401
    CareSolution, ContinuousModel, ConvergencePoint, ConvergenceStudy, SamplingBounds,
    kalman_bucy_covariance, log_log_slope, run_kalman_bucy, sampled_filter_covariance,
    sampled_filter_estimate, sampled_model, sampled_model_at, simulate_continuous,
    solve_filter_care, study_convergence, wave_modal_model,
)

__all__ = [
    "CareSolution", "ContinuousModel", "ConvergencePoint", "ConvergenceStudy", "SamplingBounds",
    "kalman_bucy_covariance", "log_log_slope", "run_kalman_bucy", "sampled_filter_covariance",
    "sampled_filter_estimate", "sampled_model", "sampled_model_at", "simulate_continuous",
    "solve_filter_care", "study_convergence", "wave_modal_model",
]
