"""The generalized equations of issue 22 from Python: the filter DARE with a cross term S and a
descriptor E against SciPy's solve_discrete_are(a, b, q, r, e, s) (the dual problem; skipped when SciPy
is not installed: python3-scipy is only a bench-peers dependency) and against its residual; the
generalized Lyapunov and Stein equations against Kronecker solves; bad input raises kfx.Error."""
import numpy as np
import pytest

import kfx


def _joint(n, m, seed):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 1.05 / max(abs(np.linalg.eigvals(A)))
    C = rng.standard_normal((m, n))
    G = rng.standard_normal((n + m, n + m))
    J = G @ G.T / (n + m) + 0.2 * np.eye(n + m)
    E = np.eye(n) + 0.3 * rng.standard_normal((n, n)) / np.sqrt(n)
    return A, C, J[:n, :n], J[n:, n:], J[:n, n:], E


def _residual(A, C, Q, R, S, E, P):
    W = C @ P @ C.T + R
    X = A @ P @ C.T + S
    res = A @ P @ A.T - E @ P @ E.T + Q - X @ np.linalg.solve(W, X.T)
    return np.linalg.norm(res) / np.linalg.norm(E @ P @ E.T)


@pytest.mark.parametrize("n,m", [(2, 1), (5, 2), (12, 4)])
def test_cross_term_descriptor_dare_residual_and_methods(n, m):
    A, C, Q, R, S, E = _joint(n, m, n)
    a = kfx.solve_filter_dare(A, C, Q, R, S=S, E=E)
    b = kfx.solve_filter_dare(A, C, Q, R, S=S, E=E, method="schur")
    assert a.summary.ok and b.summary.ok
    assert _residual(A, C, Q, R, S, E, a.P_pred) < 1e-12
    assert kfx.filter_dare_residual(A, C, Q, R, a.P_pred, S=S, E=E) == pytest.approx(a.summary.relative_residual,
                                                                                       abs=1e-15)
    assert np.linalg.norm(a.P_pred - b.P_pred) <= 1e-9 * np.linalg.norm(b.P_pred)
    K_p = a.predictor_gain
    assert max(abs(np.linalg.eigvals(np.linalg.solve(E, A - K_p @ C)))) < 1


def test_against_scipy_solve_discrete_are_with_e_and_s():
    scipy_linalg = pytest.importorskip("scipy.linalg", reason="SciPy not installed (python3-scipy is a bench-peers "
                                                              "dependency only)")
    for n, m in [(2, 1), (6, 3), (20, 5)]:
        A, C, Q, R, S, E = _joint(n, m, 100 + n)
        # SciPy: a^T X a - e^T X e - (a^T X b + s)(r + b^T X b)^{-1}(b^T X a + s^T) + q = 0, the dual of ours.
        X = scipy_linalg.solve_discrete_are(A.T, C.T, Q, R, e=E.T, s=S)
        P = kfx.solve_filter_dare(A, C, Q, R, S=S, E=E).P_pred
        assert np.linalg.norm(P - X) <= 1e-9 * np.linalg.norm(X)


def test_python_control_dare_g_case():
    # python-control's own test (mateqn_test.py test_dare_g): dare(A, B, Q, R, S, E), dual of ours.
    A = np.array([[-0.6, 0], [-0.1, -0.4]])
    Q = np.array([[2.0, 1], [1, 3]])
    B = np.array([[1.0], [2]])
    R = np.array([[1.0]])
    S = np.array([[1.0], [0]])
    E = np.array([[2.0, 1], [1, 2]])
    d = kfx.solve_filter_dare(A.T, B.T, Q, R, S=S, E=E.T)
    X, G = d.P_pred, d.predictor_gain.T
    assert np.allclose(A.T @ X @ A - E.T @ X @ E - (A.T @ X @ B + S) @ G + Q, 0, atol=1e-12)
    assert max(abs(np.linalg.eigvals(np.linalg.solve(E, A - B @ G)))) < 1


def test_generalized_lyapunov_and_stein_vs_kronecker():
    rng = np.random.default_rng(3)
    n, m = 4, 3
    A, E = rng.standard_normal((n, n)), rng.standard_normal((n, n)) + 3 * np.eye(n)
    Q = np.eye(n) + 0.1 * np.ones((n, n))
    K = np.kron(A, A) - np.kron(E, E)  # row-major vec: vec(A X A^T) = kron(A, A) vec(X)
    X = np.linalg.solve(K, -Q.ravel()).reshape(n, n)
    g = kfx.solve_generalized_discrete_lyapunov(A, E, Q)
    assert g.summary.ok and np.allclose(g.X, X, rtol=1e-11, atol=1e-12)
    B, Cm = rng.standard_normal((m, m)), rng.standard_normal((n, m))
    K = np.kron(A, B.T) - np.eye(n * m)  # row-major vec(A X B) = kron(A, B^T) vec(X)
    Y = np.linalg.solve(K, -Cm.ravel()).reshape(n, m)
    s = kfx.solve_discrete_sylvester(A, B, Cm)
    assert s.summary.ok and np.allclose(s.X, Y, rtol=1e-11, atol=1e-12)


