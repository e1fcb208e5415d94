"""Each paper method from Python against the same closed forms / second algorithms as the C++ tests
(tests/*_test.cpp), so that the binding adds nothing and loses nothing."""
import math

import numpy as np
import pytest

import kfx


def rng_model(seed, n=4, m=2, rho=0.9):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= rho / max(abs(np.linalg.eigvals(A)))
    G = rng.standard_normal((n, n))
    H = rng.standard_normal((m, m))
    return dict(A=A, C=rng.standard_normal((m, n)), Q=G @ G.T / n + 0.1 * np.eye(n), R=H @ H.T + 0.5 * np.eye(m),
                m0=rng.standard_normal(n), P0=np.eye(n))


# ---- 004 block-diagonal ------------------------------------------------------------------------------


def coupled(seed, n=3, c=2, d=1, r=1):
    rng = np.random.default_rng(seed)
    F = np.hstack([0.8 * np.linalg.qr(rng.standard_normal((c, c)))[0] for _ in range(n)])
    H = rng.standard_normal((d, n * c))
    V = np.hstack([0.1 * np.eye(c) for _ in range(n)])
    R = np.hstack([0.5 * np.eye(d) for _ in range(n)])
    G = rng.standard_normal((n * c, r))
    step = kfx.blockdiag.CoupledStep(F=F, H=H, V=V, R=R, G=G, U=np.eye(r))
    return kfx.blockdiag.CoupledSystem(step, np.zeros(n * c), np.hstack([np.eye(c)] * n)), step


def test_coupled_filters_fast_equals_naive_and_full_equals_the_dense_kalman_filter():
    sys, step = coupled(1)
    x, y, u = kfx.blockdiag.simulate_coupled(sys, 30, seed=4)
    assert x.shape == (31, 6) and y.shape == (30, 3) and u.shape == (30, 1)
    fast = kfx.blockdiag.run_coupled_filter(sys, "block-diagonal", y)
    naive = kfx.blockdiag.run_coupled_filter(sys, "block-diagonal-naive", y)
    np.testing.assert_allclose(fast.x_filt, naive.x_filt, rtol=1e-9, atol=1e-11)
    assert fast.coupling.shape == (30, 1)
    full = kfx.blockdiag.run_coupled_filter(sys, "full", y)
    dense = sys.to_dense_model()
    np.testing.assert_allclose(full.x_filt, kfx.run_filter(dense, y).x_filt, rtol=1e-9, atol=1e-11)
    # exact true error of each filter from the one engine: the Kalman filter is optimal
    mse = {k: kfx.exact_performance(dense, kfx.blockdiag.coupled_filter_as_linear_filter(sys, k, 30)).mse
           for k in ("full", "block-diagonal", "banded")}
    kalman = kfx.exact_performance(dense, kfx.kalman_as_linear_filter(dense, 30)).mse
    np.testing.assert_allclose(mse["full"], kalman, rtol=1e-9)
    assert np.all(mse["block-diagonal"] >= kalman * (1 - 1e-12))
    assert np.all(mse["banded"] >= kalman * (1 - 1e-12))
    with pytest.raises(kfx.Error, match="kind"):
        kfx.blockdiag.run_coupled_filter(sys, "diagonal", y)
    with pytest.raises(kfx.Error, match="V"):
        kfx.blockdiag.CoupledStep(F=step.F, H=step.H, V=-step.V, R=step.R, G=step.G, U=step.U)


def test_steady_state_block_diagonal_filter_equals_the_running_one_after_convergence():
    sys, step = coupled(7, n=600, c=2, d=1, r=3)  # more than one chunk of 512 subsystems
    _, y, _ = kfx.blockdiag.simulate_coupled(sys, 150, seed=5)
    running = kfx.blockdiag.run_coupled_filter(sys, "block-diagonal", y)
    steady = kfx.blockdiag.run_coupled_filter(sys, "block-diagonal", y, steady_state_tolerance=1e-12)
    assert running.steady_state_steps == 0 and 0 < steady.steady_state_steps < 150
    after = steady.steady_state_steps
    scale = np.abs(running.x_filt[-after:]).max()
    assert np.abs(steady.x_filt[-after:] - running.x_filt[-after:]).max() <= 1e-10 * scale
    np.testing.assert_allclose(steady.coupling[-after:], running.coupling[-after:], rtol=0,
                               atol=1e-10 * np.abs(running.coupling).max())
    for a, b in ((steady.P_filt, running.P_filt), (steady.coupling_cov, running.coupling_cov)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-10 * np.abs(b).max())
    with pytest.raises(kfx.Error, match="steady_state_tolerance"):
        kfx.blockdiag.run_coupled_filter(sys, "block-diagonal", y, steady_state_tolerance=0.5)


