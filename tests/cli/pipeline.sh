#!/usr/bin/env bash
# simulate -> filter -> smooth -> analyze -> reproduce, checking the outputs' shapes and the JSON
# layout that other tools read. Usage: pipeline.sh KFX SOURCE_DIR
set -euo pipefail
kfx=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
model="$src/examples/models/constant_velocity.json"
"$kfx" --version | grep -q '^kfx [0-9]'
"$kfx" --help | grep -q reproduce
"$kfx" simulate "$model" --steps 40 --seed 5 -o "$tmp/sim" > /dev/null
"$kfx" simulate "$model" --steps 40 --seed 5 -o "$tmp/sim2" > /dev/null
cmp "$tmp/sim/y.npy" "$tmp/sim2/y.npy"   # same seed, same bytes
"$kfx" simulate "$model" --steps 40 --seed 5 --csv -o "$tmp/simcsv" > /dev/null
"$kfx" filter "$model" --data "$tmp/sim/y.npy" -o "$tmp/f" > "$tmp/f.txt"
"$kfx" filter "$model" --data "$tmp/simcsv/y.csv" -o "$tmp/fc" > "$tmp/fc.txt"
grep -q "log-likelihood" "$tmp/f.txt"
# CSV data gives the same log-likelihood as .npy data (17 significant digits in CSV).
diff <(grep log-likelihood "$tmp/f.txt") <(grep log-likelihood "$tmp/fc.txt")
"$kfx" smooth "$model" --data "$tmp/sim/y.npy" -o "$tmp/s" > /dev/null 2> "$tmp/s.err"
test ! -s "$tmp/s.err"  # no progress line when stderr is not a terminal
# On a terminal (script(1) gives one) both passes of kfx smooth report progress: the backward pass's
# (done, total) increase to total = 40.
if command -v script > /dev/null; then
  script -qec "'$kfx' smooth '$model' --data '$tmp/sim/y.npy' -o '$tmp/st'" /dev/null > "$tmp/st.txt"
  tr '\r' '\n' < "$tmp/st.txt" | grep -o 'smooth (forward pass): [0-9]*/40' > /dev/null
  tr '\r' '\n' < "$tmp/st.txt" | grep -o 'smooth (backward pass): [0-9]*/40' | sed 's/.*: //; s,/40,,' > "$tmp/bw.txt"
  test "$(tail -n 1 "$tmp/bw.txt")" -eq 40
  sort -n -c "$tmp/bw.txt"
else
  echo "pipeline.sh: script(1) not installed: the terminal progress of kfx smooth not checked"
fi
for f in x_filt P_filt_diag x_pred P_pred_diag innovations; do test -s "$tmp/f/$f.npy"; done
test -s "$tmp/s/x_smooth.npy"
# Missing measurements: blank a value in the CSV and filter again.
awk 'NR==4{$0="nan"}1' "$tmp/simcsv/y.csv" > "$tmp/ymiss.csv"
"$kfx" filter "$model" --data "$tmp/ymiss.csv" -o "$tmp/fm" | grep -q "1 missing"
# Health checks by default (docs/robustness.md, class 8): none on a healthy run; on case (C)
# (Q = 0, R = 1e-12, P0 = 1e6 I) the Joseph form's wrong covariances give one warning naming the
# form to use and "health" in summary.json; the UD form none; --no-health turns the checks off.
"$kfx" filter "$model" --data "$tmp/sim/y.npy" -o "$tmp/fh" > /dev/null 2> "$tmp/fh.err"
test ! -s "$tmp/fh.err"
grep -q '"healthy": true' "$tmp/fh/summary.json"
printf '{"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[0, 0], [0, 0]], "R": [[1e-12]], "m0": [0, 0], "P0": [[1e6, 0], [0, 1e6]]}' > "$tmp/case_c.json"
"$kfx" simulate "$tmp/case_c.json" --steps 3000 --seed 17 -o "$tmp/csim" > /dev/null
"$kfx" filter "$tmp/case_c.json" --data "$tmp/csim/y.npy" -o "$tmp/cj" > /dev/null 2> "$tmp/cj.err"
test "$(wc -l < "$tmp/cj.err")" -eq 1
grep -q "^kfx: warning: .*not positive definite.*--form ud" "$tmp/cj.err"
grep -q '"healthy": false' "$tmp/cj/summary.json"
"$kfx" filter "$tmp/case_c.json" --data "$tmp/csim/y.npy" --form ud -o "$tmp/cu" > /dev/null 2> "$tmp/cu.err"
test ! -s "$tmp/cu.err"
"$kfx" filter "$tmp/case_c.json" --data "$tmp/csim/y.npy" --no-health -o "$tmp/cn" > /dev/null 2> "$tmp/cn.err"
test ! -s "$tmp/cn.err"
if grep -q '"health"' "$tmp/cn/summary.json"; then echo "--no-health wrote health"; exit 1; fi
"$kfx" analyze "$model" --monte-carlo 50 --steps 5 --json "$tmp/a.json" > "$tmp/a.txt"
grep -q "filter gain" "$tmp/a.txt"
grep -q "predictor gain" "$tmp/a.txt"
"$kfx" reproduce all --quick --json "$tmp/r.json" --out "$tmp/figs" > /dev/null
"$kfx" reproduce patel-toda --quick --json "$tmp/one.json" > /dev/null
/usr/bin/python3 - "$tmp" <<'PY'
import json, sys, os
tmp = sys.argv[1]
a = json.load(open(os.path.join(tmp, "a.json")))
assert a["dare"]["status"] == "converged", a["dare"]
assert len(a["filter_gain"]) == 2 and len(a["monte_carlo"]["rows"]) >= 3
allr = json.load(open(os.path.join(tmp, "r.json")))
ids = [p["paper"] for p in allr["papers"]]
assert ids == ["aalto-spatial", "bernstein", "patel-toda", "aalto-temporal", "block-diagonal"], ids
one = json.load(open(os.path.join(tmp, "one.json")))
assert list(one.keys()) == ["paper", "items", "figures"], one.keys()
assert one["paper"] == "patel-toda"
for p in allr["papers"] + [one]:
    for it in p["items"]:
        assert set(it) == {"key", "description", "published", "value", "rel_diff", "status"}, it
        assert it["status"] in ("reproduced", "differs", "new")
print("pipeline ok")
PY
