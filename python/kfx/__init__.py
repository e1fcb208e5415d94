"""kfx: Kalman filtering for large and infinite-dimensional linear systems.

numpy float64 arrays in and out; sequences are time-major, (T, n); stacks of matrices are (K, rows,
cols). Bad input raises kfx.Error (a ValueError) with the C++ message naming the argument; a numerical
breakdown on valid input raises kfx.NumericalError (an ArithmeticError). Solvers report convergence
in a summary instead of raising. Guide: docs/python.md; reference: the C++ headers include/kfx/*.hpp,
whose doc comments the docstrings summarize.

    import kfx
    model = kfx.Model(A=..., C=..., Q=..., R=..., m0=..., P0=...)
    x, y = kfx.simulate(model, steps=100, seed=1)
    run = kfx.run_filter(model, y)            # or kfx.KalmanFilter (FilterPy names)
    smooth = kfx.rts_smooth(model, run)
    kfx.exact_performance(model, kfx.kalman_as_linear_filter(model, 100)).mse

Submodule kfx.plots (matplotlib) draws results and the papers' figures.
"""
from . import _core
from ._core import *  # noqa: F401,F403  (the compiled core: every public name)
from ._core import Error, NumericalError, __version__  # noqa: F401
from ._filterpy import KalmanFilter  # noqa: F401  (the FilterPy drop-in: compiled core + Python layer)

__all__ = [name for name in dir(_core) if not name.startswith("_")] + ["KalmanFilter", "plots", "__version__"]


def __getattr__(name):
    # kfx.plots on first use (matplotlib is slow to import and not needed for filtering).
    if name == "plots":
        import importlib

        return importlib.import_module(".plots", __name__)
    raise AttributeError(f"module 'kfx' has no attribute {name!r}")
