"""Shared fixtures of the kfx pytest suite (run by ctest in the venv where python_pip_install put kfx;
without a venv, with PYTHONPATH=build/python)."""
import os
import shutil

import numpy as np
import pytest

import kfx

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def numpy_kalman(A, C, Q, R, m0, P0, ys):
    """The textbook filter as a plain numpy loop (an independent implementation)."""
    x, P = np.array(m0, float), np.array(P0, float)
    xs, Ps, ll = [], [], 0.0
    for y in ys:
        x = A @ x
        P = A @ P @ A.T + Q
        S = C @ P @ C.T + R
        K = np.linalg.solve(S, C @ P).T
        nu = y - C @ x
        x = x + K @ nu
        IKC = np.eye(len(x)) - K @ C
        P = IKC @ P @ IKC.T + K @ R @ K.T
        ll += -0.5 * (len(y) * np.log(2 * np.pi) + np.linalg.slogdet(S)[1] + nu @ np.linalg.solve(S, nu))
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps), ll


@pytest.fixture
def cv():
    """The constant-velocity model of examples/models/constant_velocity.json."""
    A = np.array([[1.0, 1.0], [0.0, 1.0]])
    C = np.array([[1.0, 0.0]])
    Q = np.array([[0.03333333333333333, 0.05], [0.05, 0.1]])
    R = np.array([[1.0]])
    return dict(A=A, C=C, Q=Q, R=R, m0=np.zeros(2), P0=10 * np.eye(2))


@pytest.fixture
def random_model():
    rng = np.random.default_rng(4)
    n, m = 4, 2
    A = rng.standard_normal((n, n))
    A *= 0.9 / max(abs(np.linalg.eigvals(A)))
    C = rng.standard_normal((m, n))
    G = rng.standard_normal((n, n))
    Q = G @ G.T / n + 0.1 * np.eye(n)
    H = rng.standard_normal((m, m))
    R = H @ H.T + 0.5 * np.eye(m)
    return dict(A=A, C=C, Q=Q, R=R, m0=rng.standard_normal(n), P0=np.eye(n))


@pytest.fixture
def cli():
    path = os.environ.get("KFX_CLI") or shutil.which("kfx")
    if not path or not os.path.exists(path):
        pytest.skip("the kfx CLI is not built (KFX_CLI unset)")
    return path


@pytest.fixture
def root():
    return ROOT


__all__ = ["numpy_kalman", "kfx"]
