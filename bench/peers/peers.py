#!/usr/bin/python3
"""kfx against the tools users would otherwise pick (issue 9), measured in one run.

Generates seeded systems (written as .npy for the C++ driver kfx_peers and as raw column-major
.bin for Octave), times in the same run, one BLAS thread, process CPU time, best of several
repetitions:
  DARE      kfx SolveFilterDare | SLICOT SB02OD (C++) | scipy solve_discrete_are | Octave dare
  DARE S, E kfx SolveFilterDare(A, C, Q, R, S, E) | SLICOT SG02AD (C++) | SLICOT SB02OD with L = S after E^{-1}
          (C++) | scipy solve_discrete_are(a, b, q, r, e, s) | Octave dare(a, b, q, r, s, e)
  Lyapunov  kfx SolveDiscreteLyapunov | SLICOT SB03MD (C++) | scipy solve_discrete_lyapunov
  KF        kfx RunFilter (1000 steps; with the steady-state switch and with every step full) | a plain numpy
          predict/update loop | FilterPy (if importable) | at n = 4 a fixed-size Eigen filter (C++)
checks every solution in this script (relative residual, stabilizing, symmetric PSD, difference
from SLICOT's X; filters: difference from the numpy loop), and writes OUT/peers.json and
OUT/peers.md (the table of docs/benchmarks.md).

Usage: peers.py --driver BUILD/bench/kfx_peers --out DIR [--quick] [--only dare|dare_se|lyapunov|kf ...]
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import blas_kernel  # noqa: E402
# The BLAS kernel, chosen as the kfx CLI chooses it, before numpy loads the library (docs/performance.md).
BLAS = blas_kernel.choose(sys.argv[sys.argv.index("--driver") + 1]) if "--driver" in sys.argv else None
import numpy as np  # noqa: E402  (after the thread settings)
import scipy  # noqa: E402
import scipy.linalg as sla  # noqa: E402

DARE_N = [10, 50, 100, 200, 400]
DARE_SE_N = [50, 100, 200]
LYAP_N = [10, 50, 100, 200, 400]
KF_N = [4, 50, 200, 1000]
KF_T = 1000
KF_TOL = 1e-13  # kfx steady-state fast path: freeze the gain once P_{k|k} changes by <= this
NUMPY_PREFIX_N1000 = 20  # the numpy loop at n = 1000 is timed on a prefix and scaled to 1000 steps


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def best_cpu(fn, reps):
    times, out = [], None
    for _ in range(reps):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return times, out


def spd(rng, n):
    g = rng.standard_normal((n, n))
    s = g @ g.T / n + 0.1 * np.eye(n)
    return 0.5 * (s + s.T)


def scaled(rng, n, rho):
    a = rng.standard_normal((n, n))
    return a * (rho / np.max(np.abs(np.linalg.eigvals(a))))


def save(d, name, m):
    np.save(os.path.join(d, name + ".npy"), np.asarray(m, dtype=np.float64))


def save_bin(d, name, m):  # column-major float64 for Octave's fread
    np.ascontiguousarray(np.atleast_2d(m).T, dtype="<f8").tofile(os.path.join(d, name + ".bin"))


def load(d, name):
    return np.load(os.path.join(d, name + ".npy"))


def run_driver(driver, *args):
    r = subprocess.run([driver, *map(str, args)], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"kfx_peers {' '.join(map(str, args))} failed: {r.stderr}")
    return json.loads(r.stdout)


# ---------------------------------------------------------------------------------------------
# Checks (one definition for every solver)

def dare_check(A, C, Q, R, P, P_ref):
    P = np.asarray(P)
    S = C @ P @ C.T + R
    K = np.linalg.solve(S, C @ P).T  # filter gain P C^T S^-1
    Pf = P - K @ C @ P
    res = np.linalg.norm(P - A @ Pf @ A.T - Q) / max(np.linalg.norm(P), 1e-300)
    rho = np.max(np.abs(np.linalg.eigvals(A - A @ K @ C)))
    sym = np.linalg.norm(P - P.T) / np.linalg.norm(P)
    lmin = np.min(np.linalg.eigvalsh(0.5 * (P + P.T))) / np.linalg.norm(P)
    diff = np.linalg.norm(P - P_ref) / np.linalg.norm(P_ref)
    ok = bool(res <= 1e-10 and rho < 1 and sym <= 1e-12 and lmin >= -1e-10)
    return dict(residual=res, closed_loop_rho=rho, asymmetry=sym, min_eig_rel=lmin, diff_from_slicot=diff, ok=ok)


def dare_se_check(A, C, Q, R, S, E, P, P_ref):
    """The filter DARE with cross term S and descriptor E (include/kfx/riccati.hpp):
    E P E^T = A P A^T + Q - (A P C^T + S) W^{-1} (A P C^T + S)^T, W = C P C^T + R; closed loop E^{-1} (A - K_p C)."""
    P = np.asarray(P)
    W = C @ P @ C.T + R
    X = A @ P @ C.T + S
    K_p = np.linalg.solve(W, X.T).T
    EPEt = E @ P @ E.T
    res = np.linalg.norm(A @ P @ A.T - EPEt + Q - K_p @ X.T) / max(np.linalg.norm(EPEt), 1e-300)
    rho = np.max(np.abs(np.linalg.eigvals(np.linalg.solve(E, A - K_p @ C))))
    sym = np.linalg.norm(P - P.T) / np.linalg.norm(P)
    lmin = np.min(np.linalg.eigvalsh(0.5 * (P + P.T))) / np.linalg.norm(P)
    diff = np.linalg.norm(P - P_ref) / np.linalg.norm(P_ref)
    ok = bool(res <= 1e-10 and rho < 1 and sym <= 1e-12 and lmin >= -1e-10)
    return dict(residual=res, closed_loop_rho=rho, asymmetry=sym, min_eig_rel=lmin, diff_from_slicot=diff, ok=ok)


def lyap_check(A, Q, X, X_ref):
    res = np.linalg.norm(X - A @ X @ A.T - Q) / np.linalg.norm(X)
    sym = np.linalg.norm(X - X.T) / np.linalg.norm(X)
    lmin = np.min(np.linalg.eigvalsh(0.5 * (X + X.T))) / np.linalg.norm(X)
    diff = np.linalg.norm(X - X_ref) / np.linalg.norm(X_ref)
    ok = bool(res <= 1e-10 and sym <= 1e-12 and lmin >= -1e-10)
    return dict(residual=res, asymmetry=sym, min_eig_rel=lmin, diff_from_slicot=diff, ok=ok)


# ---------------------------------------------------------------------------------------------
# Peers in Python

def numpy_kf(A, C, Q, R, m0, P0, Y):
    """The filter a numpy user writes: predict, then the standard (cheapest) update."""
    x, P = m0.copy(), P0.copy()
    At = A.T
    xs = np.empty((Y.shape[0] + 1, x.size))
    xs[0] = x
    for k in range(Y.shape[0]):
        x = A @ x
        P = A @ P @ At + Q
        PCt = P @ C.T
        S = C @ PCt + R
        K = np.linalg.solve(S, PCt.T).T
        x = x + K @ (Y[k] - C @ x)
        P = P - K @ PCt.T
        P = 0.5 * (P + P.T)
        xs[k + 1] = x
    return xs, P


def filterpy_kf(A, C, Q, R, m0, P0, Y):
    from filterpy.kalman import KalmanFilter  # not packaged in Debian; used when importable

    kf = KalmanFilter(dim_x=A.shape[0], dim_z=C.shape[0])
    kf.F, kf.H, kf.Q, kf.R = A, C, Q, R
    kf.x, kf.P = m0.copy(), P0.copy()
    xs = np.empty((Y.shape[0] + 1, A.shape[0]))
    xs[0] = m0
    for k in range(Y.shape[0]):
        kf.predict()
        kf.update(Y[k])
        xs[k + 1] = kf.x
    return xs, kf.P


def have_filterpy():
    try:
        import filterpy  # noqa: F401

        return True
    except ImportError:
        return False


OCTAVE_SCRIPT = r"""1;
pkg load control
d = '%(dir)s'; ns = [%(ns)s]; reps = %(reps)s;
function M = rd(d, name, r, c)
  f = fopen([d '/' name '.bin'], 'r'); M = fread(f, [r c], 'double'); fclose(f);
