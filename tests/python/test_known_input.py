"""A known input G g / D g and a cross-covariance S from Python (issue 22): kfx.Model(..., G=, D=, S=),
kfx.simulate(..., input=) and kfx.run_filter(..., input=) against a numpy loop of the correlated Kalman
filter (an independent implementation of the closed-form recursion), the smoother against the stacked
Gaussian posterior, and the errors naming the argument."""
import numpy as np
import pytest

import kfx


def numpy_correlated_kalman(A, C, Q, R, G, D, S, m0, P0, ys, gs):
    """x_k = A x + G g_k + w, y_k = C x_k + D g_k + v, E[w v^T] = S: predict, then the correlated update."""
    x, P = np.array(m0, float), np.array(P0, float)
    xs, Ps, ll = [x], [P], 0.0
    for y, g in zip(ys, gs):
        x = A @ x + G @ g
        P = A @ P @ A.T + Q
        U = P @ C.T + S
        Sk = C @ P @ C.T + C @ S + S.T @ C.T + R
        K = np.linalg.solve(Sk, U.T).T
        nu = y - C @ x - D @ g
        x = x + K @ nu
        P = P - K @ U.T
        ll += -0.5 * (len(y) * np.log(2 * np.pi) + np.linalg.slogdet(Sk)[1] + nu @ np.linalg.solve(Sk, nu))
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps), ll


@pytest.fixture
def driven():
    rng = np.random.default_rng(22)
    n, m, q = 3, 2, 2
    A = rng.standard_normal((n, n))
    A *= 0.9 / max(abs(np.linalg.eigvals(A)))
    F = rng.standard_normal((n + m, n + m)) / np.sqrt(n + m)
    J = F @ F.T + 0.1 * np.eye(n + m)
    return dict(A=A, C=rng.standard_normal((m, n)), Q=J[:n, :n], R=J[n:, n:], S=J[:n, n:],
                G=rng.standard_normal((n, q)), D=rng.standard_normal((m, q)), m0=rng.standard_normal(n),
                P0=np.eye(n))


def test_model_keeps_g_d_s(driven):
    model = kfx.Model(**driven)
    assert model.input_dim == 2
    step = model.step(1)
    np.testing.assert_array_equal(step.G, driven["G"])
    np.testing.assert_array_equal(step.D, driven["D"])
    np.testing.assert_array_equal(step.S, driven["S"])
    plain = kfx.Model(**{k: v for k, v in driven.items() if k not in "GDS"})
    assert plain.input_dim == 0 and plain.step(1).S.size == 0


