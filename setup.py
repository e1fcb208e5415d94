"""Builds the Python package kfx with the project's own CMake (metadata: pyproject.toml).

The extension kfx._core is the CMake target kfx_python; setuptools installs it with python/kfx/*.py.
Environment:
  KFX_BUILD_DIR    the CMake build directory (default: build-python in the source tree). An existing
                   configured build (e.g. `make test`'s build/) is reused as it is, so a repeated
                   install rebuilds only what changed; a new one is configured with the Python module
                   only (no tests, CLI, benchmarks, MPI).
  KFX_CMAKE_ARGS   extra arguments of the first configure (e.g. -DKFX_PCH=OFF).
  CMAKE_CXX_COMPILER_LAUNCHER (e.g. ccache), CMAKE_BUILD_PARALLEL_LEVEL: read by CMake itself.
"""
import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent


def project_version():
    """The one version number: project(kfx VERSION x.y.z) of CMakeLists.txt."""
    text = (ROOT / "CMakeLists.txt").read_text(encoding="utf-8")
    match = re.search(r"project\(\s*kfx\s+VERSION\s+([0-9]+(?:\.[0-9]+)*)", text)
    if not match:
        raise RuntimeError("setup.py: no 'project(kfx VERSION ...)' in CMakeLists.txt")
    return match.group(1)


def build_dir():
    return Path(os.environ.get("KFX_BUILD_DIR") or ROOT / "build-python").resolve()


class CMakeBuild(build_ext):
    """build_ext that configures (once) and builds the CMake target kfx_python."""

    def build_extension(self, ext):
        cmake = shutil.which("cmake")
        if not cmake:
            raise RuntimeError("kfx needs CMake >= 3.21 to build (Debian: apt-get install cmake)")
        bdir = build_dir()
        if not (bdir / "CMakeCache.txt").exists():
            python = getattr(sys, "_base_executable", None) or sys.executable
            args = [cmake, "-S", str(ROOT), "-B", str(bdir), "-DCMAKE_BUILD_TYPE=Release",
                    "-DKFX_BUILD_PYTHON=ON", "-DKFX_BUILD_TESTS=OFF", "-DKFX_BUILD_APPS=OFF",
                    "-DKFX_BUILD_BENCHMARKS=OFF", "-DKFX_BUILD_FUZZERS=OFF", "-DKFX_WITH_MPI=OFF",
                    f"-DPython3_EXECUTABLE={python}"]
            args += shlex.split(os.environ.get("KFX_CMAKE_ARGS", ""))
            subprocess.run(args, check=True)
        build = [cmake, "--build", str(bdir), "--target", "kfx_python"]
        if self.parallel:
            build += ["--parallel", str(self.parallel)]
        elif "CMAKE_BUILD_PARALLEL_LEVEL" not in os.environ:
            build += ["--parallel", str(os.cpu_count() or 1)]
        subprocess.run(build, check=True)
        suffix = sysconfig.get_config_var("EXT_SUFFIX")
        built = bdir / "python" / "kfx" / f"_core{suffix}"
        if not built.exists():
            found = sorted(p.name for p in (bdir / "python" / "kfx").glob("_core*"))
            raise RuntimeError(f"setup.py: {built} not built (found {found}): the build directory {bdir} was "
                               f"configured for another Python; set KFX_BUILD_DIR to a new directory")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built, target)


setup(
    version=project_version(),
    ext_modules=[Extension("kfx._core", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    options={"build": {"build_base": str(build_dir() / "setuptools")}},
)