def test_identical_subsystems_reduction_matches_the_dense_dare():
    F = np.array([[0.9, 0.1], [0.0, 0.7]])
    H = np.array([[1.0, 0.0]])
    V, R, g, U = 0.1 * np.eye(2), np.array([[0.3]]), np.array([[0.5], [1.0]]), np.array([[1.0]])
    n = 5
    a = kfx.blockdiag.analyze_identical_subsystems(kfx.blockdiag.IdenticalSubsystems(F=F, H=H, V=V, R=R, g=g, U=U), n)
    dense = kfx.blockdiag.make_identical_coupled_step(n, F, H, V, R, g, U).to_dense()
    dare = kfx.solve_filter_dare(dense.A, dense.C, dense.Q, dense.R)
    np.testing.assert_allclose(a.full_P.dense(), dare.P_filt, rtol=1e-9, atol=1e-12)
    bd = kfx.blockdiag.solve_block_diagonal_steady_state(kfx.blockdiag.make_identical_coupled_step(n, F, H, V, R, g, U))
    assert bd.summary.ok and bd.summary.termination == "converged"
    np.testing.assert_allclose(kfx.blockdiag.block_diagonal_to_dense(bd.P_filt, 2), a.block_P.dense(), rtol=1e-8, atol=1e-12)
    # the block-diagonal filter's own covariance is not its true error; the engine's is >= Kalman's
    assert np.trace(a.block_true.dense()) >= np.trace(dare.P_filt) * (1 - 1e-12)


# ---- 002 mismatch / Patel-Toda -----------------------------------------------------------------------


def test_stationary_mismatch_equals_the_engine_and_bounds_hold():
    d = rng_model(5)
    design = kfx.ModelStep(A=d["A"], C=d["C"], Q=d["Q"], R=d["R"])
    errors = kfx.mismatch.ModelingErrors(A=0.05 * np.eye(4), R=0.1 * np.eye(2))
    truth = kfx.mismatch.apply_modeling_errors(design, errors)
    np.testing.assert_allclose(truth.A, d["A"] - 0.05 * np.eye(4))
    sm = kfx.mismatch.stationary_mismatched_covariance(design, truth)
    assert sm.summary.ok and sm.summary.relative_residual < 1e-9
    truth_model = kfx.Model(truth, np.zeros(4), np.eye(4))
    f = kfx.constant_gain_as_linear_filter(design, sm.filter_gain, np.zeros(4))
    st = kfx.exact_stationary_performance(truth_model, f)
    np.testing.assert_allclose(sm.P, st.error_cov, rtol=1e-8, atol=1e-12)
    t1 = kfx.mismatch.theorem1_bound(design, errors)
    assert t1["identity_trace"] == pytest.approx(sm.trace, rel=1e-8)
    assert t1["pi1"] >= sm.trace * (1 - 1e-12)
    # the optimal filter of the truth is bounded below by Theorem 2
    opt = kfx.solve_filter_dare(truth.A, truth.C, truth.Q, truth.R)
    assert kfx.mismatch.theorem2_bound(truth) <= np.trace(opt.P_pred) * (1 + 1e-12)
    # Theorem 3 over a noise box is >= the largest true error found in the box
    ranges = kfx.mismatch.ErrorRanges(Q=0.05 * np.eye(4), R=0.05 * np.eye(2))
    b = kfx.mismatch.patel_toda_bounds(design, ranges)
    box = kfx.mismatch.search_error_box(design, ranges, refine=False)
    assert b["pi3"] is not None and b["pi5"] is None
    assert b["pi3"] >= box["least_upper"] * (1 - 1e-12)
    seq = kfx.mismatch.mismatched_covariance_sequence(kfx.Model(design, np.zeros(4), np.eye(4)), truth_model, 20)
    perf = kfx.exact_performance(truth_model, kfx.kalman_as_linear_filter(kfx.Model(design, np.zeros(4),
                                                                                     np.eye(4)), 20))
    np.testing.assert_allclose(seq["trace"], perf.mse, rtol=1e-9)
    with pytest.raises(kfx.Error, match="errors.A"):
        kfx.mismatch.apply_modeling_errors(design, kfx.mismatch.ModelingErrors(A=np.eye(3)))


