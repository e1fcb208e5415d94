#!/usr/bin/env bash
# kfx mismatch: the robustness report on the paper-002 example (plant and noise error ranges), its
# JSON, bad ranges files (exit 2, one line naming the field), and `kfx reproduce patel-toda`.
# Usage: mismatch.sh KFX SOURCE_DIR
set -u
kfx=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
model="$src/examples/models/patel_toda.json"
check() {  # check DESCRIPTION COMMAND...
  local what=$1
  shift
  if "$@"; then echo "ok: $what"; else echo "FAIL: $what"; fail=1; fi
}

"$kfx" mismatch "$model" --ranges "$src/examples/ranges/patel_toda_ranges.json" --json "$tmp/plant.json" > "$tmp/plant.txt"
check "plant ranges: exit 0" test $? -eq 0
check "plant ranges: Theorem 5 and 6 bounds" grep -q "pi5: tr P" "$tmp/plant.txt"
check "plant ranges: Theorem 6" grep -q "pi6: tr P_F" "$tmp/plant.txt"
check "plant ranges: no Theorem 3" bash -c "! grep -q 'pi3:' '$tmp/plant.txt'"
check "plant ranges: worst case located" grep -q "max tr P = .* at dA(1,1)" "$tmp/plant.txt"
check "plant ranges: JSON" grep -q '"least_upper"' "$tmp/plant.json"

"$kfx" mismatch "$model" --ranges "$src/examples/ranges/patel_toda_noise_ranges.json" > "$tmp/noise.txt"
check "noise ranges: exit 0" test $? -eq 0
check "noise ranges: Theorems 3 and 4" grep -q "pi4: tr P_F" "$tmp/noise.txt"

# Issue 22: the truth's cross-covariance S (range) and an unmodelled input: the bounds that do not hold are
# refused, saying why; the box search is not run.
printf '{"S": [[0.5], [0.0]]}\n' > "$tmp/s.json"
"$kfx" mismatch "$model" --ranges "$tmp/s.json" --json "$tmp/s_out.json" > "$tmp/s.txt"
check "S range: exit 0" test $? -eq 0
check "S range: Theorem 3 with its S term" grep -q "pi3: tr P" "$tmp/s.txt"
check "S range: pi4, pi5, pi6 refused" test "$(grep -c '^  refused pi[456]: the truth has a cross-covariance S' "$tmp/s.txt")" -eq 3
check "S range: no box search" grep -q "not searched" "$tmp/s.txt"
check "S range: JSON refused" grep -q '"refused"' "$tmp/s_out.json"
check "S range: its size in the header" grep -q '|dS| <= 0.5 ' "$tmp/s.txt"
check "S range: no ratio to an unsearched box (no nan)" bash -c "! grep -qi 'nan' '$tmp/s.txt'"
check "S range: no free-entry count of an unsearched box" bash -c "! grep -q 'free entries' '$tmp/s.txt'"
check "plant ranges: free entries and ratios printed" bash -c "grep -q 'free entries' '$tmp/plant.txt' && grep -q 'ratio min tr P_F to it' '$tmp/plant.txt'"
printf '{"Q": 1.0, "unmodelled_input": true}\n' > "$tmp/input.json"
"$kfx" mismatch "$model" --ranges "$tmp/input.json" > "$tmp/input.txt"
check "unmodelled input: exit 0" test $? -eq 0
check "unmodelled input: pi3 refused" grep -q "^  refused pi3: the truth has a known input" "$tmp/input.txt"
check "unmodelled input: pi4 holds" grep -q "pi4: tr P_F" "$tmp/input.txt"

# A design with its own S (the 002 example with cov(w, v) = 3): its filter is the correlated steady-state filter,
# whose true error on the design itself is its own tr P_filt; the engine agrees; both extremes are searched.
printf '{"format": "kfx-model", "version": 1, "A": [[-0.3333333333333333, 0.0], [0.1, -0.25]], "B": [[1.0], [0.0]],
 "U": [[10.0]], "C": [[1.0, 0.0]], "R": [[5.0]], "S": [[3.0], [0.0]], "m0": [0.0, 0.0], "P0": [[10.0, 0.0], [0.0, 10.0]]}\n' \
  > "$tmp/design_s.json"
