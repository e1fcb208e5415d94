#!/usr/bin/env bash
# Issue 20 (part A): the hostile-input classes the CLI used to get wrong, one block per class; every case
# is an exit code 2 with one stderr line naming the problem, or a run whose output is checked.
#   3 zero dimensions   4 non-finite results   5 output directories   6 integer options
#   7 CSV rules         11 FIFOs and other non-regular files
# Usage: hostile_inputs.sh KFX SOURCE_DIR
set -u
kfx=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
model="$src/examples/models/constant_velocity.json"

expect_error() {  # expect_error PATTERN -- ARGS...   (a 20 s limit: a blocked read is a failure, not a hang)
  local pattern=$1
  shift 2
  timeout 20 "$kfx" "$@" > "$tmp/out" 2> "$tmp/err" < /dev/null
  local rc=$?
  local lines
  lines=$(wc -l < "$tmp/err")
  if [[ $rc -ne 2 || $lines -ne 1 ]] || ! grep -q -- "$pattern" "$tmp/err" || grep -qi "illegal value" "$tmp/out"; then
    echo "FAIL: kfx $* -> rc $rc, $lines stderr lines, expected rc 2 and one line matching '$pattern':"
    cat "$tmp/err" "$tmp/out"
    fail=1
  else
    echo "ok: kfx $*: $(cat "$tmp/err")"
  fi
}
check() {  # check DESCRIPTION COMMAND...
  if "${@:2}"; then echo "ok: $1"; else echo "FAIL: $1"; fail=1; fi
}
npy() {  # npy FILE SHAPE DESCR: an all-zero .npy of the shape (a Python tuple) written with the header only
  python3 - "$1" "$2" "$3" <<'PY'
import struct, sys
path, shape, descr = sys.argv[1], sys.argv[2], sys.argv[3]
dims = [int(s) for s in shape.strip("()").split(",") if s.strip()]
count = 1
for d in dims: count *= d
header = "{'descr': '%s', 'fortran_order': False, 'shape': %s, }" % (descr, shape)
header += " " * (118 - len(header)) + "\n"
open(path, "wb").write(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode() + b"\0" * (8 * count))
PY
}
"$kfx" simulate "$model" -o "$tmp/sim" --steps 20 > /dev/null || { echo "FAIL: simulate"; exit 1; }
data="$tmp/sim/y.npy"

# ---- 3: zero dimensions: (0, 0) arrays in a model file, and an empty C, rejected by every command ----------
for f in A Q P0; do npy "$tmp/$f.npy" "(0, 0)" "<f8"; done
npy "$tmp/C.npy" "(1, 0)" "<f8"
npy "$tmp/m0.npy" "(0,)" "<f8"
cat > "$tmp/zero.json" <<'J'
{"format": "kfx-model", "version": 1, "A": {"npy": "A.npy"}, "C": {"npy": "C.npy"}, "Q": {"npy": "Q.npy"},
 "R": [[1]], "m0": {"npy": "m0.npy"}, "P0": {"npy": "P0.npy"}}
