"""Large models from Python (docs/python.md, "Large models and long calls"): run_filter keeps only the
covariance diagonals unless asked, result arrays are built once; long calls release the GIL, stop on
Ctrl-C with KeyboardInterrupt and report progress; array-like inputs of every kind are converted."""
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import kfx
from conftest import numpy_kalman
from test_inputs import expect_error


def chain_model(n, m, seed=0):
    """A stable random model of n states and m measurements (each step O(n^3))."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 0.95 / max(abs(np.linalg.eigvals(A)))
    G = rng.standard_normal((n, n)) / np.sqrt(n)
    return kfx.Model(A=A, C=rng.standard_normal((m, n)), Q=G @ G.T + 0.1 * np.eye(n), R=np.eye(m),
                     m0=np.zeros(n), P0=np.eye(n))


# ---- storage ---------------------------------------------------------------------------------------


def test_run_filter_stores_diagonals_by_default_and_every_covariance_on_request(random_model):
    d = random_model
    model = kfx.Model(**d)
    _, y = kfx.simulate(model, steps=30, seed=2)
    _, Ps, _ = numpy_kalman(d["A"], d["C"], d["Q"], d["R"], d["m0"], d["P0"], y)
    diag = kfx.run_filter(model, y)
    assert not diag.covariances_stored
    np.testing.assert_allclose(diag.P_filt_diag[1:], np.diagonal(Ps, axis1=1, axis2=2), rtol=1e-10, atol=1e-12)
    expect_error(lambda: diag.P_filt, "store_covariances='full'")
    expect_error(lambda: diag.P_pred, "store_covariances='full'")
    expect_error(lambda: kfx.rts_smooth(model, diag), "run", "store_covariances='full'")
    full = kfx.run_filter(model, y, store_covariances="full")
    assert full.covariances_stored and full.P_filt.shape == (31, 4, 4) and full.P_pred.shape == (31, 4, 4)
    np.testing.assert_allclose(full.P_filt[1:], Ps, rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(full.P_pred[0], d["P0"])
    np.testing.assert_array_equal(full.x_filt, diag.x_filt)
    # The earlier boolean spelling still works; anything else is a kfx.Error naming the argument.
    assert kfx.run_filter(model, y, store_covariances=True).covariances_stored
    assert not kfx.run_filter(model, y, store_covariances=False).covariances_stored
    expect_error(lambda: kfx.run_filter(model, y, store_covariances="all"), "store_covariances", "'all'")
    expect_error(lambda: kfx.run_filter(model, y, store_covariances=2), "store_covariances")


def test_result_arrays_are_built_once_and_read_only(random_model):
    model = kfx.Model(**random_model)
    _, y = kfx.simulate(model, steps=20, seed=2)
    run = kfx.run_filter(model, y, store_covariances="full")
    for name in ("P_filt", "P_pred", "x_filt", "P_filt_diag"):
        a = getattr(run, name)
        assert not a.flags.writeable, name
        with pytest.raises(ValueError):
            a[0, 0] = 1.0
    # Same object on every access: no re-stacking (a loop over run.P_filt[k] is linear, not quadratic).
    assert run.P_filt is run.P_filt and run.P_pred is run.P_pred
    sm = kfx.rts_smooth(model, run)
    assert sm.P is sm.P and sm.P.shape == (21, 4, 4)
    np.testing.assert_allclose(np.diagonal(sm.P, axis1=1, axis2=2), sm.P_diag, rtol=1e-14)
    sched = kfx.kalman_schedule(model, 20)
    assert sched.P_filt is sched.P_filt and sched.filter_gain.shape == (20, 4, 2)
    np.testing.assert_allclose(sched.P_filt, run.P_filt, rtol=1e-10, atol=1e-12)  # no missing values in y


_MEMORY_SCRIPT = textwrap.dedent("""
    import resource, sys
    import numpy as np
    import kfx
    n, T = 150, 1000
    rng = np.random.default_rng(1)
    A = 0.9 * np.eye(n) + 0.05 * rng.standard_normal((n, n)) / np.sqrt(n)
    model = kfx.Model(A=A, C=np.eye(1, n), Q=np.eye(n), R=np.eye(1), m0=np.zeros(n), P0=np.eye(n))
    y = rng.standard_normal((T, 1))
    kfx.run_filter(model, y[:5], store_covariances=sys.argv[1])  # libraries loaded, workspaces touched
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    run = kfx.run_filter(model, y, store_covariances=sys.argv[1])
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print((after - before) / 1024.0)  # MiB
""")


def _peak_growth_mib(store):
    out = subprocess.run([sys.executable, "-c", _MEMORY_SCRIPT, store], check=True, capture_output=True, text=True,
                         env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    return float(out.stdout)


def test_default_run_filter_does_not_keep_a_covariance_per_step():
    # n = 150, T = 1000: every P_{k|k} and P_{k|k-1} would be 2 * 1001 * 150^2 * 8 bytes = 344 MiB.
    stored = 2 * 1001 * 150 * 150 * 8 / 2**20
    diag = _peak_growth_mib("diag")
    full = _peak_growth_mib("full")
    assert diag < 0.1 * stored, (diag, stored)
    assert full > 0.9 * stored, (full, stored)  # the measurement sees the storage when there is some


# ---- the GIL, Ctrl-C and progress ------------------------------------------------------------------


def _long_filter_inputs(steps):
    model = chain_model(60, 6)
    _, y = kfx.simulate(model, steps=steps, seed=1)
    return model, y


def test_a_python_thread_keeps_running_during_run_filter():
    model, y = _long_filter_inputs(5000)
    count, stop = [0], threading.Event()

    def spin():
        while not stop.is_set():
            count[0] += 1

    t = threading.Thread(target=spin)
    t.start()
    time.sleep(0.05)
    c0, t0 = count[0], time.perf_counter()
    kfx.run_filter(model, y, monitor_health=False)
    c1, seconds = count[0], time.perf_counter() - t0
    stop.set()
    t.join()
    # Holding the GIL, the thread would not have counted at all during the call.
    assert seconds > 0.3, seconds
    assert c1 - c0 > 10000, (c1 - c0, seconds)


def _interrupt_after(delay):
    sent = []

    def fire():
        sent.append(time.perf_counter())
        os.kill(os.getpid(), signal.SIGINT)

    timer = threading.Timer(delay, fire)
    timer.start()
    return timer, sent


@pytest.mark.parametrize("call", ["run_filter", "simulate", "exact_performance", "monte_carlo_performance"])
def test_ctrl_c_stops_a_long_call_with_keyboard_interrupt(call):
    # Each call would take well over 5 s (run_filter: 50000 steps at n = 60, simulate: 20000 steps at
    # n = 1000, the engine 10^6 steps at n = 60, Monte Carlo 10^6 runs).
    model, y = _long_filter_inputs(50000)
    dare = kfx.solve_filter_dare(model.step(1).A, model.step(1).C, model.step(1).Q, model.step(1).R)
    f = kfx.constant_gain_as_linear_filter(model.step(1), dare.filter_gain, model.m0)
    n = 1000
    big = kfx.Model(A=0.5 * np.eye(n), C=np.eye(1, n), Q=np.eye(n), R=np.eye(1), m0=np.zeros(n), P0=np.eye(n))
    calls = {
        "run_filter": lambda: kfx.run_filter(model, y),
        "simulate": lambda: kfx.simulate(big, steps=20000),
        "exact_performance": lambda: kfx.exact_performance(model, f, steps=10**6, store_error_moments=False),
        "monte_carlo_performance": lambda: kfx.monte_carlo_performance(model, f, runs=10**6, steps=100),
    }
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        pytest.skip("SIGINT is not Python's default handler here")
    timer, sent = _interrupt_after(0.3)
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        calls[call]()
    latency = time.perf_counter() - sent[0]
    timer.join()
    assert time.perf_counter() - t0 < 5.0  # each of these calls takes far longer uninterrupted
    assert latency < 0.5, latency  # about 0.05 s plus one step
    # The module is usable afterwards.
    assert kfx.run_filter(model, y[:10]).x_filt.shape == (11, 60)


def test_progress_is_monotone_throttled_and_ends_at_the_total():
    model, y = _long_filter_inputs(5000)
    seen = []
    t0 = time.perf_counter()
    kfx.run_filter(model, y, progress=lambda done, total: seen.append((done, total, time.perf_counter())))
    seconds = time.perf_counter() - t0
    assert seen and seen[-1][:2] == (5000, 5000)
    assert all(t == 5000 for _, t, _ in seen)
    assert all(a[0] < b[0] for a, b in zip(seen, seen[1:]))
    assert len(seen) <= seconds / 0.05 + 2  # at most every 0.05 s (and at the end)
    gaps = [b[2] - a[2] for a, b in zip(seen[:-2], seen[1:-1])]
    assert all(g >= 0.045 for g in gaps), min(gaps)
    # The same hook on the other long calls; a tqdm-like bar advanced by differences ends full.
    class Bar:
        n = 0

        def update(self, k):
            self.n += k

    bar = Bar()
    kfx.simulate(model, steps=5000, progress=lambda d, t: bar.update(d - bar.n))
    assert bar.n == 5000
    dare = []
    kfx.solve_filter_dare(np.diag([1.2, 0.5]), np.eye(1, 2), np.eye(2), np.eye(1), method="doubling",
                          progress=lambda d, t: dare.append((d, t)))
    # Converged in well under 0.05 s and before max_iterations: no call (the C++ test sees every step).
    assert all(t == 60 and 1 <= d < 60 for d, t in dare)
    expect_error(lambda: kfx.run_filter(model, y[:5], progress=3), "progress", "callable")


def test_smoother_progress_increases_to_the_total():
    model, y = _long_filter_inputs(400)
    run = kfx.run_filter(model, y, store_covariances="full")
    seen = []
    kfx.rts_smooth(model, run, progress=lambda done, total: seen.append((done, total)))
    assert seen and seen[-1] == (400, 400)
    assert all(t == 400 for _, t in seen)
    assert all(a[0] < b[0] for a, b in zip(seen, seen[1:]))
    expect_error(lambda: kfx.rts_smooth(model, run, progress=3), "progress", "callable")


def test_an_exception_raised_by_progress_stops_the_call_and_propagates():
    model, y = _long_filter_inputs(50000)

    class Stop(Exception):
        pass

    def progress(done, total):
        raise Stop(done)

    t0 = time.perf_counter()
    with pytest.raises(Stop):
        kfx.run_filter(model, y, progress=progress)
    assert time.perf_counter() - t0 < 2.0


# ---- inputs ----------------------------------------------------------------------------------------


def test_lists_float32_integer_and_fortran_inputs_are_converted(random_model):
    d = random_model
    _, y = kfx.simulate(kfx.Model(**d), steps=15, seed=9)
    # (how the input is given, the float64 values it stands for): the results must be identical.
    variants = {
        "lists": (lambda a: a.tolist(), lambda a: a),
        "fortran": (np.asfortranarray, lambda a: a),
        "float32": (lambda a: a.astype(np.float32), lambda a: a.astype(np.float32).astype(np.float64)),
    }
    for name, (given, values) in variants.items():
        run = kfx.run_filter(kfx.Model(**{k: given(v) for k, v in d.items()}), given(y))
        ref = kfx.run_filter(kfx.Model(**{k: values(v) for k, v in d.items()}), values(y))
        np.testing.assert_array_equal(run.x_filt, ref.x_filt, err_msg=name)
        got = kfx.solve_filter_dare(*(given(d[k]) for k in "ACQR"))
        want = kfx.solve_filter_dare(*(values(d[k]) for k in "ACQR"))
        np.testing.assert_array_equal(got.P_pred, want.P_pred, err_msg=name)
    # Integers: the DARE of the scalar random walk x = x + w, y = x + v has P = (1 + sqrt 5) / 2.
    for A in ([[1]], np.array([[1]], dtype=np.int32), np.array([[1]], dtype=np.uint8)):
        assert kfx.solve_filter_dare(A, [[1]], [[1]], [[1]]).P_pred[0, 0] == pytest.approx((1 + 5**0.5) / 2,
                                                                                         rel=1e-14)
    # Complex and object arrays, and masked arrays, as in test_inputs.py, also through the long calls.
    model = kfx.Model(**d)
    expect_error(lambda: kfx.simulate(kfx.Model(**dict(d, P0=d["P0"].astype(complex)))), "complex")
    expect_error(lambda: kfx.run_filter(model, y.astype(object)), "expected an array of real numbers")
    masked = np.ma.masked_array(y, mask=np.zeros(y.shape, bool))
    masked[3] = np.ma.masked
    with_nan = y.copy()
    with_nan[3] = np.nan
    np.testing.assert_array_equal(kfx.run_filter(model, masked).x_filt, kfx.run_filter(model, with_nan).x_filt)
