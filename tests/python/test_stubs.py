"""python/kfx/_core.pyi is current: regenerating it from the built module gives the same text
(after changing the bindings run: PYTHONPATH=build/python /usr/bin/python3 python/gen_stubs.py)."""
import os
import subprocess
import sys

from conftest import ROOT


def test_type_stubs_match_the_module(tmp_path):
    out = tmp_path / "_core.pyi"
    subprocess.run([sys.executable, os.path.join(ROOT, "python", "gen_stubs.py"), str(out)], check=True,
                   capture_output=True)
    committed = open(os.path.join(ROOT, "python", "kfx", "_core.pyi")).read()
    assert out.read_text() == committed, "python/kfx/_core.pyi is stale: run python/gen_stubs.py"
    compile(committed, "_core.pyi", "exec")  # valid Python syntax


def test_docstrings_are_present():
    import kfx

    for obj in (kfx.run_filter, kfx.solve_filter_dare, kfx.exact_performance, kfx.reproduce, kfx.KalmanFilter,
                kfx.blockdiag.run_coupled_filter, kfx.mismatch.stationary_mismatched_covariance,
                kfx.continuous.study_convergence, kfx.reduced.reduced_order_one_step,
                kfx.subspace.subspace_filter_schedule):
        assert len(obj.__doc__ or "") > 40, obj