# ---- 003 continuous time / sampling ------------------------------------------------------------------


def test_sampled_filter_and_kalman_bucy_scalar_closed_forms():
    a, c, r, p0, T = -0.5, 1.0, 0.2, 2.0, 1.0
    m = kfx.continuous.ContinuousModel(A=[[a]], C=[[c]], R=[[r]], m0=[0.0], P0=[[p0]])

    def closed(t):
        info, prev = 1.0 / p0, 0.0
        for ti in t:
            g = (math.exp(a * ti) - math.exp(a * prev)) / a
            info += c * c * g * g / ((ti - prev) * r)
            prev = ti
        return math.exp(2 * a * t[-1]) / info

    for n in (1, 3, 16, 100):
        assert kfx.continuous.sampled_filter_covariance(m, T, n)[0, 0] == pytest.approx(closed([T * i / n for i in
                                                                                     range(1, n + 1)]), abs=1e-14)
    pc = math.exp(2 * a * T) / (1.0 / p0 + c * c * (math.exp(2 * a * T) - 1) / (2 * a * r))
    assert kfx.continuous.kalman_bucy_covariance(m, T)[0, 0] == pytest.approx(pc, abs=1e-14)
    st = kfx.continuous.study_convergence(m, T, n_values=[16, 32, 64, 128])
    assert st.tr_Pc == pytest.approx(pc, abs=1e-14)
    assert st.rate == pytest.approx(-2.0, abs=0.05)  # Theorem 1's n^-2
    assert all(p.err > 0 and p.bounds.theorem1 >= p.err for p in st.points)
    model = kfx.continuous.sampled_model(m, T, 8)
    assert model.state_dim == 2 and model.meas_dim == 1


def test_care_is_the_long_time_limit():
    m = kfx.continuous.ContinuousModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], Q=[[1.0]], R=[[1.0]], m0=[0.0], P0=[[1.0]])
    care = kfx.continuous.solve_filter_care(m)
    assert care.summary.ok and care.P[0, 0] == pytest.approx(math.sqrt(2) - 1, rel=1e-12)
    assert kfx.continuous.kalman_bucy_covariance(m, 40.0)[0, 0] == pytest.approx(care.P[0, 0], rel=1e-10)
    t, z, dy = kfx.continuous.simulate_continuous(m, 1.0, 50, seed=3)
    assert t.shape == (51,) and z.shape == (51, 1) and dy.shape == (50, 1)
    with pytest.raises(kfx.Error, match="R"):
        kfx.continuous.ContinuousModel(A=[[-1.0]], C=[[1.0]], R=[[-1.0]], m0=[0.0], P0=[[1.0]])


# ---- 001 reduced-order / subspace estimators ---------------------------------------------------------


def test_full_order_reduced_filter_is_the_kalman_predictor_and_reduced_cost_is_the_engine_cost():
    d = rng_model(21)
    model = kfx.Model(A=d["A"], C=d["C"], Q=d["Q"], R=d["R"], m0=d["m0"], P0=d["P0"])
    T = 12
    L = kfx.reduced.WeightSchedule(np.eye(4))
    s = kfx.reduced.reduced_order_one_step(model, L, steps=T)
    f = kfx.reduced.reduced_order_one_step_as_linear_filter(s, L)
    J = kfx.reduced.weighted_cost(model, f, L, T)
    pred, filt = kfx.reduced.kalman_costs(model, L, T)
    np.testing.assert_allclose(J[1:] / pred[1:], 1.0, atol=1e-9)
    y = np.random.default_rng(0).standard_normal((T, 2))
    np.testing.assert_allclose(f.run(y)[1:], kfx.run_filter(model, y).x_pred[1:], rtol=1e-8, atol=1e-9)
    # reduced order (n_e = 2 < n): the recursion's cost equals the engine's, and is >= Kalman's
    L2 = kfx.reduced.WeightSchedule(np.eye(4)[:2])
    s2 = kfx.reduced.reduced_order_one_step(model, L2, steps=T)
    J2 = kfx.reduced.weighted_cost(model, kfx.reduced.reduced_order_one_step_as_linear_filter(s2, L2), L2, T)
    np.testing.assert_allclose(J2[1:], s2.cost[1:], rtol=1e-8)
    assert np.all(J2[1:] >= kfx.reduced.kalman_costs(model, L2, T)[0][1:] * (1 - 1e-10))
    two = kfx.reduced.reduced_order_two_step(model, L, steps=T)
    Jda = kfx.reduced.weighted_cost(model, kfx.reduced.reduced_order_two_step_as_linear_filter(two, L, "data_assimilation"), L, T)
    np.testing.assert_allclose(Jda[1:] / filt[1:], 1.0, atol=1e-9)


