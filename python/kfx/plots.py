"""kfx.plots: matplotlib figures for kfx results.

Two kinds of functions:

* Figures of arrays (each returns the matplotlib Figure; ``save(fig, "name.png")`` writes PNG and SVG):
  ``estimate_band`` (estimate with a confidence band against the truth), ``covariance_heatmap``,
  ``error_vs_mesh`` (000 Fig. 1), ``ratio_vs_time`` (001 Figs. 2-3), ``error_vs_n`` (003 convergence),
  ``block_diagonal_curves`` (004 Fig. 1), ``compare_pareto`` and ``compare_error_vs_time`` (kfx compare).
* ``render(DIR)``: the papers' figures from the CSV files that ``kfx reproduce --out DIR`` (or
  ``kfx.reproduce(paper, out_dir=DIR)``) writes, and those of ``kfx compare --out DIR``, as PNG and SVG; returns the paths. This is what the
  CLI runs (``python3 .../kfx/plots.py DIR``); it needs only matplotlib, not the compiled module.
"""
import csv
import math
import os
import sys

import matplotlib

if __name__ == "__main__":  # run by the CLI: no display; as a library, keep the user's backend
    matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

FORMATS = ("png", "svg")


def save(fig, path, formats=FORMATS, dpi=120):
    """Writes fig as path with each extension in formats (PNG and SVG by default); returns the paths."""
    base, _ = os.path.splitext(path)
    out = []
    fig.tight_layout()
    for ext in formats:
        p = base + "." + ext
        fig.savefig(p, dpi=dpi)
        out.append(p)
    plt.close(fig)
    return out


_save = save


def _np():
    import numpy as np

    return np


# ---- figures of arrays ------------------------------------------------------------------------------


def estimate_band(t, x_true, x_est, P, component=0, sigmas=2.0, ax=None, label="estimate", title=None):
    """One state component: truth, estimate and the band x_est +- sigmas * sqrt(P[k, i, i]).

    t: (T,) times; x_true, x_est: (T, n); P: (T, n, n) covariances or (T, n) variances.
    """
    np = _np()
    x_true, x_est, P = np.asarray(x_true), np.asarray(x_est), np.asarray(P)
    var = P[:, component, component] if P.ndim == 3 else P[:, component]
    sd = np.sqrt(np.maximum(var, 0.0))
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(6, 3.5))
    ax.fill_between(t, x_est[:, component] - sigmas * sd, x_est[:, component] + sigmas * sd, alpha=0.25,
                    label=f"+-{sigmas:g} sigma")
    ax.plot(t, x_true[:, component], "k-", lw=1, label="truth")
    ax.plot(t, x_est[:, component], "C0-", lw=1.2, label=label)
    ax.set_xlabel("k")
    ax.set_ylabel(f"x[{component}]")
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def covariance_heatmap(P, ax=None, title="covariance", correlation=False):
    """A covariance (or, with correlation=True, correlation) matrix as a heat map."""
    np = _np()
    P = np.asarray(P, dtype=float)
    M = P
    if correlation:
        d = np.sqrt(np.maximum(np.diag(P), 1e-300))
        M = P / np.outer(d, d)
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(4.5, 4))
    lim = float(np.max(np.abs(M))) or 1.0
    im = ax.imshow(M, cmap="RdBu_r", vmin=-lim, vmax=lim, interpolation="nearest")
    fig.colorbar(im, ax=ax)
    ax.set_title(title)
    return fig


