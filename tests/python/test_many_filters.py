"""kfx.filter_many (n independent small filters) against the plain numpy filter of conftest run on each
filter alone, and its bad-input errors."""
import numpy as np
import pytest

import kfx
from conftest import numpy_kalman


def random_model(rng, n, c, d, per_filter):
    def spd(k, shift):
        g = rng.standard_normal((k, k))
        return g @ g.T / k + shift * np.eye(k)

    def one():
        A = rng.standard_normal((c, c))
        A *= 0.95 / max(abs(np.linalg.eigvals(A)))
        return A, rng.standard_normal((d, c)), spd(c, 0.05), spd(d, 0.2), rng.standard_normal(c), spd(c, 0.5)

    if not per_filter:
        return one()
    blocks = [one() for _ in range(n)]
    return tuple(np.array([b[j] for b in blocks]) for j in range(6))


@pytest.mark.parametrize("c,d,per", [(2, 1, True), (2, 1, False), (1, 1, True), (3, 2, True), (4, 2, False),
                                     (5, 3, True)])
def test_matches_the_plain_filter_of_each_filter(c, d, per):
    rng = np.random.default_rng(100 * c + 10 * d + per)
    n, T = 67, 40
    F, H, Q, R, x0, P0 = random_model(rng, n, c, d, per)
    zs = rng.standard_normal((T, n, d))
    xs, P = kfx.filter_many(F, H, Q, R, x0, P0, zs if d > 1 else zs[:, :, 0])
    assert xs.shape == (T, n, c) and P.shape == (n, c, c)
    for i in range(n):
        pick = (lambda M: M[i]) if per else (lambda M: M)
        xr, Pr, _ = numpy_kalman(pick(F), pick(H), pick(Q), pick(R), pick(x0), pick(P0), zs[:, i, :])
        assert np.abs(xs[:, i, :] - xr).max() <= 1e-12 * max(1.0, np.abs(xr).max())
        assert np.abs(P[i] - Pr[-1]).max() <= 1e-12 * np.abs(Pr[-1]).max()


def test_a_missing_value_skips_the_update():
    rng = np.random.default_rng(3)
    F, H, Q, R, x0, P0 = random_model(rng, 5, 2, 1, False)
    zs = rng.standard_normal((30, 5))
    zs[10, 2] = np.nan
    xs, _ = kfx.filter_many(F, H, Q, R, x0, P0, zs)
    # Filter 2 alone, with the missing step as a pure prediction.
    x, P = x0.copy(), P0.copy()
    for k in range(30):
        x, P = F @ x, F @ P @ F.T + Q
        if k != 10:
            S = H @ P @ H.T + R
            K = np.linalg.solve(S, H @ P).T
            x, P = x + K @ (zs[k, 2:3] - H @ x), P - K @ S @ K.T
        assert np.abs(xs[k, 2] - x).max() <= 1e-12 * max(1.0, np.abs(x).max())


def test_bad_input_names_the_argument():
    rng = np.random.default_rng(4)
    F, H, Q, R, x0, P0 = random_model(rng, 4, 2, 1, False)
    zs = rng.standard_normal((6, 4))
    with pytest.raises(kfx.Error, match="F"):
        kfx.filter_many(np.ones((3, 2, 2)), H, Q, R, x0, P0, zs)  # 3 blocks for 4 filters
    with pytest.raises(kfx.Error, match="R"):
        kfx.filter_many(F, H, Q, -R, x0, P0, zs)
    with pytest.raises(kfx.Error, match="zs"):
        kfx.filter_many(F, H, Q, R, x0, P0, zs[0])
    with pytest.raises(kfx.Error, match="zs"):
        kfx.filter_many(F, H, Q, R, x0, P0, zs[:, :, None].repeat(2, axis=2))  # d = 2, H has 1 row
    with pytest.raises(kfx.Error, match="x0"):
        kfx.filter_many(F, H, Q, R, np.zeros((3, 2)), P0, zs)
    bad = zs.copy()
    bad[0, 0] = np.inf
    with pytest.raises(kfx.Error, match="y"):
        kfx.filter_many(F, H, Q, R, x0, P0, bad)


def test_out_is_written_in_place_and_equals_a_fresh_run():
    rng = np.random.default_rng(5)
    n, T = 130, 25  # two whole chunks of 64 and a partial one
    F, H, Q, R, x0, P0 = random_model(rng, n, 2, 1, True)
    zs = rng.standard_normal((T, n))
    zs[rng.uniform(size=(T, n)) < 0.1] = np.nan
    fresh, P_fresh = kfx.filter_many(F, H, Q, R, x0, P0, zs)
    out = np.full((T, n, 2), np.nan)
    xs, P = kfx.filter_many(F, H, Q, R, x0, P0, zs, out=out)
    assert xs is out
    assert np.array_equal(out, fresh) and np.array_equal(P, P_fresh)
    # Again into the same array, on other data: every element rewritten.
    zs2 = rng.standard_normal((T, n))
    xs2, _ = kfx.filter_many(F, H, Q, R, x0, P0, zs2, out=out)
    assert xs2 is out and np.array_equal(out, kfx.filter_many(F, H, Q, R, x0, P0, zs2)[0])


def test_a_bad_out_is_refused_naming_out():
    rng = np.random.default_rng(6)
    F, H, Q, R, x0, P0 = random_model(rng, 4, 2, 1, False)
    zs = rng.standard_normal((6, 4))
    read_only = np.zeros((6, 4, 2))
    read_only.flags.writeable = False
    overlap = np.zeros((6, 4, 2))
    bad = {
        "shape (6, 4, 3)": np.zeros((6, 4, 3)),
        "dtype float32": np.zeros((6, 4, 2), np.float32),
        "non-contiguous": np.zeros((6, 4, 4))[:, :, ::2],
        "read-only": read_only,
        "list": [[[0.0] * 2] * 4] * 6,
        "overlaps": overlap,
    }
    for what, out in bad.items():
        z = overlap.reshape(-1)[:24].reshape(6, 4) if what == "overlaps" else zs  # zs a view of out's memory
        with pytest.raises(kfx.Error, match="out") as e:
            kfx.filter_many(F, H, Q, R, x0, P0, z, out=out)
        assert what.split()[0] in str(e.value), (what, str(e.value))
    with pytest.raises(TypeError):
        kfx.filter_many(F, H, Q, R, x0, P0, zs, np.zeros((6, 4, 2)))  # out is keyword-only
