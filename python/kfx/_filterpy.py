"""kfx.KalmanFilter: a drop-in for filterpy.kalman.KalmanFilter (FilterPy 1.4.5).

The steps, the attributes and batch_filter / rts_smoother are compiled (kfx._core._KalmanFilter); this
module adds what FilterPy writes in Python and kfx need not compile: __repr__, test_matrix_dimensions,
measurement_of_state, log_likelihood_of, and pickling (so copy.deepcopy, multiprocessing and joblib work).
Differences to FilterPy: docs/python.md, "kfx.KalmanFilter and FilterPy".
"""
import math
import sys

import numpy as np

from . import _core

# Every attribute that a copy or a pickle carries, in an order in which they can be set back.
_STATE = ("F", "H", "Q", "R", "B", "M", "x", "P", "x_prior", "P_prior", "x_post", "P_post", "K", "y", "S", "SI", "z")


def _pretty(label, value):
    """'label = value' as FilterPy prints it: a column vector on one line with .T, other arrays with their
    continuation lines indented under the first."""
    if isinstance(value, np.ndarray) and value.ndim == 2 and value.shape[0] > 1 and value.shape[1] == 1:
        return f"{label} = " + str(value.T).replace("\n", "") + ".T"
    lines = str(value).split("\n")
    pad = " " * (len(label) + 3)
    return "\n".join([f"{label} = {lines[0]}"] + [pad + line for line in lines[1:]])