"$kfx" mismatch "$tmp/design_s.json" --ranges "$src/examples/ranges/patel_toda_noise_ranges.json" > "$tmp/design_s.txt" 2>&1
check "design with S: exit 0" test $? -eq 0
check "design with S: nominal error = its own tr P_filt = the engine's (1e-9)" awk '
  /^nominal/ { gsub(/[(),]/, " "); for (i = 1; i <= NF; ++i) { if ($i == "P" && $(i + 1) == "=") a = $(i + 2);
    if ($i == "P_filt" && $(i + 1) == "=") b = $(i + 2); if ($i == "engine") c = $(i + 1) } }
  END { d1 = a - b; d2 = a - c; if (d1 < 0) d1 = -d1; if (d2 < 0) d2 = -d2;
    exit !(a > 0 && d1 <= 1e-9 * a && d2 <= 1e-9 * a) }' "$tmp/design_s.txt"
check "design with S: both extremes found" test "$(grep -c 'tr P_\{0,1\}F\{0,1\} = .* evaluations' "$tmp/design_s.txt")" -eq 2
check "design with S: Theorem 4 refused (its S)" grep -q "^  refused pi4" "$tmp/design_s.txt"

expect_error() {  # expect_error PATTERN -- ARGS...
  local pattern=$1
  shift 2
  "$kfx" "$@" > "$tmp/out" 2> "$tmp/err"
  local rc=$?
  if [[ $rc -ne 2 || $(wc -l < "$tmp/err") -ne 1 ]] || ! grep -q -- "$pattern" "$tmp/err"; then
    echo "FAIL: kfx $* -> rc $rc, expected rc 2 and one line matching '$pattern':"
    cat "$tmp/err"
    fail=1
  else
    echo "ok: kfx $*: $(cat "$tmp/err")"
  fi
}
expect_error "ranges" -- mismatch "$model"
expect_error "expected a model without a known input" -- mismatch "$src/examples/models/driven_cart.json" --ranges "$tmp/s.json"
printf '{"A": [[-0.1, 0], [0, 0]]}\n' > "$tmp/negative.json"
expect_error "ranges.A" -- mismatch "$model" --ranges "$tmp/negative.json"
printf '{"R": [[0.5, 0]]}\n' > "$tmp/shape.json"
expect_error "ranges.R" -- mismatch "$model" --ranges "$tmp/shape.json"
printf '{"format": "kfx-error-ranges"}\n' > "$tmp/empty.json"
expect_error "empty.json" -- mismatch "$model" --ranges "$tmp/empty.json"
expect_error "missing.json" -- mismatch "$model" --ranges "$tmp/missing.json"
printf '{"unmodelled_input": 3}\n' > "$tmp/bad_input.json"
expect_error "unmodelled_input: expected true or false" -- mismatch "$model" --ranges "$tmp/bad_input.json"
printf '{"S": [[0.5, 0.0]]}\n' > "$tmp/bad_s.json"
expect_error "ranges.S" -- mismatch "$model" --ranges "$tmp/bad_s.json"

"$kfx" reproduce patel-toda --json "$tmp/r.json" > "$tmp/r.txt"
check "reproduce patel-toda: exit 0" test $? -eq 0
for key in thm3.case1.pi3 thm3.case1.least_upper thm3.case2.pi3 thm3.case2.least_upper thm4.case1.pi4 \
  thm4.case1.greatest_lower thm4.case2.pi4 thm4.case2.greatest_lower thm5.pi5 thm5.least_upper thm6.pi6 \
  thm6.greatest_lower; do
  check "reproduce row $key" grep -q "^$key " "$tmp/r.txt"
done
check "reproduce JSON has twelve items" test "$(grep -c '"key"' "$tmp/r.json")" -eq 12
exit $fail
