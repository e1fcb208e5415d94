"""The pip-installed package (issue 21): run by ctest in the venv that python_pip_install filled.
The package imported is the installed one, its metadata version is kfx.__version__ and CMake's
project(VERSION); a wheel built offline installs into a fresh venv and imports from outside the tree."""
import importlib.metadata
import os
import re
import subprocess
import sys
import zipfile

import pytest

import kfx
from conftest import ROOT

installed_only = pytest.mark.skipif(sys.prefix == sys.base_prefix, reason="not run from a venv (pip install)")


def cmake_version():
    text = open(os.path.join(ROOT, "CMakeLists.txt"), encoding="utf-8").read()
    return re.search(r"project\(\s*kfx\s+VERSION\s+([0-9.]+)", text).group(1)


@installed_only
def test_the_installed_package_is_imported():
    here = os.path.realpath(kfx.__file__)
    assert here.startswith(os.path.realpath(sys.prefix) + os.sep), here
    assert not here.startswith(os.path.join(os.path.realpath(ROOT), "python") + os.sep), here


@installed_only
def test_one_version_and_the_metadata():
    assert importlib.metadata.version("kfx") == kfx.__version__ == cmake_version()
    meta = importlib.metadata.metadata("kfx")
    assert meta["License"] == "BSD-3-Clause"
    requires = importlib.metadata.requires("kfx")
    assert any(r.startswith("numpy") for r in requires), requires
    assert any(r.startswith("matplotlib") and "extra == 'plots'" in r for r in requires), requires
    files = {str(f) for f in importlib.metadata.files("kfx")}
    assert any(f.endswith("dist-info/LICENSE") for f in files), files
    assert {"kfx/py.typed", "kfx/_core.pyi", "kfx/plots.py"} <= files


@installed_only
def test_wheel_installs_and_imports_outside_the_tree(tmp_path):
    """pip wheel (offline, no build isolation) -> a fresh venv -> import kfx from an unrelated directory."""
    env = dict(os.environ)
    wheels = tmp_path / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-build-isolation", "--no-index",
                    "--no-deps", "--no-cache-dir", "--disable-pip-version-check", "-w", str(wheels), ROOT],
                   check=True, env=env)
    (wheel,) = wheels.glob("kfx-*.whl")
    assert wheel.name.startswith(f"kfx-{cmake_version()}-")
    names = zipfile.ZipFile(wheel).namelist()
    assert any(re.fullmatch(r"kfx/_core\..*\.so", n) for n in names), names
    print(f"wheel {wheel.name}: {wheel.stat().st_size / 1e6:.2f} MB")
    venv = tmp_path / "venv"
    subprocess.run([sys.base_prefix + "/bin/python3", "-m", "venv", "--system-site-packages", "--without-pip",
                    str(venv)], check=True)
    # pip of this venv installs into the fresh one (--without-pip there keeps this fast).
    subprocess.run([sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), "install", "--quiet",
                    "--no-index", "--no-cache-dir", "--disable-pip-version-check", str(wheel)], check=True)
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    code = ("import importlib.metadata as m, kfx, numpy as np; "
            "print(kfx.__file__); print(m.version('kfx'), kfx.__version__); "
            "print(kfx.solve_filter_dare(np.eye(1), np.eye(1), np.eye(1), np.eye(1)).P_pred[0, 0])")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "KFX_BUILD_DIR")}
    out = subprocess.run([str(venv / "bin" / "python"), "-c", code], cwd=outside, env=env, check=True,
                         capture_output=True, text=True).stdout.split("\n")
    assert out[0].startswith(str(venv)), out
    assert out[1] == f"{cmake_version()} {cmake_version()}", out
    # Scalar DARE with A = C = Q = R = 1: P = 1 + P - P^2/(P + 1)  =>  P^2 = P + 1, the golden ratio.
    assert abs(float(out[2]) - (1 + 5**0.5) / 2) < 1e-12, out
