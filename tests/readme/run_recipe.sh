#!/usr/bin/env bash
# Runs README.md's "Building from source" recipe verbatim: the fenced block between <!-- recipe:begin -->
# and <!-- recipe:end -->, with bash -e, in a copy of the source tree (the tracked and untracked files,
# not build trees) in a temporary directory, or with --in-place in SOURCE_DIR itself (what `make test`
# does: its build and test run is the recipe). Usage: run_recipe.sh [--in-place] SOURCE_DIR
# The environment may speed it up without changing the commands: CMAKE_BUILD_PARALLEL_LEVEL and
# CTEST_PARALLEL_LEVEL (2 unless set), CTEST_OUTPUT_ON_FAILURE, and in a copy CMAKE_CXX_COMPILER_LAUNCHER
# (ccache when installed).
set -euo pipefail
in_place=no
if [[ ${1:-} == --in-place ]]; then in_place=yes; shift; fi
src=$(cd "$1" && pwd)
recipe=$(awk '/<!-- recipe:end -->/{on=0} on && !/^```/{print} /<!-- recipe:begin -->/{on=1}' "$src/README.md")
[[ -n "$recipe" ]] || { echo "README.md: no <!-- recipe:begin --> ... <!-- recipe:end --> block" >&2; exit 1; }
export CMAKE_BUILD_PARALLEL_LEVEL=${CMAKE_BUILD_PARALLEL_LEVEL:-2} CTEST_PARALLEL_LEVEL=${CTEST_PARALLEL_LEVEL:-2}
if [[ $in_place == yes ]]; then
  echo "README recipe, run in $src:"
  echo "$recipe"
  start=$(date +%s)
  (cd "$src" && bash -euo pipefail -c "$recipe")
  echo "README recipe passed in $(( $(date +%s) - start )) s"
  exit 0
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if git -C "$src" rev-parse --is-inside-work-tree > /dev/null 2>&1; then
  (cd "$src" && git ls-files -z --cached --others --exclude-standard | xargs -0 tar -cf - --ignore-failed-read) |
    tar -xf - -C "$tmp"
else
  tar -cf - -C "$src" --exclude='./build*' . | tar -xf - -C "$tmp"
fi
if [[ -z "${CMAKE_CXX_COMPILER_LAUNCHER:-}" ]] && command -v ccache > /dev/null; then
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache CCACHE_BASEDIR=$tmp
fi
echo "README recipe, run in a copy of the tree ($tmp):"
echo "$recipe"
start=$(date +%s)
(cd "$tmp" && bash -euo pipefail -c "$recipe")
echo "README recipe passed in $(( $(date +%s) - start )) s"
