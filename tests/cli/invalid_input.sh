#!/usr/bin/env bash
# The classes of invalid input not covered by errors.sh (issue 11): wrong JSON types, NaN/Inf and
# non-symmetric / indefinite covariances in every role, wrongly typed or malformed .npy, missing
# files, bad option values; each must give exit code 2 and one stderr line naming the problem.
# Also: outputs are written atomically (no temporary or partial files after success or failure).
# Usage: invalid_input.sh KFX SOURCE_DIR
set -u
kfx=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
model="$src/examples/models/constant_velocity.json"

expect_error() {  # expect_error PATTERN -- ARGS...
  local pattern=$1
  shift 2
  "$kfx" "$@" > "$tmp/out" 2> "$tmp/err"
  local rc=$?
  local lines
  lines=$(wc -l < "$tmp/err")
  if [[ $rc -ne 2 || $lines -ne 1 ]] || ! grep -q -- "$pattern" "$tmp/err"; then
    echo "FAIL: kfx $* -> rc $rc, $lines stderr lines, expected rc 2 and one line matching '$pattern':"
    cat "$tmp/err"
    fail=1
  else
    echo "ok: kfx $*: $(cat "$tmp/err")"
  fi
}

good='"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": [[1]], "m0": [0, 0], "P0": [[1, 0], [0, 1]]'
model_with() {  # model_with NAME FIELD VALUE: the good model with FIELD replaced
  python3 - "$tmp/$1.json" "$2" "$3" "$good" <<'PY'
import json, sys
path, field, value, good = sys.argv[1:]
m = {"format": "kfx-model", "version": 1}
m.update(json.loads("{" + good + "}"))
m[field] = json.loads(value)
open(path, "w").write(json.dumps(m))
PY
  echo "$tmp/$1.json"
}

# Wrong JSON types.
expect_error "A" -- analyze "$(model_with a_string A '"identity"')"
expect_error "m0" -- analyze "$(model_with m0_object m0 '{"x": 1}')"
expect_error "version" -- analyze "$(model_with version_string version '"one"')"
expect_error "R" -- analyze "$(model_with r_bool R 'true')"
expect_error "C" -- analyze "$(model_with c_strings C '[["1", "0"]]')"
printf '[1, 2, 3]\n' > "$tmp/array.json"
expect_error "array.json" -- analyze "$tmp/array.json"
# NaN / Inf in matrices, non-symmetric and indefinite covariances.
expect_error "A" -- analyze "$(model_with a_nan A '[[1, "nan"], [0, 1]]')"
expect_error "Q" -- analyze "$(model_with q_inf Q '[["inf", 0], [0, 1]]')"
expect_error "P0" -- analyze "$(model_with p0_asym P0 '[[1, 0.5], [0, 1]]')"
expect_error "P0" -- analyze "$(model_with p0_indef P0 '[[1, 2], [2, 1]]')"
expect_error "Q" -- analyze "$(model_with q_indef Q '[[-1, 0], [0, 1]]')"
printf '{"A": [[1]], "C": [[1], [1]], "Q": [[1]], "R": [[1, 0.3], [0, 1]], "m0": [0], "P0": [[1]]}' > "$tmp/r_asym.json"
expect_error "R" -- analyze "$tmp/r_asym.json"
# A referenced .npy file that is missing.
expect_error "missing.npy" -- analyze "$(model_with a_missing_npy A '{"npy": "missing.npy"}')"
# Missing data file; wrongly typed, malformed and wrongly shaped .npy data.
expect_error "no-such-data.npy" -- filter "$model" --data "$tmp/no-such-data.npy" -o "$tmp/f"
"$kfx" simulate "$model" --steps 5 -o "$tmp/sim" > /dev/null || { echo "FAIL: simulate"; fail=1; }
LC_ALL=C sed 's/<f8/<c8/' "$tmp/sim/y.npy" > "$tmp/complex.npy"
expect_error "complex.npy" -- filter "$model" --data "$tmp/complex.npy" -o "$tmp/f"
LC_ALL=C sed 's/<f8/<U2/' "$tmp/sim/y.npy" > "$tmp/unicode.npy"
expect_error "unicode.npy" -- filter "$model" --data "$tmp/unicode.npy" -o "$tmp/f"
printf 'NUMPY not really' > "$tmp/magic.npy"
expect_error "magic.npy" -- filter "$model" --data "$tmp/magic.npy" -o "$tmp/f"
LC_ALL=C sed 's/(5, 1)/(5, 2)/' "$tmp/sim/y.npy" > "$tmp/short.npy"
expect_error "short.npy" -- filter "$model" --data "$tmp/short.npy" -o "$tmp/f"
LC_ALL=C sed "s/'fortran_order': False/'fortran_order': 'no'/" "$tmp/sim/y.npy" > "$tmp/header.npy"
expect_error "header.npy" -- filter "$model" --data "$tmp/header.npy" -o "$tmp/f"
printf 'nan\n' > "$tmp/nan_only.csv"
"$kfx" filter "$model" --data "$tmp/nan_only.csv" -o "$tmp/nan_ok" > /dev/null 2>&1 || { echo "FAIL: an all-missing row is valid"; fail=1; }
# Bad option values and missing required options.
expect_error "steps" -- simulate "$model" -o "$tmp/x" --steps abc
expect_error "form" -- filter "$model" --data "$tmp/sim/y.npy" -o "$tmp/f" --form kalman
expect_error "data" -- filter "$model" -o "$tmp/f"
expect_error "seed" -- analyze "$model" --seed -1x
# Output that cannot be written: -o names a regular file.
touch "$tmp/a_file"
expect_error "a_file" -- filter "$model" --data "$tmp/sim/y.npy" -o "$tmp/a_file"

# Atomic output: a successful run leaves no temporary file; a failed write leaves the old file.
"$kfx" filter "$model" --data "$tmp/sim/y.npy" -o "$tmp/ok" --form sqrt --health > /dev/null || { echo "FAIL: filter --form sqrt"; fail=1; }
if ls "$tmp/ok" | grep -q 'tmp-'; then echo "FAIL: temporary files left in $tmp/ok"; fail=1; else echo "ok: no temporary files after success"; fi
grep -q '"health"' "$tmp/ok/summary.json" || { echo "FAIL: summary.json has no health section"; fail=1; }
mkdir -p "$tmp/blocked" && mkdir "$tmp/blocked/x_filt.npy"
expect_error "x_filt.npy" -- filter "$model" --data "$tmp/sim/y.npy" -o "$tmp/blocked"
if ls "$tmp/blocked" | grep -q 'tmp-\|summary.json'; then echo "FAIL: partial output in $tmp/blocked"; fail=1; else echo "ok: nothing left after a failed write"; fi

exit $fail
