"""n independent 2-state Kalman filters from Python (kfx.filter_many) against a vectorised numpy
implementation of the same filter and against the memory-traffic bound, all measured in this run.

    PYTHONPATH=BUILD/python python3 bench/many_filters.py [--n 100000] [--steps 1000] [--reps 3]

Model: one 2-state filter per "pixel" (position/velocity, d = 1), a different F, H, Q, R, x0, P0 for
every filter (arrays (n, 2, 2) etc.), zs (T, n) with 1% missing values (NaN). The numpy filter is the
straightforward one (batched matmul over the n filters, one step at a time); it is timed over a
prefix of the steps and scaled (its equality with kfx is checked on that prefix). The bound: the bytes
a step must read and write (zs: 8 n; xs: 16 n) at the rate of a numpy sum a = b + c over arrays of
the same size (24 bytes per element), the best of several. Times are process CPU time (user + system,
page faults of the outputs included), best of the repetitions. kfx runs twice: into a fresh xs (the
kernel faults in and zeroes its pages) and into an array the caller keeps (out=).
"""
import argparse
import os
import platform
import resource

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402

import kfx  # noqa: E402


def model(rng, n):
    dt = rng.uniform(0.5, 1.5, n)
    F = np.zeros((n, 2, 2))
    F[:, 0, 0] = F[:, 1, 1] = 1.0
    F[:, 0, 1] = dt
    F[:, 1, 1] = rng.uniform(0.8, 0.99, n)
    H = np.zeros((n, 1, 2))
    H[:, 0, 0] = 1.0
    q = rng.uniform(0.01, 0.1, n)
    Q = np.empty((n, 2, 2))
    Q[:, 0, 0] = q * dt ** 3 / 3
    Q[:, 0, 1] = Q[:, 1, 0] = q * dt ** 2 / 2
    Q[:, 1, 1] = q * dt
    R = rng.uniform(0.5, 2.0, (n, 1, 1))
    x0 = rng.standard_normal((n, 2))
    P0 = np.tile(np.eye(2), (n, 1, 1)) * rng.uniform(1.0, 10.0, (n, 1, 1))
    return F, H, Q, R, x0, P0


def numpy_filter(F, H, Q, R, x0, P0, zs):
    """The vectorised numpy filter a user writes: one step at a time, batched over the filters."""
    T, n = zs.shape
    x, P = x0.copy(), P0.copy()
    Ft, Ht = F.transpose(0, 2, 1), H.transpose(0, 2, 1)
    xs = np.empty((T, n, 2))
    for k in range(T):
        x = np.einsum("nij,nj->ni", F, x)
        P = F @ P @ Ft + Q
        U = P @ Ht                                   # (n, 2, 1)
        S = (H @ U)[:, 0, 0] + R[:, 0, 0]            # (n,)
        z = zs[k]
        ok = ~np.isnan(z)
        K = U[:, :, 0] / S[:, None]                  # (n, 2)
        nu = np.where(ok, z - np.einsum("nj,nj->n", H[:, 0, :], x), 0.0)
        K = np.where(ok[:, None], K, 0.0)
        x = x + K * nu[:, None]
        P = P - K[:, :, None] * U[:, :, 0][:, None, :]
        xs[k] = x
    return xs, P


def best(fn, reps, split=None):
    """Best process CPU time of reps calls (the machine may be shared: wall time then says little); with
    a list `split`, the (user, system) times of that best call are appended to it."""
    t, out = [], None
    for _ in range(reps):
        r0 = resource.getrusage(resource.RUSAGE_SELF)
        out = fn()
        r1 = resource.getrusage(resource.RUSAGE_SELF)
        user, system = r1.ru_utime - r0.ru_utime, r1.ru_stime - r0.ru_stime
        t.append((user + system, user, system))
    b = min(t)
    if split is not None:
        split.extend(b[1:])
    return b[0], out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=100000)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--numpy-steps", type=int, default=100, help="numpy timed on this prefix, scaled")
    ap.add_argument("--reps", type=int, default=3)
    a = ap.parse_args()
    n, T = a.n, a.steps
    rng = np.random.default_rng(24)
    F, H, Q, R, x0, P0 = model(rng, n)
    zs = rng.standard_normal((T, n)) * 3.0
    zs[rng.uniform(size=(T, n)) < 0.01] = np.nan

    kfx_split, reuse_split = [], []
    t_kfx, (xs, P) = best(lambda: kfx.filter_many(F, H, Q, R, x0, P0, zs), a.reps, kfx_split)
    # The same run into an array the caller keeps (out=): no fresh pages for the kernel to fault in and zero.
    out = np.empty_like(xs)
    out.fill(0.0)
    t_reuse, (xs_reuse, _) = best(lambda: kfx.filter_many(F, H, Q, R, x0, P0, zs, out=out), a.reps, reuse_split)
    if not np.array_equal(xs_reuse, xs):
        raise SystemExit("FAIL: kfx.filter_many(out=) differs from the fresh run")
    del xs_reuse
    Tn = min(a.numpy_steps, T)
    t_np, (xs_np, _) = best(lambda: numpy_filter(F, H, Q, R, x0, P0, zs[:Tn]), max(1, a.reps - 1))
    t_np_all = t_np * T / Tn
    diff = np.abs(xs[:Tn] - xs_np).max() / np.abs(xs_np).max()

    # Memory-traffic bound: the step must read zs and write xs (24 bytes per filter and step).
    m = 4 * 1024 * 1024  # 32 MB arrays: out of every cache level
    b, c, out = np.ones(m), np.ones(m), np.empty(m)
    t_sum, _ = best(lambda: np.add(b, c, out=out), 10)
    bandwidth = 24.0 * m / t_sum
    bytes_run = 24.0 * n * T
    t_bound = bytes_run / bandwidth

    per = 1e9 / (n * T)
    print(f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f}; numpy {np.__version__}; process CPU times, best of {a.reps}.")
    print(f"| n = {n} filters (c = 2, d = 1), {T} steps | time | per filter and step | ratio |")
    print("|---|---|---|---|")
    print(f"| kfx.filter_many | {t_kfx:.3f} s | {t_kfx * per:.2f} ns (user {kfx_split[0] * per:.2f}, system "
          f"{kfx_split[1] * per:.2f}: page faults of the fresh xs) | 1 |")
    print(f"| kfx.filter_many(..., out=xs) (the caller's array reused) | {t_reuse:.3f} s | {t_reuse * per:.2f} ns "
          f"(user {reuse_split[0] * per:.2f}, system {reuse_split[1] * per:.2f}) | {t_reuse / t_kfx:.2f} |")
    print(f"| vectorised numpy ({Tn} steps timed, x {T / Tn:g}) | {t_np_all:.2f} s | {t_np_all * per:.1f} ns | "
          f"**{t_np_all / t_kfx:.1f}x** slower (target >= 10x) |")
    print(f"| memory-traffic bound (24 B per filter and step at {bandwidth / 1e9:.1f} GB/s, numpy a = b + c) | "
          f"{t_bound:.3f} s | {t_bound * per:.2f} ns | kfx at **{t_kfx / t_bound:.2f}x** the bound, "
          f"**{t_reuse / t_bound:.2f}x** with out= (target <= 2x) |")
    print(f"\nkfx vs numpy on the first {Tn} steps: max |dx| / max |x| = {diff:.1e}")
    if not diff <= 1e-12:
        raise SystemExit("FAIL: kfx.filter_many differs from the numpy filter")


if __name__ == "__main__":
    main()
