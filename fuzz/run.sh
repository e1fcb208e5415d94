#!/usr/bin/env bash
# Runs every libFuzzer target on a copy of its seed corpus (fuzz/corpus/<target>; new inputs go to
# the copy, the seeds in git stay as they are). Usage: fuzz/run.sh BUILD_DIR LIBFUZZER_FLAGS...
# Stops at the first target that finds a crash, hang, leak or sanitizer report (exit code != 0);
# the reproducer is left in BUILD_DIR/fuzz/artifacts/.
set -euo pipefail
build=$1
shift
here="$(cd "$(dirname "$0")" && pwd)"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
mkdir -p "$build/fuzz/artifacts"
for target in npy csv model cli coupled ranges int; do
  work="$build/fuzz/corpus-$target"
  mkdir -p "$work"
  cp -n "$here/corpus/$target/"* "$work/" 2> /dev/null || true
  echo "== fuzz_$target $*"
  rc=0
  "$build/fuzz/fuzz_$target" "$work" -close_fd_mask=3 -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 \
    -artifact_prefix="$build/fuzz/artifacts/$target-" -print_final_stats=1 "$@" > "$build/fuzz/$target.log" 2>&1 || rc=$?
  grep -E "^#[0-9]+[[:space:]]+(INITED|DONE)|^Done|number_of_executed_units|peak_rss_mb|SUMMARY|ERROR|deadly signal|Test unit written" \
    "$build/fuzz/$target.log" || true
  [[ $rc -eq 0 ]] || { echo "fuzz_$target: FAILED, exit code $rc (log $build/fuzz/$target.log)"; exit 1; }
done
# The targets' scratch files (/dev/shm/kfx-fuzz-<pid>, one small input each) are left by libFuzzer's
# exit; remove those of runs that have ended.
for d in /dev/shm/kfx-fuzz-* /tmp/kfx-fuzz-*; do
  [[ -d $d ]] && ! kill -0 "${d##*-}" 2> /dev/null && rm -rf "$d"
done
exit 0
