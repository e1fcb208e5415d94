"""kfx.KalmanFilter as a drop-in for filterpy.kalman.KalmanFilter 1.4.5 (docs/python.md): each FilterPy
behaviour checked against numbers derived here (closed forms, the joint Gaussian, a plain numpy
reference written for this file). FilterPy itself is not needed (its own tests were run by hand:
docs/python.md)."""
import copy
import inspect
import math
import pickle
import sys

import numpy as np
import pytest

import kfx

rng = np.random.default_rng(21)


def cv_filter(dt=0.5, column=True):
    kf = kfx.KalmanFilter(dim_x=2, dim_z=1)
    kf.x = np.array([[1.0], [0.5]]) if column else np.array([1.0, 0.5])
    kf.F[0, 1] = dt  # in place, as FilterPy code does
    kf.H = np.array([[1.0, 0.0]])
    kf.P *= 10.0
    kf.R = 2.0
    kf.Q = np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
    return kf


def random_filter(n=4, m=2, column=True):
    kf = kfx.KalmanFilter(n, m)
    A = rng.standard_normal((n, n))
    kf.F = 0.9 * A / max(abs(np.linalg.eigvals(A)))
    kf.H = rng.standard_normal((m, n))
    G = rng.standard_normal((n, n))
    kf.Q = G @ G.T / n + 0.1 * np.eye(n)
    W = rng.standard_normal((m, m))
    kf.R = W @ W.T + np.eye(m)
    kf.P = 2 * np.eye(n)
    x = rng.standard_normal(n)
    kf.x = x[:, None] if column else x
    return kf


def ref_update(x, P, z, H, R, M=None):
    """The conditional mean and covariance of x given z for the joint Gaussian with cov(x, z) = P H^T + M."""
    M = np.zeros((len(x), len(z))) if M is None else M
    Cxz = P @ H.T + M
    S = H @ P @ H.T + H @ M + M.T @ H.T + R
    K = Cxz @ np.linalg.inv(S)
    y = z - H @ x
    return x + K @ y, P - K @ Cxz.T, y, S, K


def test_defaults_are_filterpys():
    kf = kfx.KalmanFilter(3, 2, dim_u=1)
    assert (kf.dim_x, kf.dim_z, kf.dim_u) == (3, 2, 1)
    assert kf.x.shape == (3, 1) and not kf.x.any()
    for name, value in (("P", np.eye(3)), ("Q", np.eye(3)), ("F", np.eye(3)), ("H", np.zeros((2, 3))),
                        ("R", np.eye(2)), ("M", np.zeros((3, 2))), ("K", np.zeros((3, 2))), ("y", np.zeros((2, 1))),
                        ("S", np.zeros((2, 2))), ("SI", np.zeros((2, 2))), ("x_prior", np.zeros((3, 1))),
                        ("P_post", np.eye(3))):
        np.testing.assert_array_equal(getattr(kf, name), value, err_msg=name)
    assert kf.B is None and kf.z.shape == (2, 1) and all(v is None for v in kf.z.ravel())
    assert kf.log_likelihood == math.log(sys.float_info.min) and kf.likelihood == sys.float_info.min
    assert kf.alpha == 1.0 and kf.mahalanobis == 0.0


def test_in_place_edits_take_effect_and_assignment_keeps_the_callers_array():
    kf = cv_filter(dt=0.5)
    F = np.array([[1.0, 0.5], [0.0, 1.0]])
    np.testing.assert_array_equal(kf.F, F)
    kf.predict()
    np.testing.assert_allclose(kf.P, F @ (10 * np.eye(2)) @ F.T + kf.Q, rtol=1e-15)
    np.testing.assert_allclose(kf.x, F @ np.array([[1.0], [0.5]]), rtol=1e-15)
    A = np.array([[1.0, 2.0], [0.0, 1.0]])
    kf.F = A
    assert kf.F is A
    A[0, 1] = 3.0  # the caller's array is the filter's
    x0 = kf.x.copy()
    kf.predict()
    np.testing.assert_allclose(kf.x, np.array([[1.0, 3.0], [0.0, 1.0]]) @ x0, rtol=1e-15)
    kf.P[0, 0] += 1.0  # in place on the state too
    P0 = kf.P.copy()
    kf.predict()
    np.testing.assert_allclose(kf.P, A @ P0 @ A.T + kf.Q, rtol=1e-14)
    # Each step makes new x and P arrays: a list of kf.x keeps every step (xs.append(kf.x)).
    xs = []
    for z in (1.0, 2.0, 3.0):
        kf.predict()
        kf.update(z)
        xs.append(kf.x)
    assert len({id(x) for x in xs}) == 3 and not np.array_equal(xs[0], xs[2])
    assert kf.x is kf.x and kf.x_post is not kf.x
    np.testing.assert_array_equal(kf.x_post, kf.x)


