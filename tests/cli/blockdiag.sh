#!/usr/bin/env bash
# `kfx blockdiag` in one process (no mpirun; tests/mpi/blockdiag_cli.sh runs it under mpirun): with
# U = 0 the block-diagonal filter of decoupled subsystems is the Kalman filter, so its sliced output
# must equal `kfx filter` on the stacked dense model; bad input gives exit code 2 and an error line.
# Usage: blockdiag.sh KFX SOURCE_DIR
set -euo pipefail
kfx=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat > "$tmp/coupled.json" <<'JSON'
{"format": "kfx-coupled-model", "n": 6, "c": 1, "d": 1, "r": 1,
 "F": 0.9, "H": 1, "V": 0.1, "R": 0.5, "G": 1, "U": [[0]], "P0": 1}
JSON
/usr/bin/python3 - "$tmp/dense.json" <<'PY'
import json, sys
I = lambda s: [[s if i == j else 0.0 for j in range(6)] for i in range(6)]
json.dump({"format": "kfx-model", "version": 1, "A": I(0.9), "C": I(1.0), "Q": I(0.1), "R": I(0.5),
           "m0": [0.0] * 6, "P0": I(1.0)}, open(sys.argv[1], "w"))
PY
"$kfx" simulate "$tmp/dense.json" --steps 20 --seed 3 -o "$tmp/sim" > /dev/null
"$kfx" filter "$tmp/dense.json" --data "$tmp/sim/y.npy" -o "$tmp/kf" > /dev/null
"$kfx" blockdiag "$tmp/coupled.json" --data "$tmp/sim/y.npy" -o "$tmp/bd" --granule 2
grep -q '"ranks": 1' "$tmp/bd/metadata.json"
/usr/bin/python3 - "$tmp/kf/x_filt.npy" "$tmp/bd/x_filt.0-6.npy" <<'PY'
import ast, struct, sys
def npy(path):
    b = open(path, "rb").read()
    n = struct.unpack("<H", b[8:10])[0]
    h = ast.literal_eval(b[10:10 + n].decode())
    assert h["descr"] == "<f8" and not h["fortran_order"], h
    return h["shape"], struct.unpack("<%dd" % (len(b[10 + n:]) // 8), b[10 + n:])
(sa, a), (sb, b) = npy(sys.argv[1]), npy(sys.argv[2])
assert sa == sb == (21, 6), (sa, sb)
diff = max(abs(x - y) for x, y in zip(a, b))
print(f"blockdiag vs kfx filter (U = 0): max |difference| = {diff:.3g}")
assert diff < 1e-12
PY
set +e
"$kfx" blockdiag "$tmp/coupled.json" --data "$tmp/dense.json" -o "$tmp/bad" 2> "$tmp/err"
rc=$?
set -e
cat "$tmp/err"
[[ $rc -eq 2 ]] || { echo "FAIL: expected exit code 2, got $rc"; exit 1; }
grep -q "kfx: error.*dense.json" "$tmp/err" || { echo "FAIL: no error line naming dense.json"; exit 1; }
sed 's/"R": 0.5, //' "$tmp/coupled.json" > "$tmp/no_r.json"
set +e
"$kfx" blockdiag "$tmp/no_r.json" --data "$tmp/sim/y.npy" -o "$tmp/bad" 2> "$tmp/err"
rc=$?
set -e
cat "$tmp/err"
[[ $rc -eq 2 ]] || { echo "FAIL: expected exit code 2, got $rc"; exit 1; }
grep -q "field 'R'" "$tmp/err" || { echo "FAIL: no error line naming field 'R'"; exit 1; }
echo "blockdiag (one process): ok"