@pytest.mark.parametrize("form", ["conventional", "sqrt", "ud", "information"])
def test_run_filter_with_input_and_s_equals_a_numpy_loop(driven, form):
    model = kfx.Model(**driven)
    T = 40
    g = np.random.default_rng(5).standard_normal((T, 2))
    _, y = kfx.simulate(model, steps=T, seed=3, input=g)
    run = kfx.run_filter(model, y, store_covariances="full", form=form, input=g)
    xs, Ps, ll = numpy_correlated_kalman(*(driven[k] for k in "A C Q R G D S m0 P0".split()), y, g)
    np.testing.assert_allclose(run.x_filt, xs, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(run.P_filt, Ps, rtol=1e-8, atol=1e-9)
    assert run.log_likelihood == pytest.approx(ll, rel=1e-10)


def test_simulate_with_input_is_the_driven_recursion(driven):
    d = dict(driven, Q=np.zeros((3, 3)), S=np.zeros((3, 2)), P0=np.zeros((3, 3)))
    model = kfx.Model(**d)
    T = 3000
    g = np.random.default_rng(6).standard_normal((T, 2))
    x, y = kfx.simulate(model, steps=T, seed=8, input=g)
    ref = [d["m0"]]
    for k in range(T):
        ref.append(d["A"] @ ref[-1] + d["G"] @ g[k])
    np.testing.assert_allclose(x, np.array(ref), rtol=1e-10, atol=1e-10)
    v = y - x[1:] @ d["C"].T - g @ d["D"].T  # the measurement noise, N(0, R)
    assert np.all(np.abs(v.mean(0)) < 4 * np.sqrt(np.diag(d["R"]) / T))


def test_smoother_with_s_equals_the_stacked_gaussian_posterior(driven):
    model = kfx.Model(**driven)
    A, C, Q, R, G, D, S = (driven[k] for k in "A C Q R G D S".split())
    T, n, m = 12, 3, 2
    g = np.random.default_rng(9).standard_normal((T, 2))
    _, y = kfx.simulate(model, steps=T, seed=4, input=g)
    sm = kfx.rts_smooth(model, kfx.run_filter(model, y, store_covariances="full", input=g))
    # (x_0..x_T, y_1..y_T) = mean + L xi, xi = (x_0 - m0, (w_1, v_1), ..., (w_T, v_T)).
    N = n + T * (n + m)
    Lx, mx = np.zeros(((T + 1) * n, N)), np.zeros((T + 1) * n)
    Ly, my = np.zeros((T * m, N)), np.zeros(T * m)
    Lx[:n, :n], mx[:n] = np.eye(n), driven["m0"]
    Xi = np.zeros((N, N))
    Xi[:n, :n] = driven["P0"]
    for k in range(1, T + 1):
        c, i, j = n + (k - 1) * (n + m), k * n, (k - 1) * m
        Lx[i:i + n] = A @ Lx[i - n:i]
        Lx[i:i + n, c:c + n] += np.eye(n)
        mx[i:i + n] = A @ mx[i - n:i] + G @ g[k - 1]
        Ly[j:j + m] = C @ Lx[i:i + n]
        Ly[j:j + m, c + n:c + n + m] += np.eye(m)
        my[j:j + m] = C @ mx[i:i + n] + D @ g[k - 1]
        Xi[c:c + n + m, c:c + n + m] = np.block([[Q, S], [S.T, R]])
    Cxy, Cyy = Lx @ Xi @ Ly.T, Ly @ Xi @ Ly.T
    K = np.linalg.solve(Cyy, Cxy.T).T
    mean = mx + K @ (y.reshape(-1) - my)
    cov = Lx @ Xi @ Lx.T - K @ Cxy.T
    np.testing.assert_allclose(sm.x, mean.reshape(T + 1, n), rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(sm.P_diag, np.diag(cov).reshape(T + 1, n), rtol=1e-8, atol=1e-9)


def test_errors_name_the_argument(driven):
    bad = dict(driven, G=np.ones((2, 2)))
    with pytest.raises(kfx.Error, match=r"^G:"):
        kfx.Model(**bad)
    with pytest.raises(kfx.Error, match=r"^D:"):
        kfx.Model(**dict(driven, D=np.ones((2, 3))))
    with pytest.raises(kfx.Error, match=r"^S:"):
        kfx.Model(**dict(driven, S=np.ones((2, 3))))
    with pytest.raises(kfx.Error, match=r"joint covariance"):
        kfx.Model(**dict(driven, S=10 * np.ones((3, 2))))
    with pytest.raises(kfx.Error, match=r"^G:"):
        kfx.ModelStep(A=driven["A"], C=driven["C"], Q=driven["Q"], R=driven["R"], G=np.ones((4, 1)))
    model = kfx.Model(**driven)
    y = np.zeros((5, 2))
    with pytest.raises(kfx.Error, match=r"^g:"):
        kfx.run_filter(model, y)  # the model has G, D: the input is required
    with pytest.raises(kfx.Error, match=r"^g:"):
        kfx.run_filter(model, y, input=np.zeros((5, 3)))
    with pytest.raises(kfx.Error, match=r"^g:"):
        kfx.simulate(model, steps=5, input=np.zeros((4, 2)))


def test_exact_performance_with_input(driven):
    """The engine with input= (issue 22): the Kalman filter that models the input has a zero-mean error and
    the MSE of the model without input; a steady-gain filter that ignores it has the bias of a numpy
    recursion of the error mean, e_k = F e_{k-1} + ((I - K C) G - K D) g_k; Monte Carlo agrees."""
    model = kfx.Model(**driven)
    plain = kfx.Model(**{k: v for k, v in driven.items() if k not in "GD"})
    T = 20
    g = 2.0 * np.random.default_rng(6).standard_normal((T, 2))
    kf = kfx.kalman_as_linear_filter(model, T)
    assert kf.input_dim == 2
    with_input = kfx.exact_performance(model, kf, input=g)
    without = kfx.exact_performance(plain, kfx.kalman_as_linear_filter(plain, T))
    assert np.abs(with_input.bias).max() < 1e-11
    np.testing.assert_allclose(with_input.mse, without.mse, rtol=1e-12, atol=0)
    # The filter's run with the input equals run_filter's estimates.
    _, y = kfx.simulate(model, steps=T, seed=9, input=g)
    np.testing.assert_allclose(kf.run(y, input=g), kfx.run_filter(model, y, input=g).x_filt, rtol=1e-10,
                               atol=1e-10)
    # A constant-gain filter designed without G, D (no Gamma) is biased.
    A, C, G, D = driven["A"], driven["C"], driven["G"], driven["D"]
    K = 0.3 * np.ones((3, 2))
    ignoring = kfx.constant_gain_as_linear_filter(kfx.ModelStep(A=A, C=C, Q=driven["Q"], R=driven["R"]), K,
                                                  driven["m0"])
    assert ignoring.input_dim == 0
    exact = kfx.exact_performance(model, ignoring, steps=T, input=g)
    F, H = (np.eye(3) - K @ C) @ A, (np.eye(3) - K @ C) @ G - K @ D
    b = np.zeros(3)
    for k in range(1, T + 1):
        b = F @ b + H @ g[k - 1]
        np.testing.assert_allclose(exact.bias[k], b, rtol=1e-10, atol=1e-12)
    mc = kfx.monte_carlo_performance(model, ignoring, runs=2000, seed=4, steps=T, input=g)
    z = np.abs(mc.mse - exact.mse) / mc.mse_std_error
    assert z.max() < 4.5 and (z > 1.96).sum() <= 6


def test_exact_performance_input_errors_name_the_argument(driven):
    model = kfx.Model(**driven)
    kf = kfx.kalman_as_linear_filter(model, 5)
    with pytest.raises(kfx.Error, match=r"^g:"):
        kfx.exact_performance(model, kf)  # the truth has G, D: the input is required
    with pytest.raises(kfx.Error, match=r"^g:"):
        kfx.exact_performance(model, kf, input=np.zeros((5, 3)))
    with pytest.raises(kfx.Error, match=r"^g:"):
        kfx.monte_carlo_performance(model, kf, runs=2, input=np.zeros((4, 2)))
    with pytest.raises(kfx.Error, match=r"^g:"):
        kf.run(np.zeros((5, 2)))
    with pytest.raises(kfx.Error, match=r"^Gamma:"):
        kfx.LinearFilter(np.eye(3), np.ones((3, 2)), np.zeros(3), Gamma=np.ones((2, 2)))
    other = kfx.LinearFilter(np.eye(3), np.ones((3, 2)), np.zeros(3), Gamma=np.ones((3, 1)))
    with pytest.raises(kfx.Error, match=r"^filter:"):
        kfx.exact_performance(model, other, input=np.zeros((5, 2)))
    with pytest.raises(kfx.Error, match=r"^truth:"):
        kfx.exact_stationary_performance(model, kfx.constant_gain_as_linear_filter(model.step(1), np.zeros((3, 2)),
                                                                                     np.zeros(3)))
def test_single_steps_with_input_and_s_equal_run_filter(driven):
    """kfx.predict / kfx.update with input= step by step = run_filter (G, D, S, a missing value), 1e-12."""
    model = kfx.Model(**driven)
    T = 12
    rng = np.random.default_rng(9)
    g = rng.standard_normal((T, 2))
    _, y = kfx.simulate(model, steps=T, seed=4, input=g)
    y[3, 1] = np.nan
    y[7, :] = np.nan
    run = kfx.run_filter(model, y, store_covariances="full", input=g)
    est = kfx.Estimate(driven["m0"], driven["P0"])
    ll = 0.0
    for k in range(1, T + 1):
        step = model.step(k)
        prior = kfx.predict(est, step, input=g[k - 1])
        np.testing.assert_allclose(prior.x, run.x_pred[k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(prior.P, run.P_pred[k], rtol=0, atol=1e-12)
        r = kfx.update(prior, step, y[k - 1], input=g[k - 1])
        est = r.estimate
        ll += r.log_likelihood
        np.testing.assert_allclose(est.x, run.x_filt[k], rtol=0, atol=1e-12)
        np.testing.assert_allclose(est.P, run.P_filt[k], rtol=0, atol=1e-12)
    assert ll == pytest.approx(run.log_likelihood, abs=1e-12)


def test_single_steps_name_g(driven):
    model = kfx.Model(**driven)
    step = model.step(1)
    est = kfx.Estimate(driven["m0"], driven["P0"])
    with pytest.raises(kfx.Error, match="^g: .*none"):
        kfx.predict(est, step)
    with pytest.raises(kfx.Error, match="^g: "):
        kfx.update(est, step, np.zeros(2))
    with pytest.raises(kfx.Error, match="^g: .*length 3"):
        kfx.predict(est, step, input=np.ones(3))
    plain = kfx.Model(**{k: v for k, v in driven.items() if k not in "GDS"}).step(1)
    with pytest.raises(kfx.Error, match="^g: expected no known input"):
        kfx.update(est, plain, np.zeros(2), input=np.ones(2))


def test_mismatch_with_s_and_an_ignored_input_scalar_closed_form():
    """kfx.mismatch: truth x = a x + h g + w, y = x + v, E[w v] = s; the design ignores S and the input."""
    a, q, r, s, h, g, k = 0.6, 2.0, 1.5, -0.9, 0.7, 3.0, 0.45
    truth = kfx.ModelStep(A=[[a]], C=[[1.0]], Q=[[q]], R=[[r]], G=[[h]], D=[[0.0]], S=[[s]])
    design = kfx.ModelStep(A=[[a]], C=[[1.0]], Q=[[q]], R=[[r]])
    st = kfx.mismatch.stationary_mismatched_covariance(design, truth, filter_gain=[[k]], input=[g])
    F = (1 - k) * a
    cov = ((1 - k) ** 2 * q + k * k * r - 2 * (1 - k) * k * s) / (1 - F * F)
    mean = -(1 - k) * h * g / (1 - F)
    assert st.error_mean[0] == pytest.approx(mean, abs=1e-13)
    assert st.trace == pytest.approx(cov + mean * mean, abs=1e-12)
    # On the design's steady-state gain (the default), the sequence from the design's steady state converges
    # to the stationary solution (the same input at every step).
    st = kfx.mismatch.stationary_mismatched_covariance(design, truth, input=[g])
    dare = kfx.solve_filter_dare([[a]], [[1.0]], [[q]], [[r]])
    dm = kfx.Model(A=[[a]], C=[[1.0]], Q=[[q]], R=[[r]], m0=[0.0], P0=dare.P_filt)
    tm = kfx.Model(A=[[a]], C=[[1.0]], Q=[[q]], R=[[r]], G=[[h]], D=[[0.0]], S=[[s]], m0=[0.0], P0=[[1.0]])
    seq = kfx.mismatch.mismatched_covariance_sequence(dm, tm, 200, input=np.full((200, 1), g))
    assert seq["error_mean"][-1, 0] == pytest.approx(st.error_mean[0], abs=1e-9)
    assert seq["trace"][-1] == pytest.approx(st.trace, rel=1e-9)
    with pytest.raises(kfx.Error, match="^g: "):
        kfx.mismatch.mismatched_covariance_sequence(dm, tm, 5)
    with pytest.raises(kfx.Error, match="^options.input: "):
        kfx.mismatch.stationary_mismatched_covariance(design, truth, filter_gain=[[k]])


def test_patel_toda_bounds_refuse_what_does_not_hold():
    design = kfx.ModelStep(A=[[0.5]], C=[[1.0]], Q=[[1.0]], R=[[1.0]])
    b = kfx.mismatch.patel_toda_bounds(design, kfx.mismatch.ErrorRanges(S=[[0.9]]))
    assert b["pi3"] is not None and b["pi4"] is None and b["pi6"] is None
    assert [w[:4] for w in b["refused"]] == ["pi4:", "pi5:", "pi6:"]
    b = kfx.mismatch.patel_toda_bounds(design, kfx.mismatch.ErrorRanges(Q=[[0.1]], unmodelled_input=True))
    assert b["pi3"] is None and b["pi4"] is not None
    assert b["refused"][0].startswith("pi3: the truth has a known input")
