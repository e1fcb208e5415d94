"""kfx core from Python: the same numbers as the C++ library (and its CLI) and as independent
numpy/closed-form computations; shapes, dtypes and memory orders; every error path."""
import json
import math
import os
import subprocess

import numpy as np
import pytest
from conftest import numpy_kalman

import kfx


def make(d):
    return kfx.Model(A=d["A"], C=d["C"], Q=d["Q"], R=d["R"], m0=d["m0"], P0=d["P0"])


# ---- the same numbers as the C++ CLI on the same inputs ----------------------------------------------


def test_simulate_filter_smooth_equal_the_cli_bit_for_bit(cv, cli, root, tmp_path):
    model_file = os.path.join(root, "examples", "models", "constant_velocity.json")
    subprocess.run([cli, "simulate", model_file, "--steps", "40", "--seed", "5", "-o", str(tmp_path / "sim")],
                   check=True, capture_output=True)
    subprocess.run([cli, "smooth", model_file, "--data", str(tmp_path / "sim" / "y.npy"), "-o",
                    str(tmp_path / "s")], check=True, capture_output=True)
    subprocess.run([cli, "filter", model_file, "--data", str(tmp_path / "sim" / "y.npy"), "-o",
                    str(tmp_path / "f")], check=True, capture_output=True)
    model = make(cv)
    x, y = kfx.simulate(model, steps=40, seed=5)
    assert np.array_equal(x, np.load(tmp_path / "sim" / "x.npy"))
    assert np.array_equal(y, np.load(tmp_path / "sim" / "y.npy"))
    run = kfx.run_filter(model, y, store_covariances="full")
    assert np.array_equal(run.x_filt, np.load(tmp_path / "f" / "x_filt.npy"))
    assert np.array_equal(run.P_filt_diag, np.load(tmp_path / "f" / "P_filt_diag.npy"))
    sm = kfx.rts_smooth(model, run)
    assert np.array_equal(sm.x, np.load(tmp_path / "s" / "x_smooth.npy"))


def test_reproduce_equals_the_cli_json(cli, tmp_path):
    out = tmp_path / "r.json"
    subprocess.run([cli, "reproduce", "patel-toda", "--quick", "--json", str(out)], check=True, capture_output=True)
    cpp = json.load(open(out))["items"]
    py = kfx.reproduce("patel-toda", quick=True)
    assert [i["key"] for i in py] == [i["key"] for i in cpp]
    for a, b in zip(py, cpp):
        assert set(a) >= {"paper", "key", "description", "published", "value", "rel_diff", "status", "note"}
        assert a["paper"] == "patel-toda" and a["status"] == b["status"]
        assert a["value"] == pytest.approx(b["value"], rel=1e-12, abs=1e-300)
        assert (a["published"] is None) == (b["published"] is None)
    assert kfx.paper_ids() == ["aalto-spatial", "bernstein", "patel-toda", "aalto-temporal", "block-diagonal"]


# ---- closed forms (the numbers of tests/riccati/riccati_test.cpp and tests/filter/kalman_filter_test.cpp) -----------


@pytest.mark.parametrize("a,c,q,r", [(0.5, 1.0, 1.0, 1.0), (1.5, 2.0, 0.3, 0.7), (-3.0, 0.5, 2.0, 4.0),
                                     (0.99, 1e-3, 1.0, 1.0), (20.0, 1.0, 1e-4, 1e2), (1.0, 1.0, 1.0, 1.0)])
@pytest.mark.parametrize("method", ["auto", "doubling", "schur"])
def test_scalar_dare_is_the_positive_root(a, c, q, r, method):
    # p = a^2 p r / (c^2 p + r) + q  <=>  c^2 p^2 + (r - a^2 r - q c^2) p - q r = 0
    b = r - a * a * r - q * c * c
    p = (-b + math.sqrt(b * b + 4 * c * c * q * r)) / (2 * c * c)
    s = kfx.solve_filter_dare([[a]], [[c]], [[q]], [[r]], method=method)
    assert s.summary.ok and s.summary.termination == "converged"
    assert s.P_pred[0, 0] == pytest.approx(p, rel=1e-11)
    kf = p * c / (c * c * p + r)
    assert s.filter_gain[0, 0] == pytest.approx(kf, rel=1e-11)
    assert s.predictor_gain[0, 0] == pytest.approx(a * kf, rel=1e-11)
    assert s.P_filt[0, 0] == pytest.approx(p * r / (c * c * p + r), rel=1e-11)


