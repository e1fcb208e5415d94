#!/usr/bin/env bash
# ctest python_pip_install (fixture of the Python tests): installs kfx with pip into the venv VENV,
# offline, reusing the CMake build BUILD (KFX_BUILD_DIR: only changed files rebuild), so that the
# pytest suite runs against the installed package as a user would have it.
# Usage: pip_install.sh PYTHON SOURCE BUILD VENV   (PYTHON makes the venv when VENV has none)
set -euo pipefail
python=$1 source=$2 build=$3 venv=$4
if [[ ! -x "$venv/bin/pip" ]]; then
  rm -rf "$venv"
  "$python" -m venv --system-site-packages "$venv"
fi
SECONDS=0
KFX_BUILD_DIR="$build" "$venv/bin/pip" install --quiet --no-build-isolation --no-index --no-cache-dir \
  --disable-pip-version-check "$source"
echo "pip install: ${SECONDS} s"
"$venv/bin/pip" show kfx | grep -E '^(Name|Version|License|Location|Requires):'