def test_scalars_broadcast_as_filterpy_computes_with_them():
    kf = random_filter(4, 2)
    kf.P, kf.Q, kf.R = 3.0, 0.25, 1.5
    np.testing.assert_array_equal(kf.P, 3 * np.eye(4))       # F (p) F^T = p F F^T
    np.testing.assert_array_equal(kf.Q, np.full((4, 4), 0.25))  # F P F^T + q adds q everywhere
    np.testing.assert_array_equal(kf.R, np.full((2, 2), 1.5))
    F, H = kf.F.copy(), kf.H.copy()
    kf.predict(Q=0.5)  # an argument: q I
    np.testing.assert_allclose(kf.P, 3 * F @ F.T + 0.5 * np.eye(4), rtol=1e-14)
    P = kf.P.copy()
    kf.update(np.zeros(2), R=2.0)  # an argument: r I
    np.testing.assert_allclose(kf.S, H @ P @ H.T + 2 * np.eye(2), rtol=1e-14)


@pytest.mark.parametrize("column", [True, False])
def test_update_matches_the_joint_gaussian_and_keeps_x_shape(column):
    kf = random_filter(4, 2, column)
    kf.predict()
    x, P = kf.x.reshape(-1).copy(), kf.P.copy()
    z = rng.standard_normal(2)
    for zform in (z, z.reshape(2, 1), z.reshape(1, 2), list(z)):
        k2 = copy.deepcopy(kf)
        k2.update(zform)
        xr, Pr, y, S, K = ref_update(x, P, z, kf.H, kf.R)
        np.testing.assert_allclose(k2.x.reshape(-1), xr, rtol=1e-12)
        np.testing.assert_allclose(k2.P, Pr, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(k2.K, K, rtol=1e-12)
        np.testing.assert_allclose(k2.S, S, rtol=1e-14)
        np.testing.assert_allclose(k2.SI, np.linalg.inv(S), rtol=1e-12)
        np.testing.assert_allclose(k2.y.reshape(-1), y, rtol=1e-14)
        assert k2.x.shape == ((4, 1) if column else (4,)) and k2.y.shape == ((2, 1) if column else (2,))
        d2 = y @ np.linalg.solve(S, y)
        ll = -0.5 * (2 * math.log(2 * math.pi) + math.log(np.linalg.det(S)) + d2)
        assert k2.log_likelihood == pytest.approx(ll, rel=1e-12)
        assert k2.likelihood == pytest.approx(math.exp(ll), rel=1e-12)
        assert k2.mahalanobis == pytest.approx(math.sqrt(d2), rel=1e-12)
        np.testing.assert_allclose(k2.z.reshape(-1), z)
    # the scalar closed form: x = x + P/(P+R) (z - x), P = P R/(P+R)
    s = kfx.KalmanFilter(1, 1)
    s.x, s.P, s.R, s.H = np.array([[2.0]]), 3.0, 1.0, np.array([[1.0]])
    s.update(6.0)
    assert s.x[0, 0] == pytest.approx(2 + 0.75 * 4, rel=1e-15) and s.P[0, 0] == pytest.approx(0.75, rel=1e-15)


@pytest.mark.parametrize("n,m", [(1, 1), (4, 2), (8, 8), (9, 3), (3, 9), (12, 5)])
def test_steps_match_the_references_on_both_sides_of_the_small_size_kernels(n, m):
    # Up to n, m = 8 the steps run on compile-time-bounded matrices with their own products, above on
    # Eigen's (python/src/filterpy_kernels.hpp): both against the closed-form prediction and the joint Gaussian.
    kf = random_filter(n, m)
    kf.alpha = 1.05
    kf.M = 0.1 * rng.standard_normal((n, m))
    for correlated in (False, True, False):
        F, Q, x, P = kf.F.copy(), kf.Q.copy(), kf.x[:, 0].copy(), kf.P.copy()
        kf.predict()
        np.testing.assert_allclose(kf.x[:, 0], F @ x, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(kf.P, 1.05 ** 2 * F @ P @ F.T + Q, rtol=1e-12, atol=1e-14)
        x, P, z = kf.x[:, 0].copy(), kf.P.copy(), rng.standard_normal(m)
        (kf.update_correlated if correlated else kf.update)(z)
        xr, Pr, y, S, K = ref_update(x, P, z, kf.H, kf.R, kf.M if correlated else None)
        np.testing.assert_allclose(kf.x[:, 0], xr, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(kf.P, Pr, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(kf.S, S, rtol=1e-12)
        np.testing.assert_allclose(kf.K, K, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(kf.y[:, 0], y, rtol=1e-12, atol=1e-14)


def test_predict_and_update_take_arguments_as_python_functions_do():
    # predict and update are vectorcall methods (bind_filterpy_kalman_filter.cpp): positional and keyword
    # arguments bind as in a Python def, and a wrong call raises TypeError as Python's would.
    a = random_filter(4, 2)
    b = copy.deepcopy(a)
    F2, H2, R2, z = 0.5 * np.eye(4), rng.standard_normal((2, 4)), 3.0 * np.eye(2), rng.standard_normal(2)
    a.predict(None, None, F2, 0.5)
    b.predict(Q=0.5, F=F2)
    x, P = a.x[:, 0].copy(), a.P.copy()
    a.update(z, R2, H2)
    b.update(H=H2, R=R2, z=z)
    xr, Pr, _, _, _ = ref_update(x, P, z, H2, R2)
    for kf in (a, b):
        np.testing.assert_allclose(kf.x[:, 0], xr, rtol=1e-12)
        np.testing.assert_allclose(kf.P, Pr, rtol=1e-12, atol=1e-14)
    for call, what in ((lambda: a.update(), "missing required argument 'z'"),
                       (lambda: a.update(z, z=z), "multiple values for argument 'z'"),
                       (lambda: a.update(z, Rr=R2), "unexpected keyword argument 'Rr'"),
                       (lambda: a.predict(1.0, None, None, None, None), "at most 4 arguments"),
                       (lambda: kfx.KalmanFilter.predict(None), "predict")):
        with pytest.raises(TypeError, match=what):
            call()
    np.testing.assert_allclose(a.x[:, 0], xr, rtol=1e-12)  # a failed call changes nothing
    with pytest.raises(kfx.Error, match="Q: expected shape"):  # kfx's own errors as before
        a.predict(Q=np.ones((3, 3)))
    assert list(inspect.signature(kfx.KalmanFilter.update).parameters) == ["self", "z", "R", "H"]
    assert list(inspect.signature(a.predict).parameters) == ["u", "B", "F", "Q"]
    assert "x_prior" in kfx.KalmanFilter.predict.__doc__


def test_update_none_and_missing_entries():
    kf = random_filter(4, 2)
    kf.predict()
    K, S = kf.K.copy(), kf.S.copy()
    kf.update(None)
    np.testing.assert_array_equal(kf.x_post, kf.x)
    np.testing.assert_array_equal(kf.y, np.zeros((2, 1)))
    np.testing.assert_array_equal(kf.K, K)
    np.testing.assert_array_equal(kf.S, S)
    assert all(v is None for v in kf.z.ravel())
    # a NaN entry is missing: the update with the observed row only
    x, P = kf.x[:, 0].copy(), kf.P.copy()
    kf.update(np.array([0.7, np.nan]))
    xr, Pr, _, _, _ = ref_update(x, P, np.array([0.7]), kf.H[:1], kf.R[:1, :1])
    np.testing.assert_allclose(kf.x[:, 0], xr, rtol=1e-12)
    np.testing.assert_allclose(kf.P, Pr, rtol=1e-12, atol=1e-14)
    assert np.isnan(kf.y[1, 0]) and (kf.K[:, 1] == 0).all()


def test_predict_with_control_input_overrides_and_fading_memory():
    kf = random_filter(4, 2)
    kf.B = np.array([[0.0], [1.0], [0.0], [2.0]])
    kf.alpha = 1.1
    F, Q, x, P = kf.F.copy(), kf.Q.copy(), kf.x.copy(), kf.P.copy()
    kf.predict(u=np.array([[0.5]]))
    np.testing.assert_allclose(kf.x, F @ x + 0.5 * kf.B, rtol=1e-14)
    np.testing.assert_allclose(kf.P, 1.21 * F @ P @ F.T + Q, rtol=1e-14)
    np.testing.assert_array_equal(kf.x_prior, kf.x)
    F2 = np.eye(4) * 0.5
    x, P = kf.x.copy(), kf.P.copy()
    xp, Pp = kf.get_prediction(u=2.0, B=np.ones((4, 1)), F=F2, Q=np.eye(4))
    np.testing.assert_array_equal(kf.x, x)  # unchanged
    kf.predict(u=2.0, B=np.ones((4, 1)), F=F2, Q=np.eye(4))
    np.testing.assert_allclose(kf.x, 0.5 * x + 2.0, rtol=1e-15)
    np.testing.assert_allclose(kf.P, 1.21 * 0.25 * P + np.eye(4), rtol=1e-14)
    np.testing.assert_array_equal(xp, kf.x)
    np.testing.assert_array_equal(Pp, kf.P)
    with pytest.raises(ValueError, match="alpha"):
        kf.alpha = 0.5


def test_sequential_updates_equal_the_joint_update_for_independent_noise():
    a = random_filter(4, 3)
    a.R = np.diag([0.5, 1.0, 2.0])
    b = copy.deepcopy(a)
    z = rng.standard_normal(3)
    a.predict()
    b.predict()
    a.update(z)
    b.update_sequential(0, z[:1])
    b.update_sequential(1, z[1:])
    np.testing.assert_allclose(b.x, a.x, rtol=1e-12)
    np.testing.assert_allclose(b.P, a.P, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(b.z, z[:, None])
    with pytest.raises(kfx.Error, match="start"):
        b.update_sequential(2, z[:2])


def test_steady_state_steps_use_the_stored_gain():
    kf = cv_filter()
    dare = kfx.solve_filter_dare(kf.F, kf.H, kf.Q, kf.R)
    kf.K = dare.filter_gain
    P = kf.P.copy()
    x = kf.x.copy()
    kf.predict_steadystate()
    np.testing.assert_allclose(kf.x, kf.F @ x, rtol=1e-15)
    kf.update_steadystate(3.0)
    xp = kf.F @ x
    np.testing.assert_allclose(kf.x, xp + dare.filter_gain * (3.0 - xp[0, 0]), rtol=1e-14)
    np.testing.assert_array_equal(kf.P, P)
    np.testing.assert_allclose(kf.residual_of(3.0), 3.0 - kf.H @ kf.x_prior, rtol=1e-15)
    np.testing.assert_allclose(kf.measurement_of_state(kf.x), kf.H @ kf.x)


def test_update_correlated_is_the_conditional_of_the_joint_gaussian():
    kf = random_filter(4, 2)
    kf.M = 0.2 * rng.standard_normal((4, 2))
    kf.predict()
    x, P = kf.x[:, 0].copy(), kf.P.copy()
    z = rng.standard_normal(2)
    kf.update_correlated(z)
    xr, Pr, y, S, K = ref_update(x, P, z, kf.H, kf.R, kf.M)
    np.testing.assert_allclose(kf.x[:, 0], xr, rtol=1e-12)
    np.testing.assert_allclose(kf.P, Pr, rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(kf.S, S, rtol=1e-13)
    np.testing.assert_allclose(kf.K, K, rtol=1e-12)


class Counter:
    def __init__(self, kf):
        self.kf, self.xs = kf, []

    def save(self):
        self.xs.append(self.kf.x.copy())


@pytest.mark.parametrize("update_first", [False, True])
def test_batch_filter_equals_the_step_loop(update_first):
    zs = [rng.standard_normal(2) for _ in range(12)]
    zs[4] = None
    a, b = random_filter(4, 2), None
    b = copy.deepcopy(a)
    saver = Counter(a)
    mu, cov, mu_p, cov_p = a.batch_filter(zs, update_first=update_first, saver=saver)
    assert mu.shape == (12, 4, 1) and cov.shape == (12, 4, 4) and len(saver.xs) == 12
    for i, z in enumerate(zs):
        first, second = (b.update, b.predict) if update_first else (b.predict, b.update)
        (first(z) if update_first else first())
        np.testing.assert_allclose((mu if update_first else mu_p)[i], b.x, rtol=1e-12, atol=1e-14)
        (second() if update_first else second(z))
        np.testing.assert_allclose((mu_p if update_first else mu)[i], b.x, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose((cov_p if update_first else cov)[i], b.P, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(saver.xs[i], b.x, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(a.x, b.x, rtol=1e-12)
    # without a saver: the same numbers (the compiled run), and the attributes of the last step
    c = copy.deepcopy(b)
    d = copy.deepcopy(b)
    zz = np.array([rng.standard_normal(2) for _ in range(30)])
    mu2 = c.batch_filter(zz, update_first=update_first)[0]
    for i, z in enumerate(zz):
        if update_first:
            d.update(z)
            np.testing.assert_allclose(mu2[i], d.x, rtol=1e-11, atol=1e-13)
            d.predict()
        else:
            d.predict()
            d.update(z)
            np.testing.assert_allclose(mu2[i], d.x, rtol=1e-11, atol=1e-13)
    for name in ("x", "P", "y", "K", "S", "x_prior", "P_post"):
        np.testing.assert_allclose(getattr(c, name), getattr(d, name), rtol=1e-10, atol=1e-12, err_msg=name)


def test_batch_filter_per_step_matrices_and_1d_x():
    kf = random_filter(2, 1, column=False)
    ref = copy.deepcopy(kf)
    T = 6
    Fs = [np.eye(2) * (1 + 0.1 * k) for k in range(T)]
    Qs = [0.1 * (k + 1) for k in range(T)]  # numbers: q I
    Hs = [np.array([[1.0, float(k)]]) for k in range(T)]
    Rs = [np.array([[1.0 + k]]) for k in range(T)]
    Bs = [np.array([[1.0], [0.0]])] * T
    us = [float(k) for k in range(T)]
    zs = rng.standard_normal(T)
    mu, _, _, _ = kf.batch_filter(zs, Fs, Qs, Hs, Rs, Bs, us)
    assert mu.shape == (T, 2)
    for k in range(T):
        ref.predict(u=us[k], B=Bs[k], F=Fs[k], Q=Qs[k])
        ref.update(zs[k], R=Rs[k], H=Hs[k])
        np.testing.assert_allclose(mu[k], ref.x, rtol=1e-12, atol=1e-14)
    with pytest.raises(kfx.Error, match="Fs"):
        kf.batch_filter(zs, Fs=Fs[:3])


def test_rts_smoother_equals_the_batch_posterior_and_keeps_filterpys_outputs():
    kf = cv_filter(dt=1.0)
    x0, P0 = kf.x[:, 0].copy(), kf.P.copy()
    F, H, Q, R = kf.F.copy(), kf.H.copy(), kf.Q.copy(), kf.R.copy()
    T = 15
    zs = np.cumsum(rng.standard_normal(T)) + np.arange(T)
    mu, cov, _, _ = kf.batch_filter(zs)
    xs, Ps, Ks, Pp = kf.rts_smoother(mu, cov)
    assert xs.shape == (T, 2, 1)
    # the posterior mean of (x_1..x_T | z) from the stacked information form (x_0 integrated out:
    # x_1 ~ N(F x0, F P0 F^T + Q))
    n = 2
    info, vec = np.zeros((T * n, T * n)), np.zeros(T * n)
    P1 = F @ P0 @ F.T + Q
    info[:n, :n] += np.linalg.inv(P1)
    vec[:n] += np.linalg.solve(P1, F @ x0)
    Qi, Ri = np.linalg.inv(Q), np.linalg.inv(R)
    for k in range(T):
        i = k * n
        info[i:i + n, i:i + n] += H.T @ Ri @ H
        vec[i:i + n] += (H.T @ Ri)[:, 0] * zs[k]
        if k + 1 < T:
            J = np.zeros((n, T * n))
            J[:, i:i + n], J[:, i + n:i + 2 * n] = -F, np.eye(n)
            info += J.T @ Qi @ J
    np.testing.assert_allclose(xs[:, :, 0], np.linalg.solve(info, vec).reshape(T, n), rtol=1e-9, atol=1e-9)
    cov_all = np.linalg.inv(info)
    for k in range(T):
        np.testing.assert_allclose(Ps[k], cov_all[k * n:(k + 1) * n, k * n:(k + 1) * n], rtol=1e-8, atol=1e-10)
    np.testing.assert_array_equal(Pp[-1], cov[-1])  # FilterPy leaves the last Pp at the filtered P
    np.testing.assert_array_equal(Ks[-1], np.zeros((2, 2)))
    np.testing.assert_allclose(Pp[3], F @ cov[3] @ F.T + Q, rtol=1e-14)
    with pytest.raises(kfx.Error, match="length"):
        kf.rts_smoother(mu, cov[:-1])


def test_get_update_and_dimension_checks_and_repr():
    kf = random_filter(4, 2)
    kf.predict()
    x, P = kf.x.copy(), kf.P.copy()
    z = rng.standard_normal(2)
    xu, Pu = kf.get_update(z)
    np.testing.assert_array_equal(kf.x, x)
    xr, Pr, _, _, _ = ref_update(x[:, 0], P, z, kf.H, kf.R)
    np.testing.assert_allclose(xu[:, 0], xr, rtol=1e-12)
    np.testing.assert_allclose(Pu, Pr, rtol=1e-12, atol=1e-14)
    assert kf.get_update()[0] is kf.x
    kf.test_matrix_dimensions()
    kf.test_matrix_dimensions(z=np.zeros((2, 1)))
    with pytest.raises(AssertionError):
        kf.test_matrix_dimensions(z=3.0)
    with pytest.raises(AssertionError):
        kf.test_matrix_dimensions(H=np.ones((2, 3)))
    text = repr(kf)
    assert text.startswith("KalmanFilter object\ndim_x = 4") and "x = [[" in text and "].T" in text
    assert "mahalanobis = " in text and "B = None" in text


def test_deepcopy_and_pickle_carry_the_whole_state():
    kf = random_filter(3, 2)
    kf.B = np.ones((3, 1))
    kf.alpha = 1.05
    kf.tag = "mine"  # an attribute of the user's own
    for z in rng.standard_normal((5, 2)):
        kf.predict(u=1.0)
        kf.update(z)
    ll = kf.log_likelihood
    for clone in (copy.deepcopy(kf), pickle.loads(pickle.dumps(kf))):
        assert type(clone) is kfx.KalmanFilter and clone.tag == "mine" and clone.alpha == kf.alpha
        for name in ("x", "P", "F", "H", "Q", "R", "B", "M", "K", "y", "S", "SI", "z", "x_prior", "P_post"):
            np.testing.assert_array_equal(getattr(clone, name), getattr(kf, name), err_msg=name)
        assert clone.log_likelihood == ll
        clone.F[0, 0] += 1.0
        assert kf.F[0, 0] != clone.F[0, 0]  # independent
    a, b = copy.deepcopy(kf), copy.deepcopy(kf)
    for k2 in (a, b):
        k2.predict(u=0.5)
        k2.update([0.1, 0.2])
    np.testing.assert_array_equal(a.x, b.x)


def test_invalid_input_raises_kfx_error_naming_it():
    kf = kfx.KalmanFilter(2, 1)
    for name, value, what in (("F", np.eye(3), "F"), ("H", np.ones((2, 2)), "H"), ("P", np.diag([1.0, -1.0]), "P"),
                              ("Q", np.array([[1.0, 2.0], [0.0, 1.0]]), "Q"), ("R", -1.0, "R"),
                              ("x", np.zeros(3), "x"), ("x", np.array([np.nan, 0.0]), "x"),
                              ("M", np.ones((3, 1)), "M"), ("B", np.ones((3, 1)), "B"), ("F", "abc", "F")):
        with pytest.raises(kfx.Error, match=what):
            setattr(kf, name, value)
    with pytest.raises(kfx.Error, match="z"):
        kf.update(np.zeros(2))
    with pytest.raises(kfx.Error, match="z"):
        kf.update(np.inf)
    with pytest.raises(kfx.Error, match="dim_x"):
        kfx.KalmanFilter(0, 1)
    with pytest.raises(kfx.Error, match="inv"):
        kf.inv = np.linalg.pinv
    kf.P.shape = (4,)  # numpy allows reshaping in place: refused at the next step, not read wrongly
    with pytest.raises(kfx.Error, match="P"):
        kf.predict()


def test_an_indefinite_innovation_covariance_stops_with_a_numerical_error():
    # FilterPy would invert S = H P H^T + R < 0 and go on; kfx raises, saying so.
    kf = kfx.KalmanFilter(1, 1)
    kf.H = np.array([[1.0]])
    kf.R = 0.0
    kf.P[0, 0] = -1.0  # in place: not checked at assignment
    with pytest.raises(kfx.NumericalError, match="FilterPy"):
        kf.update(1.0)
