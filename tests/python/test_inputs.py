"""Hostile Python input (docs/robustness.md, classes 10 and 13): one conversion for every array
argument, so complex and object arrays raise kfx.Error instead of a silent cast, masked entries are
missing values, every shape error is a kfx.Error; estimates are validated like a Model's prior."""
import numpy as np
import pytest

import kfx


def expect_error(fn, *words, exc=kfx.Error):
    with pytest.raises(exc) as e:
        fn()
    for w in words:
        assert w in str(e.value), (w, str(e.value))
    return e.value


def test_complex_object_and_string_arrays_raise_kfx_error_everywhere(cv, random_model):
    # The DARE would have "converged" on the real part and the Lyapunov solver dropped the imaginary part.
    eye = np.eye(2)
    for bad in (eye + 1j * eye, np.array([[1.0, 0.0], [0.0, 1.0]], dtype=object), np.array([["1", "0"], ["0", "1"]])):
        expect_error(lambda: kfx.solve_filter_dare(bad, eye, eye, eye), "expected an array of real numbers")
        expect_error(lambda: kfx.solve_discrete_lyapunov(0.5 * eye, bad), "expected an array of real numbers")
        expect_error(lambda: kfx.Model(A=bad, C=cv["C"], Q=cv["Q"], R=cv["R"], m0=cv["m0"], P0=cv["P0"]),
                     "expected an array of real numbers")
    model = kfx.Model(**random_model)
    y = np.zeros((5, 2), dtype=complex)
    expect_error(lambda: kfx.run_filter(model, y), "complex")
    expect_error(lambda: kfx.Estimate(np.zeros(2, dtype=complex), np.eye(2)), "complex")
    # A ragged list is not an array of numbers either; numbers in lists, ints and bools are fine.
    expect_error(lambda: kfx.solve_discrete_lyapunov([[0.5, 0.0], [0.0]], eye), "expected an array of real numbers")
    s = kfx.solve_discrete_lyapunov([[0, 0], [0, 0]], [[1, 0], [0, True]])
    np.testing.assert_array_equal(s.X, np.eye(2))


def test_masked_entries_are_missing_values(random_model):
    model = kfx.Model(**random_model)
    _, y = kfx.simulate(model, steps=30, seed=3)
    mask = np.zeros(y.shape, dtype=bool)
    mask[4, 1] = mask[9, :] = True
    hidden = y.copy()
    hidden[mask] = 1e6  # the data behind the mask must never be used
    masked = np.ma.masked_array(hidden, mask=mask)
    with_nan = y.copy()
    with_nan[mask] = np.nan
    a, b = kfx.run_filter(model, masked), kfx.run_filter(model, with_nan)
    np.testing.assert_array_equal(a.x_filt, b.x_filt)
    assert a.log_likelihood == b.log_likelihood
    assert a.num_observed[9] == 0 and a.num_observed[4] == 1
    # A masked matrix where no value may be missing is rejected (NaN) naming the argument.
    A = np.ma.masked_array(random_model["A"], mask=np.eye(4, dtype=bool))
    expect_error(lambda: kfx.Model(**dict(random_model, A=A)), "A")


def test_every_shape_error_is_a_kfx_error():
    kf = kfx.KalmanFilter(2, 3)
    kf.H = np.ones((3, 2))
    kf.predict()
    kf.update(np.zeros((1, 3)))  # a row is a measurement too (FilterPy's reshape_z)
    expect_error(lambda: kf.update(np.zeros((2, 3))), "z", "(2, 3)")
    expect_error(lambda: kf.update(np.zeros(2)), "z", "length 3")
    expect_error(lambda: kf.update("abc"), "z")
    kf.update(np.zeros((3, 1)))  # a column is a vector
    step = kfx.ModelStep(A=np.eye(2), C=np.ones((1, 2)), Q=np.eye(2), R=np.eye(1))
    est = kfx.Estimate(np.zeros(2), np.eye(2))
    expect_error(lambda: kfx.update(est, step, np.zeros((1, 2))), "(1, 2)")
    expect_error(lambda: kfx.update(est, step, np.zeros(2)), "y", "length 1")
    expect_error(lambda: kfx.Estimate(np.zeros((2, 2)), np.eye(2)), "(2, 2)")
    expect_error(lambda: kfx.solve_discrete_lyapunov(np.zeros((2, 2, 2)), np.eye(2)), "(2, 2, 2)")
    expect_error(lambda: kfx.solve_discrete_lyapunov(np.float64(1.0), np.eye(2)), "()")


def test_estimates_are_validated_like_a_model_prior():
    # kfx.update(kfx.Estimate(x, [[1, 2], [2, 1]]), ...) used to return a covariance with a negative eigenvalue.
    x = np.zeros(2)
    expect_error(lambda: kfx.Estimate(x, np.array([[1.0, 2.0], [2.0, 1.0]])), "P", "semidefinite")
    expect_error(lambda: kfx.Estimate(x, np.array([[1.0, 0.5], [0.0, 1.0]])), "P", "symmetric")
    expect_error(lambda: kfx.Estimate(x, np.eye(3)), "P")
    expect_error(lambda: kfx.Estimate(np.array([np.nan, 0.0]), np.eye(2)), "x")
    e = kfx.Estimate(x, np.array([[1.0, 1.0], [1.0, 1.0 - 1e-14]]))  # PSD within the rounding tolerance
    assert e.P.shape == (2, 2)


def test_run_filter_checks_health_by_default_and_warns_naming_the_form():
    # Case (C) of docs/robustness.md: Q = 0, R = 1e-12, P0 = 1e6 I; the conventional form's P_{k|k}
    # loses definiteness (class 8). Warned by default, naming the form to use; the UD form is healthy.
    A = np.array([[1.0, 1.0], [0.0, 1.0]])
    model = kfx.Model(A=A, C=np.array([[1.0, 0.0]]), Q=np.zeros((2, 2)), R=np.array([[1e-12]]), m0=np.zeros(2),
                      P0=1e6 * np.eye(2))
    _, y = kfx.simulate(model, steps=3000, seed=17)
    with pytest.warns(RuntimeWarning, match="--form ud"):
        run = kfx.run_filter(model, y, store_covariances=False)
    assert run.health.monitored and not run.health.healthy and run.health.cholesky_failures > 0
    assert "not positive definite" in run.health_warning
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ud = kfx.run_filter(model, y, store_covariances=False, form="ud")
        quiet = kfx.run_filter(model, y, store_covariances=False, monitor_health=False)
    assert ud.health.healthy and ud.health_warning == ""
    assert not quiet.health.monitored and quiet.health_warning == ""
