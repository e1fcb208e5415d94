#!/usr/bin/env bash
# Every class of bad input: exit code 2 and exactly one line on stderr that names the problem.
# Usage: errors.sh KFX SOURCE_DIR
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

write_model() {  # write_model FILE JSON
  printf '%s\n' "$2" > "$1"
}

expect_error "subcommand" --
expect_error "unknown subcommand 'frobnicate' (expected one of: simulate" -- frobnicate
expect_error "no-such-option" -- simulate "$model" -o "$tmp/x" --no-such-option
expect_error "does-not-exist.json" -- simulate "$tmp/does-not-exist.json" -o "$tmp/x"
expect_error "paper" -- reproduce nonsense-paper
expect_error "steps" -- simulate "$model" -o "$tmp/x" --steps -3

write_model "$tmp/bad_json.json" '{"format": "kfx-model", "version": 1, "A": [[1, 0], [0, 1]'
expect_error "bad_json.json" -- analyze "$tmp/bad_json.json"

write_model "$tmp/missing_a.json" '{"format": "kfx-model", "version": 1, "C": [[1]], "Q": [[1]], "R": [[1]], "m0": [0], "P0": [[1]]}'
expect_error "A" -- analyze "$tmp/missing_a.json"

write_model "$tmp/dims.json" '{"format": "kfx-model", "version": 1, "A": [[1, 1], [0, 1]], "C": [[1, 0, 0]], "Q": [[1, 0], [0, 1]], "R": [[1]], "m0": [0, 0], "P0": [[1, 0], [0, 1]]}'
expect_error "C" -- analyze "$tmp/dims.json"

write_model "$tmp/asym.json" '{"format": "kfx-model", "version": 1, "A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0.5], [0, 1]], "R": [[1]], "m0": [0, 0], "P0": [[1, 0], [0, 1]]}'
expect_error "symmetric" -- analyze "$tmp/asym.json"

write_model "$tmp/indef.json" '{"format": "kfx-model", "version": 1, "A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": [[-1]], "m0": [0, 0], "P0": [[1, 0], [0, 1]]}'
expect_error "R" -- analyze "$tmp/indef.json"

write_model "$tmp/nan.json" '{"format": "kfx-model", "version": 1, "A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": [[1]], "m0": [0, "nan"], "P0": [[1, 0], [0, 1]]}'
expect_error "m0" -- analyze "$tmp/nan.json"

# Data files: wrong shape, truncated .npy, ragged CSV, infinite entries.
"$kfx" simulate "$model" --steps 5 -o "$tmp/sim" > /dev/null || { echo "FAIL: simulate"; fail=1; }
printf '1,2\n3,4\n' > "$tmp/two_cols.csv"
expect_error "y" -- filter "$model" --data "$tmp/two_cols.csv" -o "$tmp/f"
head -c 100 "$tmp/sim/y.npy" > "$tmp/truncated.npy"
expect_error "truncated.npy" -- filter "$model" --data "$tmp/truncated.npy" -o "$tmp/f"
printf '1\n2,3\n' > "$tmp/ragged.csv"
expect_error "ragged.csv" -- filter "$model" --data "$tmp/ragged.csv" -o "$tmp/f"
printf '1\ninf\n' > "$tmp/inf.csv"
expect_error "inf" -- filter "$model" --data "$tmp/inf.csv" -o "$tmp/f"
printf 'x' > "$tmp/data.txt"
expect_error "data.txt" -- filter "$model" --data "$tmp/data.txt" -o "$tmp/f"

exit $fail
