#!/usr/bin/env bash
# `mpirun -np N kfx blockdiag` at N = 1, 2, 4 and plain `kfx blockdiag`: the same states (1e-13), and
# the same as the serial RunCoupledFilter (1e-10); bad input gives exit code 2 and one line per rank.
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
echo "blockdiag CLI: ok"
