#!/usr/bin/env python3
"""Renders the figures of `kfx reproduce --out DIR` from the CSV files it writes.

Usage: python3 python/kfx_figures.py DIR [DIR ...]

DIR is a paper's output directory (e.g. demo-out/figures/block-diagonal) or a parent of several.
Needs matplotlib (Debian: python3-matplotlib); prints what it wrote, one path per line.
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read_csv(path):
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
            path = os.path.join(d, name)
            fig.tight_layout()
            fig.savefig(path, dpi=120)
            plt.close(fig)
            out.append(path)
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
        path = os.path.join(d, "coronagraph.png")
        fig.tight_layout()
        fig.savefig(path, dpi=120)
        plt.close(fig)
        out.append(path)
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
    path = os.path.join(d, "fig1_right.png")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    out.append(path)
    return out


RENDERERS = {"block-diagonal": block_diagonal, "aalto-spatial": aalto_spatial}


def main(argv):
    if len(argv) < 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    written = []
    for d in argv[1:]:
        if not os.path.isdir(d):
            print(f"kfx_figures: not a directory: {d}", file=sys.stderr)
            return 2
        dirs = [d] + [os.path.join(d, s) for s in sorted(os.listdir(d)) if os.path.isdir(os.path.join(d, s))]
        for sub in dirs:
            render = RENDERERS.get(os.path.basename(os.path.normpath(sub)))
            if render:
                written += render(sub)
    for p in written:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