end
for i = 1:numel(ns)
  n = ns(i); m = n / 2; p = sprintf('dare_%%d_', n);
  A = rd(d, [p 'A'], n, n); C = rd(d, [p 'C'], m, n); Q = rd(d, [p 'Q'], n, n); R = rd(d, [p 'R'], m, m);
  t = zeros(1, reps(i));
  for j = 1:reps(i)
    t0 = cputime(); X = dare(A', C', Q, R); t(j) = cputime() - t0;
  end
  f = fopen([d '/' p 'X_octave.bin'], 'w'); fwrite(f, X, 'double'); fclose(f);
  f = fopen([d '/' p 'octave_times.txt'], 'w'); fprintf(f, '%%.6g\n', t); fclose(f);
end
"""


OCTAVE_SE_SCRIPT = r"""1;
pkg load control
d = '%(dir)s'; ns = [%(ns)s]; reps = %(reps)s;
function M = rd(d, name, r, c)
  f = fopen([d '/' name '.bin'], 'r'); M = fread(f, [r c], 'double'); fclose(f);
end
for i = 1:numel(ns)
  n = ns(i); m = n / 2; p = sprintf('dare_se_%%d_', n);
  A = rd(d, [p 'A'], n, n); C = rd(d, [p 'C'], m, n); Q = rd(d, [p 'Q'], n, n); R = rd(d, [p 'R'], m, m);
  S = rd(d, [p 'S'], n, m); E = rd(d, [p 'E'], n, n);
  t = zeros(1, reps(i));
  for j = 1:reps(i)
    t0 = cputime(); X = dare(A', C', Q, R, S, E'); t(j) = cputime() - t0;
  end
  f = fopen([d '/' p 'X_octave.bin'], 'w'); fwrite(f, X, 'double'); fclose(f);
  f = fopen([d '/' p 'octave_times.txt'], 'w'); fprintf(f, '%%.6g\n', t); fclose(f);
end
"""


def run_octave(data, template, ns, reps, last_times_file):
    """Runs an Octave timing script; False when octave-cli is missing or failed."""
    if not ns or shutil_which("octave-cli") is None:
        return False
    script = template % dict(dir=data, ns=" ".join(map(str, ns)), reps="[" + " ".join(str(r) for r in reps) + "]")
    script_path = os.path.join(data, "octave_" + os.path.basename(last_times_file) + ".m")
    with open(script_path, "w") as f:
        f.write(script)
    r = subprocess.run(["octave-cli", "--quiet", "--no-window-system", script_path], capture_output=True, text=True)
    if r.returncode != 0 and not os.path.exists(os.path.join(data, last_times_file)):
        log("octave failed:", r.stderr[-2000:])
        return False
    return True


def octave_version():
    try:
        r = subprocess.run(["octave-cli", "--eval", "disp(version); pkg load control; "
                            "v = pkg('list', 'control'); disp(v{1}.version)"],
                           capture_output=True, text=True, timeout=120)
        return " / control ".join(r.stdout.split())
    except (OSError, subprocess.TimeoutExpired):
        return None


# ---------------------------------------------------------------------------------------------

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--driver", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--quick", action="store_true", help="small sizes only (a smoke test of the harness)")
    ap.add_argument("--only", choices=["dare", "dare_se", "lyapunov", "kf"], action="append",
                    help="run only these sections (repeatable; default: all)")
    args = ap.parse_args()
    dare_n, dare_se_n, lyap_n, kf_n = DARE_N, DARE_SE_N, LYAP_N, KF_N
    if args.quick:
        dare_n, dare_se_n, lyap_n, kf_n = [10, 50], [50], [10, 50], [4, 50]
    if args.only:
        dare_n, dare_se_n, lyap_n, kf_n = (ns if name in args.only else [] for name, ns in
                                           (("dare", dare_n), ("dare_se", dare_se_n), ("lyapunov", lyap_n),
                                            ("kf", kf_n)))
    out = os.path.abspath(args.out)
    data = os.path.join(out, "data")
    os.makedirs(data, exist_ok=True)
    t_start = time.time()
    reps_for = lambda n: 7 if n <= 50 else 5 if n <= 100 else 3  # noqa: E731
    # The DARE targets are medians of paired ratios: at least 5 pairs (3 is one outlier from a miss).
    dare_reps = lambda n: max(5, reps_for(n))  # noqa: E731

    result = dict(
        machine=dict(platform=platform.platform(), processor=platform.processor(), cpus=os.cpu_count(),
                     loadavg_start=os.getloadavg()),
        versions=dict(python=platform.python_version(), numpy=np.__version__, scipy=scipy.__version__,
                      octave=octave_version(), filterpy=have_filterpy()),
        timing="process CPU seconds, best of the repetitions; OPENBLAS_NUM_THREADS=1",
        blas=BLAS,
        dare=[], dare_se=[], lyapunov=[], kf=[])

    log("DGEMM rate ...")
    result["dgemm"] = run_driver(args.driver, "dgemm", 7)
    a = np.random.default_rng(0).standard_normal((1000, 1000))
    t, _ = best_cpu(lambda: a @ a, 5)
    result["dgemm"]["numpy_gflops"] = 2.0 / min(t)

    # ---- DARE -------------------------------------------------------------------------------
    for n in dare_n:
        rng = np.random.default_rng(20240 + n)
        m = n // 2
        A = scaled(rng, n, 0.95)
        C = rng.standard_normal((m, n))
        Q, R = spd(rng, n), spd(rng, m)
        p = f"dare_{n}_"
        for name, M in zip("ACQR", (A, C, Q, R)):
            save(data, p + name, M)
            save_bin(data, p + name, M)
    octave_ok = bool(dare_n) and shutil_which("octave-cli") is not None
    if octave_ok:
        log("Octave dare ...")
        script = OCTAVE_SCRIPT % dict(dir=data, ns=" ".join(map(str, dare_n)),
                                      reps="[" + " ".join(str(dare_reps(n)) for n in dare_n) + "]")
        script_path = os.path.join(data, "octave_dare.m")
        with open(script_path, "w") as f:
            f.write(script)
        r = subprocess.run(["octave-cli", "--quiet", "--no-window-system", script_path], capture_output=True,
                           text=True)
        if r.returncode != 0 and not os.path.exists(os.path.join(data, f"dare_{dare_n[-1]}_octave_times.txt")):
            log("octave failed:", r.stderr[-2000:])
            octave_ok = False
    for n in dare_n:
        log(f"DARE n = {n} ...")
        m, reps, p = n // 2, dare_reps(n), f"dare_{n}_"
        A, C, Q, R = (load(data, p + x) for x in "ACQR")
        c = run_driver(args.driver, "dare", data, n, reps)
        X_sl = load(data, p + "X_sb02od")
        t_sp, X_sp = best_cpu(lambda: sla.solve_discrete_are(A.T, C.T, Q, R), reps)
        row = dict(n=n, m=m, reps=reps, kfx=c["kfx"], sb02od=c["sb02od"], scipy=t_sp,
                   kfx_info=dict(status=c["kfx_status"], method=c["kfx_method"], doubling_steps=c["kfx_steps"],
                                 refinement_steps=c["kfx_refine"], lyapunov_certified=c["kfx_lyapunov_certified"],
                                 eigenvalues_exact=c["kfx_eigenvalues_exact"], rho_reported=c["kfx_rho_reported"]),
                   sb02od_info=c["sb02od_info"], ratio_sb02od_paired_median=float(np.median(c["paired_ratio"])))
        checks = dict(kfx=dare_check(A, C, Q, R, load(data, p + "X_kfx"), X_sl),
                      sb02od=dare_check(A, C, Q, R, X_sl, X_sl),
                      scipy=dare_check(A, C, Q, R, X_sp, X_sl))
        if octave_ok:
            row["octave"] = [float(v) for v in open(os.path.join(data, p + "octave_times.txt")).read().split()]
            X_oc = np.fromfile(os.path.join(data, p + "X_octave.bin"), dtype="<f8").reshape(n, n).T
            checks["octave"] = dare_check(A, C, Q, R, X_oc, X_sl)
        row["checks"] = checks
        result["dare"].append(row)

    # ---- DARE with cross term S and descriptor E -----------------------------------------------
    for n in dare_se_n:
        rng = np.random.default_rng(50240 + n)
        m = n // 2
        A = scaled(rng, n, 0.95)
        C = rng.standard_normal((m, n))
        J = spd(rng, n + m)  # joint covariance [[Q, S], [S^T, R]] > 0
        Q, S, R = J[:n, :n], J[:n, n:], J[n:, n:]
        E = np.eye(n) + 0.3 * rng.standard_normal((n, n)) / np.sqrt(n)
        p = f"dare_se_{n}_"
        for name, M in zip("ACQRSE", (A, C, Q, R, S, E)):
            save(data, p + name, M)
            save_bin(data, p + name, M)
    octave_se_ok = run_octave(data, OCTAVE_SE_SCRIPT, dare_se_n, [dare_reps(n) for n in dare_se_n],
                              f"dare_se_{dare_se_n[-1]}_octave_times.txt" if dare_se_n else "")
    for n in dare_se_n:
        log(f"DARE with S and E, n = {n} ...")
        m, reps, p = n // 2, dare_reps(n), f"dare_se_{n}_"
        A, C, Q, R, S, E = (load(data, p + x) for x in "ACQRSE")
        c = run_driver(args.driver, "dare_se", data, n, reps)
        X_sg = load(data, p + "X_sg02ad")
        # SciPy's default balancing of the pencil with e fails on some well-posed problems ("eigenvalues too
        # close to the unit circle", SciPy 1.10): then it is timed with balanced=False, and the table says so.
        scipy_note = ""
        try:
            sla.solve_discrete_are(A.T, C.T, Q, R, e=E.T, s=S)
            balanced = True
        except np.linalg.LinAlgError as e:
            scipy_note, balanced = f"default (balanced=True) failed: {e}; timed with balanced=False", False
        t_sp, X_sp = best_cpu(lambda: sla.solve_discrete_are(A.T, C.T, Q, R, e=E.T, s=S, balanced=balanced), reps)
        row = dict(n=n, m=m, reps=reps, kfx=c["kfx"], sg02ad=c["sg02ad"], sb02od=c["sb02od"], scipy=t_sp,
                   scipy_note=scipy_note,
                   kfx_info=dict(status=c["kfx_status"], method=c["kfx_method"], fell_back=c["kfx_fell_back"],
                                 doubling_steps=c["kfx_steps"], refinement_steps=c["kfx_refine"],
                                 lyapunov_certified=c["kfx_lyapunov_certified"]),
                   sg02ad_info=c["sg02ad_info"], sb02od_info=c["sb02od_info"],
                   ratio_sg02ad_paired_median=float(np.median(c["paired_ratio_sg02ad"])),
                   ratio_sb02od_paired_median=float(np.median(c["paired_ratio_sb02od"])))
        chk = lambda X: dare_se_check(A, C, Q, R, S, E, X, X_sg)  # noqa: E731
        checks = dict(kfx=chk(load(data, p + "X_kfx")), sg02ad=chk(X_sg), sb02od=chk(load(data, p + "X_sb02od")),
                      scipy=chk(X_sp))
        if octave_se_ok:
            row["octave"] = [float(v) for v in open(os.path.join(data, p + "octave_times.txt")).read().split()]
            checks["octave"] = chk(np.fromfile(os.path.join(data, p + "X_octave.bin"), dtype="<f8").reshape(n, n).T)
        row["checks"] = checks
        result["dare_se"].append(row)

    # ---- Lyapunov ---------------------------------------------------------------------------
    for n in lyap_n:
        log(f"Lyapunov n = {n} ...")
        rng = np.random.default_rng(30240 + n)
        A, Q = scaled(rng, n, 0.95), spd(rng, n)
        p, reps = f"lyap_{n}_", reps_for(n)
        save(data, p + "A", A)
        save(data, p + "Q", Q)
        c = run_driver(args.driver, "lyap", data, n, reps)
        X_sl = load(data, p + "X_sb03md")
        t_sp, X_sp = best_cpu(lambda: sla.solve_discrete_lyapunov(A, Q), reps)
        result["lyapunov"].append(dict(
            n=n, reps=reps, kfx=c["kfx"], sb03md=c["sb03md"], scipy=t_sp,
            ratio_sb03md_paired_median=float(np.median(c["paired_ratio"])),
            checks=dict(kfx=lyap_check(A, Q, load(data, p + "X_kfx"), X_sl), sb03md=lyap_check(A, Q, X_sl, X_sl),
                        scipy=lyap_check(A, Q, X_sp, X_sl))))

    # ---- Kalman filter ----------------------------------------------------------------------
    for n in kf_n:
        log(f"Kalman filter n = {n} ...")
        rng = np.random.default_rng(40240 + n)
        m = max(2, n // 10)
        A = 0.95 * np.linalg.qr(rng.standard_normal((n, n)))[0]  # normal, spectral radius 0.95
        C = rng.standard_normal((m, n)) / np.sqrt(n)
        Q = 0.1 * spd(rng, n)
        R = np.eye(m)
        m0, P0 = np.zeros(n), np.eye(n)
        Lq = np.linalg.cholesky(Q)
        x = rng.standard_normal(n)
        Y = np.empty((KF_T, m))
        for k in range(KF_T):
            x = A @ x + Lq @ rng.standard_normal(n)
            Y[k] = C @ x + rng.standard_normal(m)
        p = f"kf_{n}_"
        for name, M in (("A", A), ("C", C), ("Q", Q), ("R", R), ("m0", m0), ("P0", P0), ("Y", Y)):
            save(data, p + name, M)
        big = n >= 1000
        reps = 2 if big else reps_for(n)
        c = run_driver(args.driver, "kf", data, n, reps, 3 if big else 10, KF_TOL)
        steps_np = NUMPY_PREFIX_N1000 if big else KF_T
        t_np, (xs_np, P_np) = best_cpu(lambda: numpy_kf(A, C, Q, R, m0, P0, Y[:steps_np]), 1 if big else reps)
        t_np_1000 = [t * KF_T / steps_np for t in t_np]
        xs_kfx = load(data, p + "xfilt_kfx")
        scale = np.linalg.norm(xs_np)
        row = dict(n=n, m=m, steps=KF_T, reps=reps, kfx=c["kfx"], numpy=t_np_1000, numpy_steps_timed=steps_np,
                   kfx_cov_step=c["cov_step"], cov_step_flops=c["cov_step_flops"], peak_rss_mb=c["peak_rss_mb"],
                   run_rss_growth_mb=c["run_rss_growth_mb"], run_outputs_mb=c["run_outputs_mb"],
                   covariance_mb=c["covariance_mb"],
                   kfx_full_steps=KF_T - c["steady_state_steps"],
                   kfx_every_step=[t * KF_T / c["kfx_full_steps_timed"] for t in c["kfx_full"]],
                   kfx_every_step_timed=c["kfx_full_steps_timed"], eigen_fixed=c["eigen_fixed"],
                   eigen_fixed_x_diff=c["eigen_fixed_x_diff"], eigen_fixed_loglik_diff=c["eigen_fixed_loglik_diff"],
                   checks=dict(x_diff_from_numpy=float(np.linalg.norm(xs_kfx[:steps_np + 1] - xs_np) / scale)))
        if not big:
            Pd = load(data, p + "Pdiag_kfx").ravel()
            row["checks"]["final_Pdiag_diff_from_numpy"] = float(np.linalg.norm(Pd - np.diag(P_np)) /
                                                                 np.linalg.norm(np.diag(P_np)))
        if have_filterpy():
            t_fp, (xs_fp, _) = best_cpu(lambda: filterpy_kf(A, C, Q, R, m0, P0, Y[:steps_np]), 1 if big else reps)
            row["filterpy"] = [t * KF_T / steps_np for t in t_fp]
            row["checks"]["filterpy_x_diff_from_numpy"] = float(np.linalg.norm(xs_fp - xs_np) / scale)
        row["checks"]["ok"] = bool(row["checks"]["x_diff_from_numpy"] <= 1e-8 and
                                   row["checks"].get("final_Pdiag_diff_from_numpy", 0.0) <= 1e-8)
        result["kf"].append(row)

    result["machine"]["loadavg_end"] = os.getloadavg()
    result["wall_seconds"] = time.time() - t_start
    with open(os.path.join(out, "peers.json"), "w") as f:
        json.dump(result, f, indent=1, default=float)
    md = table(result)
    with open(os.path.join(out, "peers.md"), "w") as f:
        f.write(md)
    print(md)
    log(f"wrote {out}/peers.json and {out}/peers.md ({result['wall_seconds']:.0f} s)")


def shutil_which(name):
    import shutil

    return shutil.which(name)


def fmt_t(s):
    return f"{s * 1e3:.3g} ms" if s < 1 else f"{s:.3g} s"


def table(r):
    dg = r["dgemm"]["gflops"]
    L = []
    v = r["versions"]
    L.append(f"Machine: {r['machine']['cpus']} CPUs ({r['machine']['processor'] or platform.machine()}), "
             f"load average {r['machine']['loadavg_start'][0]:.1f} at the start, "
             f"{r['machine']['loadavg_end'][0]:.1f} at the end; one BLAS thread. "
             f"Measured single-thread DGEMM (n = 1000): **{dg:.1f} GFLOP/s** from C++ (Eigen -> OpenBLAS), "
             f"{r['dgemm']['numpy_gflops']:.1f} GFLOP/s from numpy. Python {v['python']}, numpy {v['numpy']}, "
             f"SciPy {v['scipy']}, Octave {v['octave'] or 'not installed'}, FilterPy {'yes' if v['filterpy'] else 'not installed'}. "
             f"Times: process CPU time, best of the repetitions; ratios = peer time / kfx time "
             f"(> 1: kfx faster). Whole run: {r['wall_seconds'] / 60:.1f} min.\n")
    if r.get("blas"):
        L.append(blas_kernel.line(r["blas"], dg) + "\n")

    def ok(c):
        return "ok" if c["ok"] else "**FAIL**"

    L.append("### DARE (filter form), m = n/2\n")
    L.append("| n | kfx | SB02OD | SciPy | Octave | SB02OD / kfx (paired median) | SciPy / kfx | Octave / kfx | "
             "kfx residual | SB02OD res. | SciPy res. | Octave res. | kfx vs SB02OD X | checks |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for d in r["dare"]:
        k, s, sp = min(d["kfx"]), min(d["sb02od"]), min(d["scipy"])
        oc = min(d["octave"]) if "octave" in d else float("nan")
        ch = d["checks"]
        allok = all(c["ok"] for c in ch.values())
        L.append(f"| {d['n']} | {fmt_t(k)} | {fmt_t(s)} | {fmt_t(sp)} | {fmt_t(oc) if oc == oc else 'not installed'} | "
                 f"**{d['ratio_sb02od_paired_median']:.2f}x** | {sp / k:.1f}x | "
                 f"{f'{oc / k:.1f}x' if oc == oc else 'not installed'} | {ch['kfx']['residual']:.1e} | "
                 f"{ch['sb02od']['residual']:.1e} | {ch['scipy']['residual']:.1e} | "
                 f"{format(ch['octave']['residual'], '.1e') if 'octave' in ch else 'not installed'} | "
                 f"{ch['kfx']['diff_from_slicot']:.1e} | {'all ok' if allok else ', '.join(f'{a}: {ok(c)}' for a, c in ch.items())} |")
    if r.get("dare_se"):
        L.append("\n### DARE with cross term S and descriptor E, m = n/2\n")
        L.append("E P Eᵀ = A P Aᵀ + Q - (A P Cᵀ + S) W⁻¹ (A P Cᵀ + S)ᵀ, W = C P Cᵀ + R (include/kfx/riccati.hpp). "
                 "SG02AD: SLICOT's solver for E and S (as kfx's Schur method calls it); SB02OD: SLICOT's solver "
                 "without E, called with L = E⁻¹ S on E⁻¹ A, E⁻¹ Q E⁻ᵀ (the LU solves timed with it). Residuals "
                 "relative to |E P Eᵀ|; checks: residual <= 1e-10, rho(E⁻¹ (A - K_p C)) < 1, symmetric PSD.\n")
        L.append("| n | kfx | SG02AD | SB02OD (E⁻¹, L = S) | SciPy | Octave | SG02AD / kfx (paired median) | "
                 "SB02OD / kfx (paired median) | SciPy / kfx | Octave / kfx | kfx method | kfx residual | SG02AD res. | "
                 "SB02OD res. | SciPy res. | Octave res. | kfx vs SG02AD X | checks |")
        L.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        notes = [f"n = {d['n']}: SciPy's {d['scipy_note']}" for d in r["dare_se"] if d["scipy_note"]]
        for d in r["dare_se"]:
            k, sg, sb, sp = min(d["kfx"]), min(d["sg02ad"]), min(d["sb02od"]), min(d["scipy"])
            ch = d["checks"]
            allok = all(c["ok"] for c in ch.values())
            has_oc = "octave" in d
            oc = min(d["octave"]) if has_oc else None
            L.append(f"| {d['n']} | {fmt_t(k)} | {fmt_t(sg)} | {fmt_t(sb)} | "
                     f"{fmt_t(sp)}{' (balanced=False: the default fails)' if d['scipy_note'] else ''} | "
                     f"{fmt_t(oc) if has_oc else 'not installed'} | **{d['ratio_sg02ad_paired_median']:.2f}x** | "
                     f"**{d['ratio_sb02od_paired_median']:.2f}x** | {sp / k:.1f}x | "
                     f"{f'{oc / k:.1f}x' if has_oc else 'not installed'} | {d['kfx_info']['method']} | "
                     f"{ch['kfx']['residual']:.1e} | {ch['sg02ad']['residual']:.1e} | {ch['sb02od']['residual']:.1e} | "
                     f"{ch['scipy']['residual']:.1e} | "
                     f"{format(ch['octave']['residual'], '.1e') if has_oc else 'not installed'} | "
                     f"{ch['kfx']['diff_from_slicot']:.1e} | "
                     f"{'all ok' if allok else ', '.join(f'{a}: {ok(c)}' for a, c in ch.items())} |")
        L.extend("\n" + note for note in notes)
    L.append("\n### Discrete Lyapunov X = A X Aᵀ + Q\n")
    L.append("| n | kfx | SB03MD | SciPy | SB03MD / kfx (paired median) | SciPy / kfx | kfx residual | "
             "SB03MD res. | SciPy res. | kfx vs SB03MD X | checks |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|")
    for d in r["lyapunov"]:
        k, s, sp = min(d["kfx"]), min(d["sb03md"]), min(d["scipy"])
        ch = d["checks"]
        allok = all(c["ok"] for c in ch.values())
        L.append(f"| {d['n']} | {fmt_t(k)} | {fmt_t(s)} | {fmt_t(sp)} | **{d['ratio_sb03md_paired_median']:.2f}x** | "
                 f"{sp / k:.1f}x | {ch['kfx']['residual']:.1e} | {ch['sb03md']['residual']:.1e} | "
                 f"{ch['scipy']['residual']:.1e} | {ch['kfx']['diff_from_slicot']:.1e} | "
                 f"{'all ok' if allok else ', '.join(f'{a}: {ok(c)}' for a, c in ch.items())} |")
    L.append(f"\n### Kalman filter, {KF_T} steps, m = max(2, n/10)\n")
    L.append("Two kfx columns: with the steady-state switch (FilterRunOptions::steady_state_tolerance = "
             f"{KF_TOL:g}: the gain is frozen once P_k|k stops changing; 'full steps' says after how many) and with "
             "every step a full covariance step (tolerance 0), which is what the numpy loop and FilterPy do.\n")
    L.append("| n | m | kfx, switch | kfx full steps | kfx, every step full | numpy loop | FilterPy | numpy / kfx switch | "
             "numpy / kfx every step | kfx covariance step | "
             "its GFLOP/s | fraction of DGEMM | kfx peak RSS | run's RSS growth - outputs | in covariances (n^2 doubles) | "
             "x vs numpy | checks |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for d in r["kf"]:
        k, nl = min(d["kfx"]), min(d["numpy"])
        fp = fmt_t(min(d["filterpy"])) if "filterpy" in d else "-"
        cs = min(d["kfx_cov_step"])
        gf = d["cov_step_flops"] / cs * 1e-9
        note = "" if d["numpy_steps_timed"] == KF_T else f" ({d['numpy_steps_timed']} steps x {KF_T // d['numpy_steps_timed']})"
        ke = min(d["kfx_every_step"])
        enote = "" if d["kfx_every_step_timed"] == KF_T else f" ({d['kfx_every_step_timed']} steps x {KF_T // d['kfx_every_step_timed']})"
        L.append(f"| {d['n']} | {d['m']} | {fmt_t(k)} | {d['kfx_full_steps']} | {fmt_t(ke)}{enote} | {fmt_t(nl)}{note} | {fp} | "
                 f"**{nl / k:.1f}x** | **{nl / ke:.1f}x** | {fmt_t(cs)} | "
                 f"{gf:.1f} | **{gf / dg:.0%}** | {d['peak_rss_mb']:.0f} MB | "
                 f"{d['run_rss_growth_mb'] - d['run_outputs_mb']:.1f} MB | "
                 f"**{(d['run_rss_growth_mb'] - d['run_outputs_mb']) / d['covariance_mb']:.2f}** | "
                 f"{d['checks']['x_diff_from_numpy']:.1e} | "
                 f"{'ok' if d['checks']['ok'] else '**FAIL**'} |")
    for d in r["kf"]:
        if d.get("eigen_fixed"):
            ke, ef = min(d["kfx_every_step"]), min(d["eigen_fixed"])
            L.append(f"\nAt n = {d['n']}, m = {d['m']}: a fixed-size Eigen filter (Eigen::Matrix<double, 4, 4>, the same "
                     f"step: predict, Joseph update, symmetrization, log-likelihood; bench/peers/kfx_peers.cpp) takes "
                     f"{fmt_t(ef)} for {KF_T} steps; kfx with every step full takes {fmt_t(ke)}: "
                     f"**{ke / ef:.2f}x** the fixed-size time (target <= 2x). Means equal to "
                     f"{d['eigen_fixed_x_diff']:.1e}, log-likelihood to {d['eigen_fixed_loglik_diff']:.1e} (relative).")
    return "\n".join(L) + "\n"


if __name__ == "__main__":
    main()