def test_bad_input_names_the_argument():
    A, C, Q, R, S, E = _joint(3, 2, 9)
    with pytest.raises(kfx.Error, match="S"):
        kfx.solve_filter_dare(A, C, Q, R, S=np.ones((2, 2)))
    with pytest.raises(kfx.Error, match=r"\[\[Q, S\], \[S\^T, R\]\]"):
        kfx.solve_filter_dare(A, C, Q, R, S=100 * S)
    with pytest.raises(kfx.Error, match="E"):
        kfx.solve_filter_dare(A, C, Q, R, E=np.zeros((3, 3)))
    with pytest.raises(kfx.Error, match="E"):
        kfx.solve_generalized_discrete_lyapunov(A, np.zeros((3, 3)), Q)
    with pytest.raises(kfx.Error, match="C"):
        kfx.solve_discrete_sylvester(A, A, np.ones((2, 2)))


# ---- The filter CARE with a cross term S and a descriptor E (kfx.continuous.solve_filter_care) ------------

def _care_system(n, m, seed):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) / np.sqrt(n) - 0.3 * np.eye(n)  # eigenvalues on both sides of the axis
    C = rng.standard_normal((m, n))
    G = rng.standard_normal((n + m, n + m))
    J = G @ G.T / (n + m) + 0.2 * np.eye(n + m)
    E = np.eye(n) + 0.3 * rng.standard_normal((n, n)) / np.sqrt(n)
    return A, C, J[:n, :n], J[n:, n:], J[:n, n:], E


def _care_residual(A, C, Q, R, S, E, P):
    X = E @ P @ C.T + S
    res = A @ P @ E.T + E @ P @ A.T + Q - X @ np.linalg.solve(R, X.T)
    return np.linalg.norm(res) / np.linalg.norm(A @ P @ E.T)


@pytest.mark.parametrize("n,m", [(2, 1), (6, 3), (20, 5)])
def test_care_against_scipy_solve_continuous_are_with_s_and_e(n, m):
    scipy_linalg = pytest.importorskip("scipy.linalg", reason="SciPy not installed (python3-scipy is a bench-peers "
                                                              "dependency only)")
    A, C, Q, R, S, E = _care_system(n, m, 200 + n)
    # SciPy: a^T X e + e^T X a - (e^T X b + s) r^{-1} (b^T X e + s^T) + q = 0, the dual of ours.
    for e in (None, E):
        X = scipy_linalg.solve_continuous_are(A.T, C.T, Q, R, e=None if e is None else e.T, s=S)
        c = kfx.continuous.solve_filter_care(A, C, Q, R, S=S, E=e)
        assert c.summary.ok, c.summary.brief_report()
        assert np.linalg.norm(c.P - X) <= 1e-9 * np.linalg.norm(X)
        Ee = np.eye(n) if e is None else e
        assert _care_residual(A, C, Q, R, S, Ee, c.P) < 1e-12
        assert np.allclose(c.gain @ R, Ee @ c.P @ C.T + S, rtol=1e-10, atol=1e-12)
        assert max(np.linalg.eigvals(np.linalg.solve(Ee, A - c.gain @ C)).real) < 0
        assert min(np.linalg.eigvalsh(c.P)) > -1e-12 * np.linalg.norm(c.P)


def test_care_matrix_form_equals_the_model_form():
    A, C, Q, R, _, _ = _care_system(4, 2, 11)
    model = kfx.continuous.ContinuousModel(A=A, B=np.eye(4), C=C, Q=Q, R=R, m0=np.zeros(4), P0=np.eye(4))
    a = kfx.continuous.solve_filter_care(model)
    b = kfx.continuous.solve_filter_care(A, C, Q, R)
    assert a.summary.ok and b.summary.ok
    assert np.linalg.norm(a.P - b.P) <= 1e-12 * np.linalg.norm(b.P)


def test_care_bad_input_names_the_argument():
    A, C, Q, R, S, E = _care_system(3, 2, 9)
    with pytest.raises(kfx.Error, match="S"):
        kfx.continuous.solve_filter_care(A, C, Q, R, S=np.ones((2, 2)))
    with pytest.raises(kfx.Error, match=r"\[\[Q, S\], \[S\^T, R\]\]"):
        kfx.continuous.solve_filter_care(A, C, Q, R, S=100 * S)
    with pytest.raises(kfx.Error, match="R"):
        kfx.continuous.solve_filter_care(A, C, Q, -R, S=S)
    with pytest.raises(kfx.Error, match="E"):
        kfx.continuous.solve_filter_care(A, C, Q, R, S=S, E=np.zeros((3, 3)))
    with pytest.raises(kfx.Error, match="A"):
        kfx.continuous.solve_filter_care(np.full((3, 3), np.nan), C, Q, R)
