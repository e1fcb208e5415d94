"""kfx: Kalman filtering for large and infinite-dimensional linear systems.

numpy float64 arrays in and out; sequences are time-major, (T, n); stacks of matrices are (K, rows,
cols). Bad input raises kfx.Error (a ValueError) with the C++ message naming the argument; a numerical
breakdown on valid input raises kfx.NumericalError (an ArithmeticError). Solvers report convergence
in a summary instead of raising. Guide: docs/python.md; reference: the C++ headers include/kfx/*.hpp,
whose doc comments the docstrings summarize.

    import kfx
    model = kfx.Model(A=..., C=..., Q=..., R=..., m0=..., P0=...)
    x, y = kfx.simulate(model, steps=100, seed=1)
    run = kfx.run_filter(model, y, store_covariances="full")  # or kfx.KalmanFilter
    smooth = kfx.rts_smooth(model, run)
    kfx.exact_performance(model, kfx.kalman_as_linear_filter(model, 100)).mse

The top level holds the core: models, simulation and discretization, the Kalman filter and smoother,
the DARE and Lyapunov solvers, the exact-performance engine, compare and reproduce. One submodule per
method family: kfx.subspace (paper 000), kfx.reduced (001), kfx.mismatch (002), kfx.continuous (003),
kfx.blockdiag (004); kfx.plots (matplotlib, loaded on first use) draws results and the papers' figures.
"""
import warnings as _warnings

from . import _core
from . import blockdiag, continuous, mismatch, reduced, subspace  # noqa: F401
from ._core import (  # noqa: F401  (the core, listed so that editors and type checkers see it)
    DareSolution, Error, Estimate, FilterHealth, FilterRun, KalmanSchedule, LinearFilter,
    LinearFilterStep, LyapunovSolution, Model, ModelStep, MonteCarloResult, NumericalError, PerformanceResult,
    SmootherRun, StationaryPerformance, SteinSolution, Summary, UpdateResult, __version__, compare,
    constant_gain_as_linear_filter, discretize_process_noise, discretize_zoh, exact_performance,
    exact_stationary_performance, filter_dare_residual, filter_many, kalman_as_linear_filter, kalman_schedule,
    matrix_exponential, monte_carlo_performance, paper_ids, parse_method, predict, reproduce, rts_smooth,
    run_filter, simulate, solve_discrete_lyapunov, solve_discrete_sylvester, solve_filter_dare,
    solve_generalized_discrete_lyapunov, spectral_radius, update,
)
from ._filterpy import KalmanFilter  # noqa: F401  (the FilterPy drop-in: compiled core + Python layer)

_SUBMODULES = ("blockdiag", "continuous", "mismatch", "reduced", "subspace")
# Old top-level name -> its submodule (issue 21; the aliases go in the release after 0.3).
_MOVED = {name: family for family in _SUBMODULES for name in globals()[family].__all__}
# A compiled name that is in no list yet (a binding added since) stays reachable at the top level;
# tests/python/test_namespace.py fails until it is given its place.
_UNPLACED = [n for n in dir(_core) if not n.startswith("_") and n not in _MOVED and n not in globals()]
globals().update({n: getattr(_core, n) for n in _UNPLACED})

__all__ = sorted(n for n in dir(_core) if not n.startswith("_") and n not in _MOVED)
__all__ += ["KalmanFilter"] + list(_SUBMODULES) + ["plots", "__version__"]


def __getattr__(name):
    # kfx.plots on first use (matplotlib is slow to import and not needed for filtering).
    if name == "plots":
        import importlib

        return importlib.import_module(".plots", __name__)
    family = _MOVED.get(name)
    if family is not None:
        _warnings.warn(f"kfx.{name} is now kfx.{family}.{name}; the old name will be removed after 0.3",
                       DeprecationWarning, stacklevel=2)
        return getattr(_core, name)
    raise AttributeError(f"module 'kfx' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | {"plots"})
