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
# --steady-state-tolerance: coupled subsystems (U > 0), 200 steps; after the freeze the estimates equal the
# running filter's to 1e-10 (relative), and metadata.json counts the steps on the frozen gain.
sed 's/"U": \[\[0\]\]/"U": [[0.4]]/' "$tmp/coupled.json" > "$tmp/coupled_u.json"
"$kfx" simulate "$tmp/dense.json" --steps 200 --seed 5 -o "$tmp/sim200" > /dev/null
"$kfx" blockdiag "$tmp/coupled_u.json" --data "$tmp/sim200/y.npy" -o "$tmp/run" > /dev/null
"$kfx" blockdiag "$tmp/coupled_u.json" --data "$tmp/sim200/y.npy" -o "$tmp/steady" --steady-state-tolerance 1e-12 \
  | tee "$tmp/steady.txt"
grep -q "steps on the frozen gain" "$tmp/steady.txt" || { echo "FAIL: no steady-state line"; exit 1; }
/usr/bin/python3 - "$tmp/run" "$tmp/steady" <<'PY'
import ast, json, struct, sys
def npy(path):
    b = open(path, "rb").read()
    n = struct.unpack("<H", b[8:10])[0]
    h = ast.literal_eval(b[10:10 + n].decode())
    return h["shape"], struct.unpack("<%dd" % (len(b[10 + n:]) // 8), b[10 + n:])
run, steady = sys.argv[1], sys.argv[2]
meta_r, meta_s = (json.load(open(d + "/metadata.json")) for d in (run, steady))
frozen = meta_s["steady_state_steps"]
assert meta_r["steady_state_steps"] == 0 and 0 < frozen < 200, (meta_r, meta_s)
assert meta_s["steady_state_tolerance"] == 1e-12
(sa, a), (sb, b) = npy(run + "/x_filt.0-6.npy"), npy(steady + "/x_filt.0-6.npy")
assert sa == sb == (201, 6), (sa, sb)
after = slice((201 - frozen) * 6, 201 * 6)
scale = max(abs(v) for v in a[after])
diff = max(abs(x - y) for x, y in zip(a[after], b[after]))
print(f"blockdiag --steady-state-tolerance: {frozen} frozen steps, max |difference| = {diff / scale:.3g} (relative)")
assert diff <= 1e-10 * scale
PY
for bad in "--steady-state-tolerance 0.5" "--steady-state-tolerance 1e-10 --filter banded"; do
  set +e
  # shellcheck disable=SC2086
  "$kfx" blockdiag "$tmp/coupled_u.json" --data "$tmp/sim200/y.npy" -o "$tmp/bad" $bad 2> "$tmp/err"
  rc=$?
  set -e
  cat "$tmp/err"
  [[ $rc -eq 2 ]] || { echo "FAIL: $bad: expected exit code 2, got $rc"; exit 1; }
  grep -qi "steady.state.tolerance" "$tmp/err" || { echo "FAIL: $bad: no error line naming the option"; exit 1; }
done
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
