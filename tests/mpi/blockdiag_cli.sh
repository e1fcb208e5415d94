#!/usr/bin/env bash
# `mpirun -np N kfx blockdiag` at N = 1, 2, 4 and plain `kfx blockdiag`: the same states (1e-13), and
# the same as the serial RunCoupledFilter (1e-10); bad input gives exit code 2 and one line for the job.
# Issue 20: fewer subsystems than the granule and than the ranks (class 1), one rank that cannot write
# (class 2: every rank ends, one message, no metadata.json), missing measurements (class 14).
# Usage: blockdiag_cli.sh KFX CHECK MPIEXEC WORKDIR
set -euo pipefail
KFX=$1 CHECK=$2 MPIEXEC=$3 W=$4
rm -rf "$W" && mkdir -p "$W"
"$CHECK" make-model "$W"
for filter in block-diagonal banded; do
  "$KFX" blockdiag "$W/model.json" --data "$W/y.npy" -o "$W/$filter-plain" --filter "$filter" --granule 4
  for np in 1 2 4; do
    "$MPIEXEC" -np $np "$KFX" blockdiag "$W/model.json" --data "$W/y.npy" -o "$W/$filter-np$np" \
      --filter "$filter" --granule 4 > "$W/$filter-np$np.log"
    cat "$W/$filter-np$np.log"
    grep -q "$np rank" "$W/$filter-np$np.log"
    test "$(ls "$W/$filter-np$np"/x_filt.*.npy | wc -l)" -eq $np
    "$CHECK" compare "$W/$filter-np$np" "$W/$filter-plain"
  done
  "$CHECK" check-serial "$W/$filter-np2" "$W/model.json" "$W/y.npy" "$filter"
done
test -s "$W/block-diagonal-np4/coupling_mean.npy"
# A measurement file with the wrong number of columns: exit code 2, an error line, no hang.
python3 - "$W/bad.npy" <<'PY'
import struct, sys
header = "{'descr': '<f8', 'fortran_order': False, 'shape': (0, 7), }"
header += " " * (118 - len(header)) + "\n"
open(sys.argv[1], "wb").write(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode())
PY
set +e
"$MPIEXEC" -np 2 "$KFX" blockdiag "$W/model.json" --data "$W/bad.npy" -o "$W/bad" 2> "$W/bad.err"
code=$?
set -e
cat "$W/bad.err"
[[ $code -ne 0 ]] || { echo "FAIL: expected a non-zero exit code"; exit 1; }
grep -q "kfx: error (rank 0): .*bad.npy: expected measurements of shape" "$W/bad.err" || { echo "FAIL: error line"; exit 1; }

# Class 1: n = 1 and n = 3 subsystems (fewer than the default granule 1024 and, at np 4, than the ranks),
# both filters, with and without missing measurements (class 14): the plain run's states, and the serial ones.
for n in 1 3; do
  for missing in "" missing; do
    M="$W/few$n$missing"
    "$CHECK" make-model "$M" $n $missing
    for filter in block-diagonal banded; do
      "$KFX" blockdiag "$M/model.json" --data "$M/y.npy" -o "$M/$filter-plain" --filter "$filter"
      "$CHECK" check-serial "$M/$filter-plain" "$M/model.json" "$M/y.npy" "$filter"
      for np in 2 4; do
        timeout 120 "$MPIEXEC" -np $np "$KFX" blockdiag "$M/model.json" --data "$M/y.npy" -o "$M/$filter-np$np" \
          --filter "$filter" > "$M/$filter-np$np.log"
        "$CHECK" compare "$M/$filter-np$np" "$M/$filter-plain"
      done
    done
  done
done

# Class 2: rank 1's slice cannot be written (its name is a directory) after a complete earlier run in the
# same directory: every rank ends (no hang), exit code != 0, one error line, and the directory is visibly
# incomplete (the earlier metadata.json is gone).
"$MPIEXEC" -np 2 "$KFX" blockdiag "$W/model.json" --data "$W/y.npy" -o "$W/fail" --granule 4 > /dev/null
test -s "$W/fail/metadata.json"
slice1=$(ls "$W/fail"/x_filt.*.npy | grep -v "x_filt\.0-" | head -1)
rm -f "$slice1" && mkdir -p "$slice1/occupied" && touch "$slice1/occupied/file"
set +e
timeout 120 "$MPIEXEC" -np 2 "$KFX" blockdiag "$W/model.json" --data "$W/y.npy" -o "$W/fail" --granule 4 \
  > "$W/fail.out" 2> "$W/fail.err"
code=$?
set -e
cat "$W/fail.err"
[[ $code -ne 0 && $code -ne 124 ]] || { echo "FAIL: rank failure: exit code $code (124: hang)"; exit 1; }
[[ $(grep -c "kfx: error" "$W/fail.err") -eq 1 ]] || { echo "FAIL: expected one error line"; exit 1; }
grep -q "x_filt" "$W/fail.err" || { echo "FAIL: the error line does not name the slice"; exit 1; }
[[ ! -e "$W/fail/metadata.json" ]] || { echo "FAIL: metadata.json of an incomplete run"; exit 1; }
echo "blockdiag CLI: ok"
