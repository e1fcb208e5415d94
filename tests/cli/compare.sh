#!/usr/bin/env bash
# `kfx filter --method` and `kfx compare` (docs/cli.md): `--method kalman` is today's `kfx filter`, byte for
# byte; `--method blockdiag` equals `kfx blockdiag` on the same data; compare's Kalman row is the DARE's
# and every other row is at least it; its JSON and --out files; every bad spec is one error line, exit 2.
# Usage: compare.sh KFX SOURCE_DIR
set -euo pipefail
kfx=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
chain="$src/examples/models/mass_spring_chain.json"
coupled="$src/examples/coupled/model.json"
"$kfx" simulate "$chain" --steps 50 --seed 2 -o "$tmp/sim" > /dev/null
"$kfx" filter "$chain" --data "$tmp/sim/y.npy" -o "$tmp/kf" > /dev/null
"$kfx" filter "$chain" --method kalman:form=joseph --data "$tmp/sim/y.npy" -o "$tmp/kf_method" > /dev/null
for f in x_filt x_pred P_filt_diag innovations; do cmp "$tmp/kf/$f.npy" "$tmp/kf_method/$f.npy"; done
"$kfx" filter "$chain" --method tau:order=4,step=two-da --data "$tmp/sim/y.npy" -o "$tmp/tau" > /dev/null
grep -q '"method": "tau:order=4,step=two-da"' "$tmp/tau/summary.json"
"$kfx" filter "$coupled" --method blockdiag --data "$src/examples/coupled/y.npy" -o "$tmp/bd_method" > /dev/null
"$kfx" blockdiag "$coupled" --data "$src/examples/coupled/y.npy" -o "$tmp/bd" > /dev/null
"$kfx" compare "$chain" --stationary --method kalman --method steady --method tau:order=4 \
  --method "subspace61:basis=$tmp/E.npy" --json "$tmp/cmp.json" 2> "$tmp/err" && exit 1  # E.npy is not there yet
grep -q "method 'subspace61:basis=$tmp/E.npy': basis: " "$tmp/err"
/usr/bin/python3 - "$tmp" <<'PY'
import sys
import numpy as np  # Debian's python3-numpy (the Makefile's dependencies)
d = sys.argv[1]
a, b = np.load(d + "/bd_method/x_filt.npy"), np.load(d + "/bd/x_filt.0-6.npy")
assert a.shape == b.shape == (201, 12), (a.shape, b.shape)
diff = np.abs(a - b).max()
print(f"filter --method blockdiag vs kfx blockdiag: max |difference| = {diff:.3g}")
assert diff < 1e-12
assert np.load(d + "/tau/x_filt.npy").shape == (51, 8)
# a 3-column basis of the chain's positions, for the next step
np.save(d + "/E.npy", np.eye(8)[:, :3])
PY
"$kfx" compare "$chain" --stationary --method kalman --method steady --method tau:order=4 \
  --method "subspace61:basis=$tmp/E.npy" --json "$tmp/cmp.json" --out "$tmp/out" > "$tmp/table.txt"
cat "$tmp/table.txt"
test -s "$tmp/out/compare_rows.csv" && test -s "$tmp/out/compare_curves.csv" && test -s "$tmp/out/compare.json"
# The figures, where matplotlib is installed (make test installs it): both drawn, no "not drawn" message.
if /usr/bin/python3 -c "import matplotlib" 2> /dev/null; then
  test -s "$tmp/out/compare_pareto.png" && test -s "$tmp/out/compare_error_vs_time.png"
  ! grep -q "not drawn" "$tmp/table.txt"
fi
/usr/bin/python3 - "$tmp/cmp.json" <<'PY'
import json, sys
c = json.load(open(sys.argv[1]))
ref = c["kalman_stationary_mse"]
rows = {r["method"]: r for r in c["rows"]}
assert abs(rows["kalman"]["stationary_mse"] - ref) <= 1e-8 * ref, (rows["kalman"], ref)
assert abs(rows["steady"]["stationary_mse"] - ref) <= 1e-8 * ref
assert rows["tau:order=4"]["stationary_mse"] is None and rows["tau:order=4"]["stationary_note"]
for r in c["rows"]:
    assert r["mse"] >= c["kalman_final_mse"] * (1 - 1e-9), r
    if r["stationary_mse"] is not None:
        assert r["stationary_mse"] >= ref * (1 - 1e-9), r
print("compare: Kalman row = DARE", ref, "; every row >= it")
PY
fail() {  # fail EXPECTED_TEXT ARGS...: exit code 2 and one line naming EXPECTED_TEXT
  local want=$1
  shift
  set +e
  "$kfx" "$@" > /dev/null 2> "$tmp/err"
  local rc=$?
  set -e
  [[ $rc -eq 2 ]] || { echo "expected exit 2, got $rc: $*"; exit 1; }
  [[ $(wc -l < "$tmp/err") -eq 1 ]] || { echo "expected one line: $*"; cat "$tmp/err"; exit 1; }
  grep -qF -- "$want" "$tmp/err" || { echo "expected '$want' in:"; cat "$tmp/err"; exit 1; }
}
fail "method 'tau:order=9': order 9 is larger than the state dimension 8" compare "$chain" --method tau:order=9
fail "method 'blockdiag': blockdiag needs a coupled model" compare "$chain" --method blockdiag
fail "method 'kalmann': unknown method" compare "$chain" --method kalmann
fail "method 'tau:ordr=2': unknown parameter 'ordr'" filter "$chain" --method tau:ordr=2 --data "$tmp/sim/y.npy" -o "$tmp/x"
fail "weight: " compare "$chain" --method steady --weight "$tmp/E.npy"
echo "compare.sh: ok"