class KalmanFilter(_core._KalmanFilter):
    """A Kalman filter that runs code written for filterpy.kalman.KalmanFilter (1.4.5) unchanged.

    KalmanFilter(dim_x, dim_z, dim_u=0) starts as FilterPy's: x = 0 of shape (dim_x, 1), P = Q = F = I,
    H = 0 (dim_z, dim_x), R = I, B = None, M = 0 (dim_x, dim_z), alpha = 1. KalmanFilter(model) starts
    from a time-invariant kfx.Model. The attributes x, P, F, H, Q, R, B, M are numpy arrays: in-place
    edits (kf.F[0, 1] = dt, kf.P *= 1000) take effect, and assignment replaces them (checked: shape,
    finite, P, Q, R symmetric PSD; kfx.Error, a ValueError, names the attribute). A number assigned to P
    means p I; to Q or R, q (r) in every entry, which is what FilterPy computes with it.

    Methods: predict(u, B, F, Q), update(z, R, H) (z None: no update; NaN entries are missing),
    update_correlated, update_sequential, update_steadystate, predict_steadystate,
    batch_filter(zs, Fs, Qs, Hs, Rs, Bs, us, update_first, saver) -> (means, covariances, means_p,
    covariances_p), rts_smoother(Xs, Ps, Fs, Qs) -> (x, P, K, Pp), get_prediction, get_update,
    residual_of, measurement_of_state, log_likelihood_of, test_matrix_dimensions. After each call: y, S,
    SI, K, z, x_prior, P_prior, x_post, P_post, log_likelihood, likelihood, mahalanobis.

    Raises kfx.NumericalError where FilterPy would invert an innovation covariance S that is not
    positive definite. Differences to FilterPy are listed in docs/python.md.
    """

    @property
    def inv(self):
        """numpy.linalg.inv, for code that reads it: kfx solves with S's Cholesky factor instead."""
        return np.linalg.inv

    @inv.setter
    def inv(self, value):
        raise _core.Error("inv: kfx does not invert S (it solves with its Cholesky factor); inv cannot be replaced")

    def measurement_of_state(self, x):
        """H x: the measurement a state x would give (x of any shape H can multiply). Raises ValueError (numpy's)
        if H cannot multiply x."""
        return np.dot(self.H, x)

    def log_likelihood_of(self, z):
        """log N(z; H x, S) with the current x and S (None: log of the smallest float). Raises ValueError (numpy's)
        if z does not have one entry per row of H, LinAlgError (numpy.linalg) if S is not positive definite."""
        if z is None:
            return math.log(sys.float_info.min)
        r = np.ravel(np.asarray(z, dtype=float)) - np.ravel(np.dot(self.H, self.x))
        L = np.linalg.cholesky(self.S)
        w = np.linalg.solve(L, r)
        return float(-0.5 * (len(r) * math.log(2 * math.pi) + w @ w) - np.log(np.diag(L)).sum())

    def test_matrix_dimensions(self, z=None, H=None, R=None, F=None, Q=None):
        """Raises AssertionError unless x, P, Q, F, H, R (the attributes, or the matrices given) and z have
        shapes that fit dim_x and H's rows."""
        H = self.H if H is None else H
        R = self.R if R is None else R
        F = self.F if F is None else F
        Q = self.Q if Q is None else Q
        n = self.dim_x
        x = self.x
        assert x.shape in ((n,), (n, 1)), f"x: expected shape ({n},) or ({n}, 1), got {x.shape}"
        for name, mat in (("P", self.P), ("Q", Q), ("F", F)):
            assert np.shape(mat) == (n, n), f"{name}: expected shape ({n}, {n}), got {np.shape(mat)}"
        assert np.ndim(H) == 2 and np.shape(H)[1] == n, f"H: expected shape (dim_z, {n}), got {np.shape(H)}"
        k = np.shape(H)[0]
        allowed = [(), (1,), (1, 1)] if k == 1 else [(k, k)]
        assert np.shape(R) in allowed, f"R: expected shape {allowed[-1]}, got {np.shape(R)}"
        Hx = np.dot(H, x)
        zs = (k, 1) if z is None else np.shape(z)
        if zs == ():
            assert k == 1, f"z: expected shape {Hx.shape} for this H, got a number"
        elif len(zs) == 1:
            assert zs[0] == k and (Hx.ndim == 1 or k == 1 or Hx.shape == (k, 1)), \
                f"z: expected shape {Hx.shape} for this H, got {zs}"
        else:
            assert zs == Hx.shape or (Hx.ndim == 1 and zs == (k, 1) and k == 1) or (k == 1 and zs == (1, 1)), \
                f"z: expected shape {Hx.shape} for this H, got {zs}"

    def __repr__(self):
        items = [("dim_x", self.dim_x), ("dim_z", self.dim_z), ("dim_u", self.dim_u), ("x", self.x), ("P", self.P),
                 ("x_prior", self.x_prior), ("P_prior", self.P_prior), ("x_post", self.x_post),
                 ("P_post", self.P_post), ("F", self.F), ("Q", self.Q), ("R", self.R), ("H", self.H), ("K", self.K),
                 ("y", self.y), ("S", self.S), ("SI", self.SI), ("M", self.M), ("B", self.B), ("z", self.z),
                 ("log-likelihood", self.log_likelihood), ("likelihood", self.likelihood),
                 ("mahalanobis", self.mahalanobis), ("alpha", self.alpha), ("inv", self.inv)]
        return "\n".join(["KalmanFilter object"] + [_pretty(label, value) for label, value in items])

    # ---- copy and pickle: every attribute, the lazy likelihoods and the instance's own attributes ------

    def __reduce__(self):
        return (type(self), (self.dim_x, self.dim_z, self.dim_u), self.__getstate__())

    def __getstate__(self):
        state = {}
        for name in _STATE:
            value = getattr(self, name)
            if name == "z" and value.dtype == object:
                value = None  # before any measurement: FilterPy's column of None
            state[name] = None if value is None else np.array(value)
        state["alpha"] = self.alpha
        state["update_form"] = self.update_form
        state["likelihoods"] = (self.log_likelihood, self.likelihood, self.mahalanobis)
        state["__dict__"] = dict(self.__dict__)
        return state

    def __setstate__(self, state):
        for name in _STATE:
            self._restore(name, state[name])
        self.alpha = state["alpha"]
        self.update_form = state["update_form"]
        self._set_likelihoods(*state["likelihoods"])
        self.__dict__.update(state["__dict__"])
