"""kfx.plots: the array figures, the papers' figures from CSV data, and `kfx reproduce --out` drawing
them through Python (PNG and SVG) or saying plainly that it did not."""
import os
import subprocess

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402

import kfx  # noqa: E402
from kfx import plots  # noqa: E402


def test_array_figures_write_png_and_svg(tmp_path):
    t = np.arange(10)
    x = np.random.default_rng(0).standard_normal((10, 2))
    P = np.tile(np.eye(2), (10, 1, 1))
    written = []
    written += plots.save(plots.estimate_band(t, x, x + 0.1, P, component=1), str(tmp_path / "band.png"))
    written += plots.save(plots.covariance_heatmap(P[0] + 0.5, correlation=True), str(tmp_path / "cov.png"))
    written += plots.save(plots.error_vs_mesh([0.5, 0.25, 0.125], [1e-2, 1e-3, 1e-4], fit=(1.0, 3.3)),
                          str(tmp_path / "mesh.png"))
    written += plots.save(plots.ratio_vs_time(t, {"one-step": 1 + 1 / (t + 1)}), str(tmp_path / "ratio.png"))
    written += plots.save(plots.error_vs_n([1, 2, 4], [1.0, 0.25, 0.06], {"bound": [2.0, 0.5, 0.12]}),
                          str(tmp_path / "n.png"))
    written += plots.save(plots.block_diagonal_curves([1, 10, 100], {"beta = 0.1": [1e-3, 1e-4, np.nan]}),
                          str(tmp_path / "bd.png"))
    assert len(written) == 12
    for p in written:
        assert os.path.getsize(p) > 0
    assert open(tmp_path / "band.svg").read(200).lstrip().startswith("<?xml")


def test_cli_reproduce_out_draws_figures_or_says_why_not(cli, tmp_path):
    # bernstein: the quickest reproduction that has figures
    r = subprocess.run([cli, "reproduce", "bernstein", "--quick", "--out", str(tmp_path / "figs")],
                       check=True, capture_output=True, text=True)
    assert "figures:" in r.stdout and "PNG and SVG" in r.stdout, r.stdout
    listed = open(tmp_path / "figs" / "figures.txt").read().split()
    assert any(p.endswith("fig2a.png") for p in listed) and any(p.endswith("fig2a.svg") for p in listed)
    for p in listed:
        assert os.path.getsize(p) > 0
    # kfx.plots.render on the same data from Python gives the same files
    assert sorted(plots.render(str(tmp_path / "figs"))) == sorted(listed)
    # Without Python (patel-toda: quick, and the message does not depend on the paper)
    env = dict(os.environ, KFX_PYTHON="/nonexistent/python3")
    r = subprocess.run([cli, "reproduce", "patel-toda", "--quick", "--out", str(tmp_path / "nofigs")],
                       check=True, capture_output=True, text=True, env=env)
    assert "figures: not drawn: no Python with matplotlib (tried /nonexistent/python3)" in r.stdout, r.stdout
    assert "CSV data are in" in r.stdout
    assert not (tmp_path / "nofigs" / "figures.txt").exists()
    r = subprocess.run([cli, "reproduce", "patel-toda", "--quick", "--out", str(tmp_path / "none")],
                       check=True, capture_output=True, text=True)
    assert "figures: none to draw" in r.stdout, r.stdout