def test_double_integrator_dare_closed_form():
    # tests/riccati/riccati_test.cpp: a = 2, r = 1 gives q = 1/3, P = [2 1; 1 1], K_f = [2/3; 1/3], K_p = [1; 1/3].
    A = np.array([[1.0, 1.0], [0.0, 1.0]])
    s = kfx.solve_filter_dare(A, [[1.0, 0.0]], np.diag([0.0, 1.0 / 3]), [[1.0]], exact_eigenvalues=True)
    assert s.eigenvalues_exact
    np.testing.assert_allclose(s.P_pred, [[2, 1], [1, 1]], atol=1e-13)
    np.testing.assert_allclose(s.filter_gain, [[2 / 3], [1 / 3]], atol=1e-14)
    np.testing.assert_allclose(s.predictor_gain, [[1], [1 / 3]], atol=1e-14)
    assert s.closed_loop_spectral_radius == pytest.approx(1 / math.sqrt(3), abs=1e-14)
    assert kfx.filter_dare_residual(A, [[1.0, 0.0]], np.diag([0.0, 1.0 / 3]), [[1.0]], s.P_pred) < 1e-14
    # Default: stability proven by the Lyapunov certificate, which reports an upper bound on rho.
    b = kfx.solve_filter_dare(A, [[1.0, 0.0]], np.diag([0.0, 1.0 / 3]), [[1.0]])
    assert b.lyapunov_certified and not b.eigenvalues_exact
    assert 1 / math.sqrt(3) <= b.closed_loop_spectral_radius < 1


def test_golden_ratio_and_lyapunov():
    s = kfx.solve_filter_dare([[1.0]], [[1.0]], [[1.0]], [[1.0]])
    assert s.P_pred[0, 0] == pytest.approx((1 + math.sqrt(5)) / 2, abs=1e-15)
    rng = np.random.default_rng(1)
    A = rng.standard_normal((5, 5))
    A *= 0.8 / kfx.spectral_radius(A)
    Q = np.eye(5)
    sol = kfx.solve_discrete_lyapunov(A, Q)
    assert sol.summary.ok and sol.summary.termination == "converged"
    X = sol.X
    # independent: the Kronecker form (I - A (x) A) vec X = vec Q
    Xk = np.linalg.solve(np.eye(25) - np.kron(A, A), Q.reshape(-1)).reshape(5, 5)
    np.testing.assert_allclose(X, Xk, rtol=1e-10, atol=1e-12)
    assert kfx.spectral_radius(A) == pytest.approx(max(abs(np.linalg.eigvals(A))), rel=1e-12)


def test_dare_agrees_with_the_riccati_recursion(random_model):
    d = random_model
    s = kfx.solve_filter_dare(d["A"], d["C"], d["Q"], d["R"])
    P = np.eye(4)
    for _ in range(2000):
        S = d["C"] @ P @ d["C"].T + d["R"]
        P = d["A"] @ (P - P @ d["C"].T @ np.linalg.solve(S, d["C"] @ P)) @ d["A"].T + d["Q"]
    np.testing.assert_allclose(s.P_pred, P, rtol=1e-9)


def test_discretizations():
    A = np.array([[0.0, 1.0], [-2.0, -0.3]])
    Ad, Bd = kfx.discretize_zoh(A, np.array([[0.0], [1.0]]), 0.1)
    # independent: a truncated Taylor series of the block exponential
    M = np.zeros((3, 3))
    M[:2, :2], M[:2, 2:] = A * 0.1, np.array([[0.0], [1.0]]) * 0.1
    E, term = np.eye(3), np.eye(3)
    for k in range(1, 30):
        term = term @ M / k
        E = E + term
    np.testing.assert_allclose(Ad, E[:2, :2], atol=1e-14)
    np.testing.assert_allclose(Bd, E[:2, 2:], atol=1e-14)
    np.testing.assert_allclose(kfx.matrix_exponential(A * 0.1), E[:2, :2], atol=1e-14)
    Ad2, Qd = kfx.discretize_process_noise(A, np.diag([0.0, 1.0]), 0.1)
    np.testing.assert_allclose(Ad2, Ad, atol=1e-14)
    assert np.allclose(Qd, Qd.T) and min(np.linalg.eigvalsh(Qd)) > 0