def error_vs_mesh(h, err, fit=None, ax=None, title="error against mesh size"):
    """000 Fig. 1 (right): error against mesh size on log-log axes; fit = (c, p) draws c h^p."""
    np = _np()
    h, err = np.asarray(h, float), np.asarray(err, float)
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(5.5, 4))
    ax.loglog(h, err, "kx", ms=8, mew=2, label="kfx")
    if fit is not None:
        hh = np.geomspace(h.min(), h.max(), 50)
        ax.loglog(hh, fit[0] * hh ** fit[1], "-", label=f"{fit[0]:.3g} h^{fit[1]:.3g}")
    ax.set_xlabel("mesh size h")
    ax.set_ylabel("error")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def ratio_vs_time(k, curves, ax=None, ylabel="$J_k / J_k^{KF}$", title=None):
    """001 Figs. 2-3: cost ratios against time; curves = {label: values}."""
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(5.5, 4))
    for label, v in curves.items():
        ax.plot(k, v, label=label)
    ax.set_xlabel("k")
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def error_vs_n(n, err, bounds=None, ax=None, title="err(n)"):
    """003: err(n) against the number of samples n (log-log) with bounds = {label: values}."""
    np = _np()
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(5, 4))
    ax.loglog(n, np.maximum(np.asarray(err, float), 1e-300), "ko-", ms=3, label="err(n)")
    for label, v in (bounds or {}).items():
        ax.loglog(n, v, "--", label=label)
    ax.set_xlabel("n")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def block_diagonal_curves(n, curves, ax=None, ylabel=None, title=None):
    """004 Fig. 1: quantities against the number of subsystems n (log-log); curves = {label: values}."""
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(5.5, 4))
    for label, v in curves.items():
        pts = [(a, b) for a, b in zip(n, v) if math.isfinite(b) and b > 0]
        if pts:
            ax.loglog(*zip(*pts), marker="o", ms=3, label=label)
    ax.set_xlabel("number of subsystems n")
    if ylabel:
        ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def _short_method(spec):
    """A method specification without the directories of its file parameters (legend labels)."""
    import re

    return re.sub(r"(?<=[=:])[^=,:]*/", "", spec)


def _legend_outside(fig, ax):
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    fig.set_size_inches(9.5, 4.5)


def _error_axis(ax, values):
    """Log scale when the errors span a decade or more, else linear with plain numbers."""
    v = [x for x in values if math.isfinite(x) and x > 0]
    if v and max(v) / min(v) >= 10:
        ax.set_yscale("log")


def _compare_axes(fig, ax, errors, kalman, kalman_label, xlabel, title):
    """What both kfx compare figures share: the error axis, the optimal filter's line, labels, grid, legend."""
    _error_axis(ax, errors)
    if kalman is not None and math.isfinite(kalman) and kalman > 0:
        ax.axhline(kalman, color="k", ls=":", lw=1, label=kalman_label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("true mean-square error (exact)")
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    _legend_outside(fig, ax)
    return fig


def compare_pareto(rows, kalman=None, ax=None, title="true error against cost per step"):
    """kfx compare: each method's true (exact) error against its online time per step, log-log, with
    the Pareto front (no other method is both cheaper and more accurate) joined; rows = list of dicts
    with "method", "online_seconds_per_step", "headline" (the error), as kfx.compare returns them;
    kalman = the optimal filter's error (default: the rows' "kalman_final_mse" / "kalman_stationary_mse")."""
    if kalman is None and rows and "kalman_final_mse" in rows[0]:
        kalman = rows[0]["kalman_stationary_mse" if rows[0].get("stationary") else "kalman_final_mse"]
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(6.5, 4.5))
    def num(v):
        return math.nan if v is None or v == "" else float(v)

    pts = [(num(r["online_seconds_per_step"]) * 1e6, num(r["headline"]), r["method"]) for r in rows]
    pts = [p for p in pts if math.isfinite(p[0]) and math.isfinite(p[1]) and p[0] > 0 and p[1] > 0]
    markers = "osD^v<>ph*"
    for i, (x, y, label) in enumerate(pts):
        ax.plot([x], [y], markers[i % len(markers)], ms=7, label=_short_method(label))
    front, best = [], math.inf
    for x, y, _ in sorted(pts):
        if y < best:
            front.append((x, y))
            best = y
    if len(front) > 1:
        ax.plot(*zip(*front), "k-", lw=0.8, alpha=0.6, label="Pareto front")
    ax.set_xscale("log")
    return _compare_axes(fig, ax, [p[1] for p in pts], kalman, "optimal Kalman filter",
                         "online time per step (microseconds)", title)


