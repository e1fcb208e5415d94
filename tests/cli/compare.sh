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
# A continuous-time model file (paper 003): simulate, filter and compare read it as its exact discrete
# equivalent at its dt; sampled:dt=0.05 (its own dt) is the Kalman filter; every sampled row is at least the
# Kalman filter's, which is at least the Kalman-Bucy filter's.
osc="$src/examples/continuous/oscillator.json"
"$kfx" simulate "$osc" --steps 40 --seed 3 -o "$tmp/osc_sim" > /dev/null
"$kfx" filter "$osc" --data "$tmp/osc_sim/y.npy" -o "$tmp/osc_kf" > /dev/null
"$kfx" filter "$osc" --method sampled:dt=0.05 --data "$tmp/osc_sim/y.npy" -o "$tmp/osc_s1" > /dev/null
"$kfx" filter "$osc" --method sampled:dt=0.2 --data "$tmp/osc_sim/y.npy" -o "$tmp/osc_s4" > /dev/null
"$kfx" compare "$osc" --steps 40 --method kalman --method sampled:dt=0.1 --method sampled:dt=0.4,gain=steady \
  --json "$tmp/osc.json" > /dev/null
/usr/bin/python3 - "$tmp" <<'PY'
import json, sys
import numpy as np
d = sys.argv[1]
a, b, c = (np.load(f"{d}/{x}/x_filt.npy") for x in ("osc_kf", "osc_s1", "osc_s4"))
assert a.shape == b.shape == c.shape == (41, 4), (a.shape, b.shape, c.shape)
assert np.abs(a[:, :2] - b[:, :2]).max() < 1e-12  # z = the first p columns
assert np.all(c[:, 2:] == 0)  # the sampled filter forms no estimate of the step integral
j = json.load(open(f"{d}/osc.json"))
assert j["kalman_bucy_mse"] < j["kalman_final_mse"] and j["kalman_bucy_stationary_mse"] < j["kalman_stationary_mse"], j
for r in j["rows"]:
    assert r["mse"] >= j["kalman_final_mse"] * (1 - 1e-10), r
print("continuous model: Kalman-Bucy", j["kalman_bucy_mse"], "<= Kalman", j["kalman_final_mse"], "<= every row")
PY
fail "method 'sampled:dt=0': dt: expected a finite number > 0" compare "$osc" --method sampled:dt=0
fail "method 'sampled:dt=0.07': dt=0.07 is not a positive integer multiple" compare "$osc" --method sampled:dt=0.07
fail "method 'sampled:0.1': sampled needs a continuous-time model" compare "$chain" --method sampled:0.1
fail "method 'subspace:mesh=2': mesh=2: the meshes are not nested" compare "$chain" --method subspace:mesh=2
sed 's/"dt": 0.05/"dt": -1/' "$osc" > "$tmp/osc_bad.json"
fail "osc_bad.json: field 'dt': expected a finite number > 0" compare "$tmp/osc_bad.json" --method kalman
fail "osc_bad.json: field 'dt': expected a finite number > 0" filter "$tmp/osc_bad.json" --data "$tmp/osc_sim/y.npy" -o "$tmp/x"
echo "compare.sh: ok"