J
cat > "$tmp/zero_m.json" <<'J'
{"format": "kfx-model", "version": 1, "A": [[1]], "C": [], "Q": [[1]], "R": [], "m0": [0], "P0": [[1]]}
J
for cmd in "simulate -o $tmp/z" "filter --data $data -o $tmp/z" "smooth --data $data -o $tmp/z"; do
  # shellcheck disable=SC2086
  expect_error "'A': expected at least one state" -- ${cmd%% *} "$tmp/zero.json" ${cmd#* }
done
expect_error "zero.json\|A: expected at least one state" -- analyze "$tmp/zero.json"
expect_error "C\|m = 0\|expected" -- simulate "$tmp/zero_m.json" -o "$tmp/z"

# ---- 4: non-finite results: Q = 1e308 simulates finite numbers; a diverging model is an error -------------
cat > "$tmp/huge_q.json" <<'J'
{"format": "kfx-model", "version": 1, "A": [[0.5]], "C": [[1]], "Q": [[1e308]], "R": [[1]], "m0": [0], "P0": [[1]]}
J
cat > "$tmp/diverging.json" <<'J'
{"format": "kfx-model", "version": 1, "A": [[10]], "C": [[1]], "Q": [[1]], "R": [[1]], "m0": [1], "P0": [[1]]}
J
"$kfx" simulate "$tmp/huge_q.json" -o "$tmp/huge" --steps 50 --csv > /dev/null 2> "$tmp/err"
check "simulate Q = 1e308: exit 0, finite" bash -c "! grep -qi 'inf\|nan' '$tmp/huge/x.csv' '$tmp/huge/y.csv' && test -s '$tmp/huge/summary.json'"
expect_error "not finite at step" -- simulate "$tmp/diverging.json" -o "$tmp/div" --steps 400
check "diverging simulate: nothing written" test ! -e "$tmp/div/x.npy"

# ---- 5: output directories: a failed run leaves no completion marker beside old files ----------------------
"$kfx" filter "$model" --data "$data" -o "$tmp/f" > /dev/null
check "filter writes summary.json" test -s "$tmp/f/summary.json"
rm "$tmp/f/P_pred_diag.npy" && mkdir -p "$tmp/f/P_pred_diag.npy/occupied"  # the 4th output cannot be written
expect_error "P_pred_diag.npy" -- filter "$model" --data "$data" -o "$tmp/f"
check "failed filter: the old summary.json is gone" test ! -e "$tmp/f/summary.json"
"$kfx" simulate "$model" -o "$tmp/s" --steps 10 > /dev/null
rm "$tmp/s/y.npy" && mkdir -p "$tmp/s/y.npy/occupied"
expect_error "y.npy" -- simulate "$model" -o "$tmp/s" --steps 30
check "failed simulate: no summary.json beside the new x.npy" test ! -e "$tmp/s/summary.json"
"$kfx" smooth "$model" --data "$data" -o "$tmp/f2" > /dev/null
check "smooth: summary.json lists its files" grep -q x_smooth "$tmp/f2/summary.json"

# ---- 6: integer options: negative, huge, fractional values name the option ---------------------------------
expect_error "--seed" -- simulate "$model" -o "$tmp/x" --seed -1
expect_error "--seed" -- simulate "$model" -o "$tmp/x" --seed 18446744073709551616
expect_error "--seed" -- simulate "$model" -o "$tmp/x" --seed 1e23
expect_error "--steps" -- simulate "$model" -o "$tmp/x" --steps 99999999999
expect_error "--monte-carlo" -- analyze "$model" --monte-carlo -5
expect_error "--steps" -- analyze "$model" --steps 2.5
expect_error "--seed" -- analyze "$model" --seed -5
expect_error "--granule" -- blockdiag "$model" --data "$data" -o "$tmp/x" --granule -1
expect_error "--steps" -- blockdiag "$model" --data "$data" -o "$tmp/x" --steps 4294967296

# ---- 7: CSV rules -------------------------------------------------------------------------------------------
printf '1\r2\r3\r4\r' > "$tmp/cr.csv"
"$kfx" filter "$model" --data "$tmp/cr.csv" -o "$tmp/cr" > "$tmp/out"
check "CR-only CSV: 4 steps" grep -q "filtered 4 steps" "$tmp/out"
printf '1e999\n1\n2\n' > "$tmp/h1.csv"
expect_error "line 1, column 1" -- filter "$model" --data "$tmp/h1.csv" -o "$tmp/x"
printf '0x10\n1\n2\n' > "$tmp/h2.csv"
expect_error "line 1, column 1" -- filter "$model" --data "$tmp/h2.csv" -o "$tmp/x"
printf 'y\n1\n\n3\n' > "$tmp/blank.csv"
"$kfx" filter "$model" --data "$tmp/blank.csv" -o "$tmp/bl" > "$tmp/out"
check "blank line in a one-column CSV: a missing value in its row" grep -q "filtered 3 steps.*1 missing" "$tmp/out"
printf 'a;b\n1;2\n' > "$tmp/semi.csv"
expect_error "line 1, column 1" -- filter "$model" --data "$tmp/semi.csv" -o "$tmp/x"
printf '1;2\n3;4\n' > "$tmp/semi2.csv"
expect_error "line 1, column 1.*separated" -- filter "$model" --data "$tmp/semi2.csv" -o "$tmp/x"
printf 'y\n' > "$tmp/none.csv"
expect_error "no data rows" -- filter "$model" --data "$tmp/none.csv" -o "$tmp/x"
printf '1\n2,3\n' > "$tmp/ragged.csv"
expect_error "line 2, column 2" -- filter "$model" --data "$tmp/ragged.csv" -o "$tmp/x"

# ---- 11: FIFOs as model file, referenced .npy and --data: an error, not a blocked read ----------------------
mkfifo "$tmp/model_fifo.json" "$tmp/data_fifo.npy" "$tmp/data_fifo.csv" "$tmp/A_fifo.npy"
cat > "$tmp/fifo_ref.json" <<'J'
{"format": "kfx-model", "version": 1, "A": {"npy": "A_fifo.npy"}, "C": [[1]], "Q": [[1]], "R": [[1]], "m0": [0], "P0": [[1]]}
J
expect_error "FIFO" -- filter "$tmp/model_fifo.json" --data "$data" -o "$tmp/x"
expect_error "FIFO" -- filter "$model" --data "$tmp/data_fifo.npy" -o "$tmp/x"
expect_error "FIFO" -- filter "$model" --data "$tmp/data_fifo.csv" -o "$tmp/x"
expect_error "FIFO" -- simulate "$tmp/fifo_ref.json" -o "$tmp/x"
expect_error "FIFO" -- analyze "$tmp/model_fifo.json"

exit $fail