def compare_error_vs_time(k, curves, kalman=None, ax=None, title="true error against time"):
    """kfx compare: each method's exact MSE at k = 0..T (semilog); curves = {method: values}."""
    fig, ax = (ax.figure, ax) if ax is not None else plt.subplots(figsize=(6.5, 4.5))
    for label, v in curves.items():
        kk = [a for a, b in zip(k, v) if math.isfinite(b) and b > 0]
        vv = [b for b in v if math.isfinite(b) and b > 0]
        ax.plot(kk, vv, label=_short_method(label))
    return _compare_axes(fig, ax, [b for v in curves.values() for b in v], kalman, "optimal Kalman filter at T",
                         "k (time step)", title)


# ---- the papers' figures from `kfx reproduce --out DIR` --------------------------------------------


def read_csv(path):
    """The rows of a CSV file with a header line, as a list of dicts (column name -> text).

    Raises OSError if the file cannot be read."""
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def block_diagonal(d):
    """004: Fig. 1 (a), (b) as log-log plots against n, one curve per beta; coronagraph curves."""
    out = []
    fig1 = os.path.join(d, "fig1.csv")
    if os.path.exists(fig1):
        rows = read_csv(fig1)
        betas = sorted({float(r["beta"]) for r in rows})
        for col, name, title in [
            ("block_minus_uncoupled", "fig1a.png", r"(a) $\|\tilde P - P_0\|_F / n$"),
            ("block_minus_full", "fig1b.png", r"(b) $\|\tilde P - P\|_F / n$"),
            ("block_true_minus_uncoupled", "fig1c.png", r"true error of the block-diagonal filter: $\|E - P_0\|_F / n$"),
        ]:
            fig, ax = plt.subplots(figsize=(5.5, 4))
            for b in betas:
                pts = [(int(r["n"]), float(r[col])) for r in rows if float(r["beta"]) == b]
                pts = [(n, v) for n, v in pts if math.isfinite(v) and v > 0]
                if pts:
                    ax.loglog(*zip(*pts), marker="o", ms=3, label=f"beta = {b:g}")
            ax.set_xlabel("number of subsystems n")
            ax.set_title(title)
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8)
            out += _save(fig, os.path.join(d, name))
    cor = os.path.join(d, "coronagraph.csv")
    if os.path.exists(cor):
        rows = read_csv(cor)
        fig, ax = plt.subplots(figsize=(5.5, 4))
        for col, label, style in [
            ("mse_full", "full EKF", ":"),
            ("mse_block_diagonal", "block-diagonal EKF", "-"),
            ("mse_banded", "banded EKF", "--"),
        ]:
            sec = float(rows[0][col.replace("mse", "seconds")])
            ax.semilogy([int(r["step"]) for r in rows], [float(r[col]) for r in rows], style,
                        label=f"{label} ({sec * 1e3:.3g} ms/step)")
        ax.set_xlabel("step")
        ax.set_ylabel("mean squared field error per pixel")
        ax.set_title("speckle drift (synthetic analogue of 004 Fig. 2)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        out += _save(fig, os.path.join(d, "coronagraph.png"))
    return out


def aalto_temporal(d):
    """003: err(n) = tr P_{T,n} - tr P_c(T) on log-log axes with the bounds, one panel per example;
    Example 1 (wave equation, rough and smooth initial state)."""
    out = []
    panels = [("scalar", "scalar (B = 0)"), ("osc_B0", "osc_B0"), ("osc_noise", "osc_noise"), ("rw_highsnr", "rw_highsnr")]
    present = [(n, t) for n, t in panels if os.path.exists(os.path.join(d, n + ".csv"))]
    if present:
        fig, axes = plt.subplots(1, len(present), figsize=(4.2 * len(present), 3.8), squeeze=False)
        for ax, (name, title) in zip(axes[0], present):
            rows = read_csv(os.path.join(d, name + ".csv"))
            n = [float(r["n"]) for r in rows]
            err = [float(r["err"]) for r in rows]
            ax.loglog(n, [max(e, 1e-300) for e in err], "ko-", ms=3, label="err(n)")
            noise = float(rows[0]["theorem2"]) != float(rows[0]["theorem1"])
            curves = [("theorem2", "Thm 2 (as stated)", "r--"), ("theorem2_proof", "Thm 2 (its proof)", "m:"),
                      ("corollary1", "Cor. 1 (ii)", "c-.")] if noise else \
                     [("theorem1", "Thm 1", "r--"), ("theorem4", "Thm 4", "b:"), ("theorem3", "Thm 3", "g-.")]
            for key, label, style in curves:
                ax.loglog(n, [float(r[key]) for r in rows], style, label=label)
            ax.set_title(title)
            ax.set_xlabel("n")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
        axes[0][0].set_ylabel(r"$\mathrm{tr}\,P_{T,n} - \mathrm{tr}\,P_c(T)$")
        out += _save(fig, os.path.join(d, "convergence.png"))
    waves = [(s, os.path.join(d, "wave_" + s + ".csv")) for s in ("rough", "smooth")]
    waves = [(s, p) for s, p in waves if os.path.exists(p)]
    if waves:
        fig, ax = plt.subplots(figsize=(5, 3.8))
        for s, p in waves:
            rows = read_csv(p)
            n = [float(r["n"]) for r in rows]
            err = [float(r["err"]) for r in rows]
            ax.loglog(n, [max(e, 1e-300) for e in err], "o-", ms=3, label=s + " initial state")
            ax.loglog(n, [float(r["theorem4"]) for r in rows], ":", label="Thm 4 bound (" + s + ")")
        ax.set_xlabel("n")
        ax.set_ylabel("err(n)")
        ax.set_title("Example 1: wave equation, dyadic modes")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        out += _save(fig, os.path.join(d, "wave.png"))
    return out


def bernstein(d):
    """001: Fig. 2 (a) reduced-order, (b) subspace (Sec. V, n_e = 8, 16) and Fig. 3 (Sec. VI, subspace,
    n_e = 4, 8) as J_k / J_k^KF against k (001's indexing)."""
    out = []
    for csv_name, png, title in [
        ("fig2a.csv", "fig2a.png", "(a) reduced-order estimator ($\\tau$), Sec. V"),
        ("fig2b.csv", "fig2b.png", "(b) subspace estimator ($\\mu$), Sec. V"),
        ("fig3.csv", "fig3.png", "subspace estimator ($\\mu$), free-free chain, Sec. VI"),
    ]:
        path_csv = os.path.join(d, csv_name)
        if not os.path.exists(path_csv):
            continue
        rows = read_csv(path_csv)
        ks = [int(r["k"]) for r in rows]
        fig, ax = plt.subplots(figsize=(5.5, 4))
        for col in [c for c in rows[0].keys() if c != "k"]:
            kind, ne = col.rsplit("_ne", 1)
            style = {"onestep": "-", "twostep_da": "--", "twostep_f": ":"}[kind]
            label = {"onestep": "one-step", "twostep_da": "two-step, data assimilation",
                     "twostep_f": "two-step, forecast"}[kind]
            ax.plot(ks, [float(r[col]) for r in rows], style, label=f"{label}, $n_e$ = {ne}")
        ax.set_xlabel("k (time index)")
        ax.set_ylabel("$J_k / J_k^{KF}$")
        ax.set_title(title, fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
        out += _save(fig, os.path.join(d, png))
    return out


def aalto_spatial(d):
    """000: Fig. 1 (right), lim E|Q x~ - x^|^2 against h_c = 1/(N_c + 1) (N_f = 65), log-log, with the
    least-squares line over N_c = 1, 2, 5, 10 and the paper's 86.8 h^7.06."""
    out = []
    fig1 = os.path.join(d, "fig1.csv")
    if not os.path.exists(fig1):
        return out
    rows = read_csv(fig1)
    h = [float(r["h"]) for r in rows]
    D = [float(r["D"]) for r in rows]
    c, p = float(rows[0]["fit_c"]), float(rows[0]["fit_p"])
    fig, ax = plt.subplots(figsize=(5.5, 4))
    ax.loglog(h, D, "x", ms=8, mew=2, color="k", label="kfx (exact, engine)")
    hh = [min(h) * (max(h) / min(h)) ** (i / 50) for i in range(51)]
    ax.loglog(hh, [c * x**p for x in hh], "-", label=f"fit {c:.3g} h^{p:.3g} (N_c = 1, 2, 5, 10)")
    ax.loglog(hh, [86.8 * x**7.06 for x in hh], ":", label="paper: 86.8 h^7.06")
    ax.axhspan(1e-300, 1e-8, color="0.9", zorder=0, label="round-off dominated (< 1e-8)")
    ax.set_ylim(min(min(D) / 10, 1e-9), max(D) * 10)
    ax.set_xlabel("coarse mesh size h_c")
    ax.set_ylabel(r"$\lim_k E\|Q\tilde x_k - \hat x_k\|^2_X$")
    ax.set_title("000 Fig. 1 (right): N_f = 65")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    out += _save(fig, os.path.join(d, "fig1_right.png"))
    return out


def compare(d):
    """kfx compare --out DIR: the Pareto figure and the error-vs-time curves from compare_rows.csv and
    compare_curves.csv."""
    rows_path, curves_path = os.path.join(d, "compare_rows.csv"), os.path.join(d, "compare_curves.csv")
    if not (os.path.exists(rows_path) and os.path.exists(curves_path)):
        return []
    rows = read_csv(rows_path)
    methods = [r for r in rows if r["state_dim"] != ""]
    reference = [float(r["headline"]) for r in rows if r["state_dim"] == ""]
    kalman = reference[0] if reference else None
    out = _save(compare_pareto(methods, kalman), os.path.join(d, "compare_pareto.png"))
    with open(curves_path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        data = [[float(x) for x in line] for line in reader if line]
    k = [r[0] for r in data]
    curves = {name: [r[i + 1] for r in data] for i, name in enumerate(header[1:])}
    finals = [float(r["mse"]) for r in rows if r["state_dim"] == ""]
    out += _save(compare_error_vs_time(k, curves, finals[0] if finals else None),
                 os.path.join(d, "compare_error_vs_time.png"))
    return out


RENDERERS = {
    "block-diagonal": block_diagonal,
    "aalto-temporal": aalto_temporal,
    "bernstein": bernstein,
    "aalto-spatial": aalto_spatial,
}


def render(*dirs):
    """Draws every paper figure found under the given directories (a paper's output directory, e.g.
    out/block-diagonal, or a parent of several); returns the written paths (PNG and SVG)."""
    written = []
    for d in dirs:
        if not os.path.isdir(d):
            raise FileNotFoundError(f"kfx.plots.render: not a directory: {d}")
        subs = [d] + [os.path.join(d, s) for s in sorted(os.listdir(d)) if os.path.isdir(os.path.join(d, s))]
        for sub in subs:
            renderer = RENDERERS.get(os.path.basename(os.path.normpath(sub)))
            if renderer:
                written += renderer(sub)
            written += compare(sub)
    return written


def main(argv):
    """Command line `python3 -m kfx.plots DIR [DIR ...]`: draws the figures of each `kfx reproduce --out
    DIR` directory into it. Returns the exit status (2 on a usage error)."""
    if len(argv) < 2:
        print("usage: python3 -m kfx.plots DIR [DIR ...]  (figures of kfx reproduce --out DIR)", file=sys.stderr)
        return 2
    try:
        written = render(*argv[1:])
    except FileNotFoundError as e:
        print(f"kfx.plots: {e}", file=sys.stderr)
        return 2
    for p in written:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