# ---- the filter against an independent numpy implementation ------------------------------------------


def test_run_filter_equals_a_numpy_loop(random_model):
    d = random_model
    model = make(d)
    x, y = kfx.simulate(model, steps=60, seed=3)
    assert x.shape == (61, 4) and y.shape == (60, 2) and x.dtype == np.float64
    run = kfx.run_filter(model, y, store_covariances="full")
    xs, Ps, ll = numpy_kalman(d["A"], d["C"], d["Q"], d["R"], d["m0"], d["P0"], y)
    np.testing.assert_allclose(run.x_filt[1:], xs, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(run.P_filt[1:], Ps, rtol=1e-10, atol=1e-12)
    assert run.P_filt.shape == (61, 4, 4) and run.innovations.shape == (60, 2)
    assert run.log_likelihood == pytest.approx(ll, rel=1e-11)


def test_kalman_filter_class_predict_update_equal_batch_filter_and_numpy(random_model):
    d = random_model
    kf = kfx.KalmanFilter(dim_x=4, dim_z=2)
    kf.F, kf.H, kf.Q, kf.R, kf.x, kf.P = d["A"], d["C"], d["Q"], d["R"], d["m0"], d["P0"]
    _, y = kfx.simulate(make(d), steps=30, seed=9)
    xs, Ps, _ = numpy_kalman(d["A"], d["C"], d["Q"], d["R"], d["m0"], d["P0"], y)
    means, covs = [], []
    for z in y:
        kf.predict()
        np.testing.assert_array_equal(kf.x_prior, kf.x)
        kf.update(z)
        means.append(kf.x)
        covs.append(kf.P)
        assert kf.K.shape == (4, 2) and kf.y.shape == (2,) and kf.S.shape == (2, 2)  # 1-D x: 1-D y
    np.testing.assert_allclose(means, xs, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(covs, Ps, rtol=1e-10, atol=1e-12)
    kf2 = kfx.KalmanFilter(make(d))  # x = m0 as a column, as FilterPy shapes x
    mu, cov, mu_p, cov_p = kf2.batch_filter(y)
    assert mu.shape == (30, 4, 1) and cov.shape == (30, 4, 4) and mu_p.shape == (30, 4, 1) and cov_p.shape == (30, 4, 4)
    mu, mu_p = mu[:, :, 0], mu_p[:, :, 0]
    np.testing.assert_allclose(mu, means, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(cov, covs, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(kf2.x[:, 0], means[-1], rtol=1e-12)
    # mu_p is A times the previous filtered mean
    np.testing.assert_allclose(mu_p[1:], mu[:-1] @ d["A"].T, rtol=1e-12, atol=1e-14)


def test_rts_smoother_equals_the_model_smoother_and_a_batch_solution(cv):
    model = make(cv)
    _, y = kfx.simulate(model, steps=25, seed=2)
    kf = kfx.KalmanFilter(model)
    mu, cov, _, _ = kf.batch_filter(y)
    xs, Ps, Ks, Pp = kf.rts_smoother(mu[:, :, 0], cov)
    assert xs.shape == (25, 2) and Ps.shape == (25, 2, 2) and Ks.shape == (25, 2, 2) and Pp.shape == (25, 2, 2)
    sm = kfx.rts_smooth(model, kfx.run_filter(model, y, store_covariances="full"))
    np.testing.assert_allclose(xs, sm.x[1:], rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(Ps, sm.P[1:], rtol=1e-9, atol=1e-10)
    # independent: the smoothed mean is the posterior mean of the stacked Gaussian (x_0..x_T | y)
    A, C, Q, R = cv["A"], cv["C"], cv["Q"], cv["R"]
    T, n = 25, 2
    N = (T + 1) * n
    info, vec = np.zeros((N, N)), np.zeros(N)
    info[:n, :n] += np.linalg.inv(cv["P0"])
    Qi, Ri = np.linalg.inv(Q), np.linalg.inv(R)
    for k in range(1, T + 1):
        i0, i1 = (k - 1) * n, k * n
        J = np.zeros((n, N))
        J[:, i0:i0 + n], J[:, i1:i1 + n] = -A, np.eye(n)
        info += J.T @ Qi @ J
        info[i1:i1 + n, i1:i1 + n] += C.T @ Ri @ C
        vec[i1:i1 + n] += C.T @ Ri @ y[k - 1]
    np.testing.assert_allclose(np.linalg.solve(info, vec).reshape(T + 1, n), sm.x, rtol=1e-8, atol=1e-9)


def test_missing_measurements_are_nan(random_model):
    d = random_model
    model = make(d)
    _, y = kfx.simulate(model, steps=10, seed=1)
    y[3, 1] = np.nan
    y[5, :] = np.nan
    run = kfx.run_filter(model, y)
    assert run.num_observed[3] == 1 and run.num_observed[5] == 0
    assert np.isnan(run.innovations[5]).all()
    kf = kfx.KalmanFilter(model)
    for k, z in enumerate(y):
        kf.predict()
        kf.update(z)
        np.testing.assert_allclose(kf.x[:, 0], run.x_filt[k + 1], rtol=1e-12, atol=1e-14)
        if k == 3:
            assert np.isfinite(kf.y[0, 0]) and np.isnan(kf.y[1, 0]) and kf.K[0, 1] == 0.0


# ---- shapes, dtypes and memory orders ----------------------------------------------------------------


def test_fortran_ordered_noncontiguous_and_integer_inputs_give_the_same_numbers(random_model):
    d = random_model
    model = make(d)
    _, y = kfx.simulate(model, steps=20, seed=4)
    ref = kfx.run_filter(model, y).x_filt
    wide = np.zeros((20, 5))
    wide[:, ::2][:, :2] = y  # non-contiguous view: every other column
    view = wide[:, ::2][:, :2]
    assert not view.flags.c_contiguous
    modelF = kfx.Model(A=np.asfortranarray(d["A"]), C=np.asfortranarray(d["C"]), Q=np.asfortranarray(d["Q"]),
                       R=np.asfortranarray(d["R"]), m0=d["m0"], P0=np.asfortranarray(d["P0"]))
    for yy in (np.asfortranarray(y), view, y.T.copy().T):
        out = kfx.run_filter(modelF, yy).x_filt
        assert out.dtype == np.float64 and out.shape == (21, 4) and out.flags.c_contiguous
        np.testing.assert_allclose(out, ref, rtol=1e-12, atol=1e-14)
    # float32 input is converted to float64 (the same numbers as the float64 copy of those values)
    y32 = y.astype(np.float32)
    np.testing.assert_array_equal(kfx.run_filter(model, y32).x_filt,
                                  kfx.run_filter(model, y32.astype(np.float64)).x_filt)
    # integer arrays convert to float64
    s = kfx.solve_filter_dare(np.array([[1]]), np.array([[1]]), np.array([[1]]), np.array([[1]]))
    assert s.P_pred.dtype == np.float64
    # 1-D x and (n, 1) x are both accepted by the FilterPy class, and keep their shape
    kf = kfx.KalmanFilter(4, 2)
    kf.x = d["m0"].reshape(4, 1)
    assert kf.x.shape == (4, 1)
    kf.x = list(d["m0"])
    np.testing.assert_array_equal(kf.x, d["m0"])


def test_scalar_and_column_measurements_for_dim_z_1(cv):
    model = make(cv)
    _, y = kfx.simulate(model, steps=5, seed=1)
    ref = kfx.run_filter(model, y).x_filt
    for convert in (lambda z: float(z[0]), lambda z: z.reshape(1, 1), lambda z: z):
        kf = kfx.KalmanFilter(model)
        for k, z in enumerate(y):
            kf.predict()
            kf.update(convert(z))
            np.testing.assert_allclose(kf.x[:, 0], ref[k + 1], rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(kfx.KalmanFilter(model).batch_filter(y[:, 0])[0][:, :, 0], ref[1:], rtol=1e-13, atol=1e-14)
    with pytest.raises(kfx.Error, match="length 2"):
        kf2 = kfx.KalmanFilter(2, 2)
        kf2.update(1.0)


def test_returned_arrays_are_copies_or_read_only(cv):
    kf = kfx.KalmanFilter(make(cv))
    x0 = kf.x
    kf.predict()
    kf.update([1.0])
    assert not np.array_equal(x0, kf.x)  # the old array is not overwritten
    step = make(cv).step(1)
    with pytest.raises(ValueError):
        step.A[0, 0] = 5.0


# ---- the exact-performance engine and Monte Carlo ----------------------------------------------------


def test_exact_performance_of_the_kalman_filter_is_its_own_covariance(random_model):
    model = make(random_model)
    f = kfx.kalman_as_linear_filter(model, 30)
    perf = kfx.exact_performance(model, f)
    sched = kfx.kalman_schedule(model, 30)
    np.testing.assert_allclose(perf.mse, np.trace(sched.P_filt, axis1=1, axis2=2), rtol=1e-10)
    assert perf.error_moment.shape == (31, 4, 4) and perf.bias.shape == (31, 4)
    mc = kfx.monte_carlo_performance(model, f, runs=400, seed=2)
    z = (mc.mse[1:] - perf.mse[1:]) / mc.mse_std_error[1:]
    assert np.max(np.abs(z)) < 4.5  # 30 steps, each within 4.5 standard errors
    # a constant-gain filter: stationary value from ExactStationaryPerformance = limit of ExactPerformance
    d = random_model
    dare = kfx.solve_filter_dare(d["A"], d["C"], d["Q"], d["R"])
    cg = kfx.constant_gain_as_linear_filter(model.step(1), dare.filter_gain, d["m0"])
    st = kfx.exact_stationary_performance(model, cg)
    assert st.summary.ok and st.mse == pytest.approx(np.trace(dare.P_filt), rel=1e-9)
    long = kfx.exact_performance(model, cg, steps=400, store_error_moments=False)
    assert long.mse[-1] == pytest.approx(st.mse, rel=1e-8)


def test_linear_filter_run_equals_the_kalman_run(random_model):
    model = make(random_model)
    _, y = kfx.simulate(model, steps=15, seed=8)
    f = kfx.kalman_as_linear_filter(model, 15)
    np.testing.assert_allclose(f.run(y), kfx.run_filter(model, y).x_filt, rtol=1e-10, atol=1e-12)
    g = kfx.LinearFilter(Phi=0.5 * np.eye(4), K=np.ones((4, 2)), z0=np.zeros(4))
    assert g.time_invariant and g.state_dim == 4 and g.meas_dim == 2


# ---- every error path raises a Python exception naming the argument ---------------------------------


def expect_error(fn, *words, exc=kfx.Error):
    with pytest.raises(exc) as e:
        fn()
    for w in words:
        assert w in str(e.value), (w, str(e.value))
    return e.value


def test_errors_are_value_errors_naming_the_argument(cv):
    assert issubclass(kfx.Error, ValueError) and issubclass(kfx.NumericalError, ArithmeticError)
    d = dict(cv)
    bad_Q = dict(d, Q=np.array([[1.0, 0.5], [0.0, 1.0]]))
    expect_error(lambda: make(bad_Q), "Q", "symmetric")
    expect_error(lambda: make(dict(d, R=np.array([[-1.0]]))), "R")
    expect_error(lambda: make(dict(d, A=np.ones((3, 3)))), "C")
    expect_error(lambda: make(dict(d, A=np.array([[np.nan, 1], [0, 1]]))), "A")
    expect_error(lambda: make(dict(d, m0=np.zeros(3))), "m0")
    expect_error(lambda: make(dict(d, P0=-np.eye(2))), "P0")
    model = make(d)
    expect_error(lambda: kfx.run_filter(model, np.zeros((5, 3))), "y")
    expect_error(lambda: kfx.run_filter(model, np.array([[np.inf]])), "y")
    expect_error(lambda: kfx.simulate(model, steps=-1), "steps")
    expect_error(lambda: kfx.solve_filter_dare(np.eye(2), np.eye(2), np.eye(3), np.eye(2)), "Q")
    expect_error(lambda: kfx.solve_filter_dare(np.eye(2), np.eye(2), np.eye(2), np.eye(2), method="qz"), "method")
    expect_error(lambda: kfx.solve_discrete_lyapunov(np.ones((2, 3)), np.eye(2)), "A")
    expect_error(lambda: kfx.exact_performance(model, kfx.LinearFilter(np.eye(3), np.ones((3, 1)), np.zeros(3))),
                 "filter")
    expect_error(lambda: kfx.reproduce("nope"), "nope")
    kf = kfx.KalmanFilter(2, 1)
    expect_error(lambda: setattr(kf, "F", np.eye(3)), "F", "(2, 2)")
    expect_error(lambda: setattr(kf, "H", np.eye(2)), "H")
    expect_error(lambda: setattr(kf, "Q", np.array([[1.0, 2.0], [0.0, 1.0]])), "Q")
    expect_error(lambda: setattr(kf, "R", -np.ones((1, 1))), "R")
    expect_error(lambda: setattr(kf, "P", np.array([[1.0, 0.0], [0.0, -1.0]])), "P")
    expect_error(lambda: setattr(kf, "x", np.zeros(3)), "x")
    expect_error(lambda: setattr(kf, "x", np.array([np.nan, 0.0])), "x")
    expect_error(lambda: setattr(kf, "update_form", "other"), "update_form")
    expect_error(lambda: kfx.KalmanFilter(0, 1), "dim_x")
    kf.predict()
    expect_error(lambda: kf.update(np.zeros(2)), "z", "length 1")
    expect_error(lambda: kf.batch_filter(np.zeros((4, 2))), "zs")
    expect_error(lambda: kf.rts_smoother(np.zeros((4, 2)), np.zeros((3, 2, 2))), "Ps")
    expect_error(lambda: kfx.solve_filter_dare("A", np.eye(1), np.eye(1), np.eye(1)), "real numbers")


def test_numerical_breakdown_raises_numerical_error():
    # Valid inputs whose S = C P C^T + R is singular in floating point (C of rank 1, R = 1e-40 I below
    # the rounding of C P C^T = [[2, 2], [2, 2]]): a numerical breakdown, kfx.NumericalError, not a
    # silently wrong number. (An indefinite P is refused by kfx.Estimate itself: test_inputs.py.)
    step = kfx.ModelStep(A=np.eye(2), C=np.ones((2, 2)), Q=np.zeros((2, 2)), R=1e-40 * np.eye(2))
    est = kfx.Estimate(np.zeros(2), np.eye(2))
    expect_error(lambda: kfx.update(est, step, np.array([1.0, 1.0])), "innovation covariance",
                 exc=kfx.NumericalError)
    step = kfx.ModelStep(A=np.eye(1), C=np.ones((1, 1)), Q=np.zeros((1, 1)), R=np.ones((1, 1)))
    ok = kfx.update(kfx.Estimate(np.zeros(1), np.ones((1, 1))), step, np.array([1.0]))
    assert ok.estimate.x[0] == pytest.approx(0.5) and ok.gain[0, 0] == pytest.approx(0.5)


def test_one_summary_shape_reports_numerical_outcomes():
    # The DARE, the Lyapunov equation and the stationary analysis report how they ended in the same
    # kfx.Summary; numerical outcomes are never raised.
    s = kfx.solve_filter_dare(np.eye(1), np.eye(1), np.eye(1), np.eye(1))
    assert isinstance(s.summary, kfx.Summary) and s.summary.ok
    assert s.summary.computation == "filter DARE" and s.summary.method in ("doubling", "schur")
    assert s.summary.relative_residual < 1e-14 and "rho(A - K_p C)" in s.summary.details
    assert "termination" in s.summary.full_report() and "\n" not in s.summary.brief_report()
    undetectable = kfx.solve_filter_dare(np.array([[1.5]]), np.zeros((1, 1)), np.eye(1), np.eye(1))
    assert not undetectable.summary.ok and undetectable.summary.termination == "not_detectable"
    singular = kfx.solve_discrete_lyapunov(np.eye(2), np.eye(2))
    assert isinstance(singular.summary, kfx.Summary)
    assert singular.summary.termination == "singular" and "spectral radius 1" in singular.summary.message
    model = kfx.Model(A=np.array([[1.0]]), C=np.eye(1), Q=np.eye(1), R=np.eye(1), m0=np.zeros(1), P0=np.eye(1))
    wrong = kfx.constant_gain_as_linear_filter(kfx.ModelStep(np.array([[0.5]]), np.eye(1), np.eye(1), np.eye(1)),
                                                np.array([[0.5]]), np.zeros(1))
    st = kfx.exact_stationary_performance(model, wrong)
    assert st.summary.termination == "unstable" and math.isinf(st.mse)


def test_zero_dimensions_are_rejected_naming_the_matrix():
    # Issue 20, class 3: a model of (0, 0) arrays is a kfx.Error naming A or C, never a crash,
    # a SystemError or a BLAS message; the smoother and the simulator never see it.
    z = np.zeros((0, 0))
    expect_error(lambda: kfx.Model(A=z, C=np.zeros((1, 0)), Q=z, R=np.eye(1), m0=np.zeros(0), P0=z), "A", "n = 0")
    expect_error(lambda: kfx.Model(A=np.eye(2), C=np.zeros((0, 2)), Q=np.eye(2), R=z, m0=np.zeros(2), P0=np.eye(2)),
                 "C", "m = 0")


# ---- kfx.compare: the rows of `kfx compare` (docs/cli.md) ---------------------------------------------


def test_compare_rows_against_the_kalman_filter_and_monte_carlo(root, tmp_path):
    chain = os.path.join(root, "examples", "models", "mass_spring_chain.json")
    rows = kfx.compare(chain, ["kalman", "steady", "tau:order=4,step=two-da"], steps=30, monte_carlo=300, seed=3)
    assert [r["method"] for r in rows] == ["kalman", "steady", "tau:order=4,step=two-da"]
    ref = rows[0]["kalman_final_mse"]
    assert abs(rows[0]["mse"] - ref) <= 1e-8 * ref  # the Kalman row is the Riccati recursion's tr P_{T|T}
    assert abs(rows[1]["stationary_mse"] - rows[1]["kalman_stationary_mse"]) <= 1e-8 * rows[1]["stationary_mse"]
    for r in rows:
        assert r["mse"] >= ref * (1 - 1e-9)
        assert abs(r["monte_carlo_mse"] - r["mse"]) <= 4 * r["monte_carlo_std_error"]
        assert len(r["mse_curve"]) == 31
    with pytest.raises(kfx.Error, match="method 'tau:order=9': order 9 is larger than the state dimension 8"):
        kfx.compare(chain, ["tau:order=9"])
    assert kfx.parse_method("tau:order=4,step=two-da") == ("tau", {"order": "4", "step": "two-da"})
    written = kfx.plots.save(kfx.plots.compare_pareto(rows), str(tmp_path / "pareto.png"))
    assert all(os.path.getsize(p) > 0 for p in written)


def test_compare_sampled_filters_of_a_continuous_model_file(root):
    """sampled:dt=H on examples/continuous/oscillator.json: the library's P_{T,n}, between the Kalman filter
    and the Kalman-Bucy filter (kfx.kalman_bucy_covariance), Monte Carlo within its interval."""
    osc = os.path.join(root, "examples", "continuous", "oscillator.json")
    rows = kfx.compare(osc, ["kalman", "sampled:dt=0.1", "sampled:dt=0.4"], steps=40, monte_carlo=300, seed=4)
    cm = kfx.ContinuousModel(A=[[0, 1], [-1, -0.4]], C=[[1, 0]], Q=[[0, 0], [0, 0.5]], B=np.eye(2), R=[[0.02]],
                             m0=[0, 0], P0=np.eye(2))
    for r, n in zip(rows[1:], (20, 5)):
        library = np.trace(kfx.sampled_filter_covariance(cm, 2.0, n))
        assert abs(r["mse"] - library) <= 1e-9 * library, (r["method"], r["mse"], library)
        assert abs(r["monte_carlo_mse"] - r["mse"]) <= 4 * r["monte_carlo_std_error"]
    bucy = np.trace(kfx.kalman_bucy_covariance(cm, 2.0))
    assert abs(rows[0]["kalman_bucy_mse"] - bucy) <= 1e-12 * bucy
    assert bucy < rows[0]["kalman_final_mse"] <= rows[1]["mse"] < rows[2]["mse"]
    with pytest.raises(kfx.Error, match="method 'sampled:dt=0.07': dt=0.07 is not a positive integer multiple"):
        kfx.compare(osc, ["sampled:dt=0.07"])