def test_subspace_estimator_and_spring_mass_chain():
    ch = kfx.reduced.spring_mass_chain(4, mass=1.0, k=1.0, c=0.1, dt=0.1)
    Ad = ch["Ad"]
    np.testing.assert_allclose(Ad, kfx.matrix_exponential(ch["Ac"] * 0.1), rtol=1e-12, atol=1e-14)
    # fixed-fixed uniform chain, no damping: stiffness eigenvalues 2 - 2 cos(j pi / (N + 1))
    K = kfx.reduced.spring_mass_chain(4, c=0.0)["K"]
    np.testing.assert_allclose(np.linalg.eigvalsh(K), [2 - 2 * math.cos(j * math.pi / 5) for j in range(1, 5)],
                               atol=1e-12)
    basis = kfx.reduced.least_damped_subspace(Ad, 4)
    assert basis.T.shape == (8, 8) and basis.invariance_residual < 1e-10
    C = np.zeros((1, 8))
    C[0, 0] = 1.0
    model = kfx.Model(A=Ad, C=C, Q=0.01 * np.eye(8), R=[[0.1]], m0=np.zeros(8), P0=np.eye(8))
    L = kfx.reduced.WeightSchedule(np.eye(8))
    s = kfx.reduced.subspace_one_step(model, basis.T, 4, L, steps=10)
    f = kfx.reduced.subspace_one_step_as_linear_filter(s, basis.T, 4)
    J = kfx.reduced.weighted_cost(model, f, L, 10)
    pred, _ = kfx.reduced.kalman_costs(model, L, 10)
    assert np.all(J[1:] >= pred[1:] * (1 - 1e-10))
    with pytest.raises(kfx.Error):
        kfx.reduced.least_damped_subspace(Ad, 9)


# ---- 000 subspace filter / damped wave ---------------------------------------------------------------


def test_full_space_subspace_filter_is_the_kalman_filter_and_wave_reduced_filter_between():
    d = rng_model(11, n=6, m=2, rho=0.95)
    step = kfx.ModelStep(A=d["A"], C=d["C"], Q=d["Q"], R=d["R"])
    P0 = np.eye(6)
    sched = kfx.subspace.subspace_filter_schedule(step, P0, kfx.subspace.Subspace(np.eye(6)), steps=25)
    ks = kfx.kalman_schedule(kfx.Model(step, np.zeros(6), P0), 25)
    np.testing.assert_allclose(sched.gain, ks.filter_gain, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(sched.P_final, ks.P_filt[-1], rtol=1e-9, atol=1e-12)

    wave = kfx.subspace.damped_wave(fine_nodes=11, coarse_nodes=2)
    fine = wave.fine.step
    N = fine.state_dim
    S = kfx.solve_discrete_lyapunov(fine.A, fine.Q).X
    sub = wave.subspace
    assert sub.reduced_dim == 4 and sub.full_dim == N
    sch = kfx.subspace.subspace_filter_schedule(fine, S, sub, stationary_prior=True)
    assert sch.summary.ok
    truth = kfx.Model(fine, np.zeros(N), S)
    reduced = kfx.exact_stationary_performance(truth, kfx.subspace.converged_subspace_filter_as_linear_filter(fine, sub, sch, np.zeros(N)),
                                               weight=sub.gram)
    dare = kfx.solve_filter_dare(fine.A, fine.C, fine.Q, fine.R)
    full = kfx.exact_stationary_performance(truth, kfx.constant_gain_as_linear_filter(fine, dare.filter_gain, np.zeros(N)),
                                            weight=sub.gram)
    assert reduced.summary.ok and full.summary.ok
    assert full.weighted_mse <= reduced.weighted_mse * (1 + 1e-10)
    b = kfx.subspace.discretization_bounds(fine, S, sub, sch)
    assert b.actual >= -1e-12 and b.theorem41_exact_dP >= b.actual * (1 - 1e-9)
    with pytest.raises(kfx.Error, match="projection"):
        kfx.subspace.Subspace(np.ones((2, 6)))
