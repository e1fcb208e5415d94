#!/usr/bin/env bash
# A known input G g / D g and a cross-covariance S through the CLI (issue 22): model files with fields
# G, D, S; `kfx simulate --input` against the recursion x_k = A x_{k-1} + G g_k (Q = 0, P0 = 0: exact) and
# the measurement noise y - C x - D g against N(0, R) within 4 standard errors; `kfx filter --input` and
# `kfx smooth --input` against the posterior of the stacked Gaussian (x_0..x_T, y_1..y_T) computed here
# with numpy (an independent algorithm); every invalid input gives exit 2 and one line naming it.
# Usage: known_input.sh KFX SOURCE_DIR
set -euo pipefail
kfx=$1
src=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cart="$src/examples/models/driven_cart.json"
cart_g="$src/examples/models/driven_cart_input.csv"

# 1. Simulation: a deterministic state (Q = 0, P0 = 0, S = 0 written as a field) driven by a known input.
/usr/bin/python3 - "$tmp" <<'PY'
import json, sys
import numpy as np
tmp = sys.argv[1]
m = {"format": "kfx-model", "version": 1, "A": [[0.9, 0.2], [-0.1, 0.8]], "C": [[1.0, 0.5], [0.0, 1.0]],
     "Q": [[0, 0], [0, 0]], "R": [[0.5, 0.1], [0.1, 0.3]], "G": [[1.0, 0.0, 0.5], [0.0, 1.0, -0.5]],
     "D": [[0.2, 0.0, 0.0], [0.0, 0.0, 3.0]], "S": [[0, 0], [0, 0]], "m0": [1.0, -2.0], "P0": [[0, 0], [0, 0]]}
json.dump(m, open(f"{tmp}/det.json", "w"))
rng = np.random.default_rng(3)
np.savetxt(f"{tmp}/det_g.csv", rng.standard_normal((2000, 3)), delimiter=",", header="a,b,c", comments="")
PY
"$kfx" simulate "$tmp/det.json" --steps 2000 --seed 9 --input "$tmp/det_g.csv" -o "$tmp/dsim" > /dev/null
/usr/bin/python3 - "$tmp" <<'PY'
import json, sys
import numpy as np
tmp = sys.argv[1]
m = {k: np.array(v, float) for k, v in json.load(open(f"{tmp}/det.json")).items() if k not in ("format", "version")}
g = np.loadtxt(f"{tmp}/det_g.csv", delimiter=",", skiprows=1)
x, y = np.load(f"{tmp}/dsim/x.npy"), np.load(f"{tmp}/dsim/y.npy")
assert x.shape == (2001, 2) and y.shape == (2000, 2), (x.shape, y.shape)
ref = [m["m0"]]
for k in range(2000):
    ref.append(m["A"] @ ref[-1] + m["G"] @ g[k])
np.testing.assert_allclose(x, np.array(ref), rtol=1e-10, atol=1e-10)
v = y - x[1:] @ m["C"].T - g @ m["D"].T
T = len(v)
mean, cov = v.mean(0), np.cov(v.T)
se_mean = np.sqrt(np.diag(m["R"]) / T)
assert np.all(np.abs(mean) < 4 * se_mean), (mean, se_mean)
# var of a sample covariance entry: (R_ii R_jj + R_ij^2) / T
R = m["R"]
se_cov = np.sqrt((np.outer(np.diag(R), np.diag(R)) + R**2) / T)
assert np.all(np.abs(cov - R) < 4 * se_cov), (cov, R, se_cov)
print("simulate --input ok")
PY

# 2. Filter and smoother with G, D and S (the example driven_cart), with one missing measurement.
"$kfx" simulate "$cart" --steps 50 --seed 4 --input "$cart_g" --csv -o "$tmp/csim" > /dev/null
awk 'NR==8{$0="nan"}1' "$tmp/csim/y.csv" > "$tmp/y.csv"
"$kfx" filter "$cart" --data "$tmp/y.csv" --input "$cart_g" -o "$tmp/f" | grep -q "1 missing"
"$kfx" smooth "$cart" --data "$tmp/y.csv" --input "$cart_g" -o "$tmp/s" > /dev/null
for form in standard sqrt ud information; do
  "$kfx" filter "$cart" --data "$tmp/y.csv" --input "$cart_g" --form "$form" -o "$tmp/f_$form" > /dev/null
done
/usr/bin/python3 - "$tmp" "$cart" "$cart_g" <<'PY'
import json, sys
import numpy as np
tmp, cart, cart_g = sys.argv[1:]
m = {k: np.array(v, float) for k, v in json.load(open(cart)).items() if k in "A C Q R G D S m0 P0".split()}
A, C, Q, R, G, D, S = (m[k] for k in "A C Q R G D S".split())
g = np.array([float(l) for l in open(cart_g) if l.strip() and l[0] not in "#g"]).reshape(-1, 1)  # comment, header
y = np.genfromtxt(f"{tmp}/y.csv", delimiter=",").reshape(-1, 1)  # no header; "nan" = missing
T, n, mm = len(y), 2, 1
# (x_0, ..., x_T, y_1, ..., y_T) = mean + L xi with xi = (x_0 - m0, (w_1, v_1), ..., (w_T, v_T)).
N = n + T * (n + mm)
Lx, mx = np.zeros(((T + 1) * n, N)), np.zeros((T + 1) * n)
Ly, my = np.zeros((T * mm, N)), np.zeros(T * mm)
Lx[:n, :n], mx[:n] = np.eye(n), m["m0"]
for k in range(1, T + 1):
    c = n + (k - 1) * (n + mm)
    Lx[k * n:(k + 1) * n] = A @ Lx[(k - 1) * n:k * n]
    Lx[k * n:(k + 1) * n, c:c + n] += np.eye(n)
    mx[k * n:(k + 1) * n] = A @ mx[(k - 1) * n:k * n] + G @ g[k - 1]
    Ly[(k - 1) * mm:k * mm] = C @ Lx[k * n:(k + 1) * n]
    Ly[(k - 1) * mm:k * mm, c + n:c + n + mm] += np.eye(mm)
    my[(k - 1) * mm:k * mm] = C @ mx[k * n:(k + 1) * n] + D @ g[k - 1]
J = np.block([[Q, S], [S.T, R]])
Xi = np.zeros((N, N))
Xi[:n, :n] = m["P0"]
for k in range(T):
    c = n + k * (n + mm)
    Xi[c:c + n + mm, c:c + n + mm] = J
yv = y.reshape(-1)

def posterior(upto):  # mean and covariance of every x_j given y_1..y_upto (observed entries)
    obs = np.flatnonzero(~np.isnan(yv[:upto * mm]))
    Cxy = Lx @ Xi @ Ly[obs].T
    Cyy = Ly[obs] @ Xi @ Ly[obs].T
    K = np.linalg.solve(Cyy, Cxy.T).T
    mean = mx + K @ (yv[obs] - my[obs])
    cov = Lx @ Xi @ Lx.T - K @ Cxy.T
    return mean.reshape(T + 1, n), cov

x_filt = np.load(f"{tmp}/f/x_filt.npy")
P_filt_diag = np.load(f"{tmp}/f/P_filt_diag.npy")
for k in range(T + 1):
    mean, cov = posterior(k)
    np.testing.assert_allclose(x_filt[k], mean[k], rtol=1e-8, atol=1e-8, err_msg=f"x_filt k={k}")
    np.testing.assert_allclose(P_filt_diag[k], np.diag(cov)[k * n:(k + 1) * n], rtol=1e-8, atol=1e-8)
for form in ("standard", "sqrt", "ud", "information"):
    np.testing.assert_allclose(np.load(f"{tmp}/f_{form}/x_filt.npy"), x_filt, rtol=1e-8, atol=1e-8, err_msg=form)
mean, cov = posterior(T)
np.testing.assert_allclose(np.load(f"{tmp}/s/x_smooth.npy"), mean, rtol=1e-8, atol=1e-8)
np.testing.assert_allclose(np.load(f"{tmp}/s/P_smooth_diag.npy"), np.diag(cov).reshape(T + 1, n), rtol=1e-8,
                           atol=1e-8)
print("filter/smooth --input ok")
PY

# 3. Invalid input: exit 2, one line naming the argument.
fail=0
expect_error() {  # expect_error PATTERN -- ARGS...
  local pattern=$1
  shift 2
  set +e
  "$kfx" "$@" > "$tmp/out" 2> "$tmp/err"
  local rc=$?
  set -e
  local lines
  lines=$(wc -l < "$tmp/err")
  if [[ $rc -ne 2 || $lines -ne 1 ]] || ! grep -q -- "$pattern" "$tmp/err"; then
    echo "FAIL: kfx $* -> rc $rc, $lines stderr lines, expected rc 2 and one line matching '$pattern':"
    cat "$tmp/err"
    fail=1
  fi
}
model_with() {  # model_with NAME FIELD VALUE: driven_cart.json with FIELD replaced
  /usr/bin/python3 - "$cart" "$tmp/$1.json" "$2" "$3" <<'PY'
import json, sys
src, path, field, value = sys.argv[1:]
m = json.load(open(src))
m[field] = json.loads(value)
json.dump(m, open(path, "w"))
PY
}
expect_error "--input: g: expected a known input" -- simulate "$cart" --steps 5 -o "$tmp/e1"
expect_error "--input: g: expected a known input" -- filter "$cart" --data "$tmp/y.csv" -o "$tmp/e2"
printf 'a,b\n1,2\n1,2\n' > "$tmp/g2.csv"
expect_error "--input: g: expected a known input of 50 rows and 1 columns" -- \
  smooth "$cart" --data "$tmp/y.csv" --input "$tmp/g2.csv" -o "$tmp/e3"
expect_error "--input: g: expected no known input" -- \
  simulate "$src/examples/models/constant_velocity.json" --steps 2 --input "$tmp/g2.csv" -o "$tmp/e4"
expect_error "--input" -- filter "$cart" --data "$tmp/y.csv" --input "$tmp/missing.csv" -o "$tmp/e5"
model_with badG G '[[1.0], [1.0], [1.0]]'
expect_error "field 'G'" -- simulate "$tmp/badG.json" --steps 2 --input "$cart_g" -o "$tmp/e6"
model_with badD D '[[0.5, 1.0]]'
expect_error "field 'D'" -- simulate "$tmp/badD.json" --steps 2 --input "$cart_g" -o "$tmp/e7"
model_with badS S '[[0.025, 0.05]]'
expect_error "field 'S'" -- simulate "$tmp/badS.json" --steps 2 --input "$cart_g" -o "$tmp/e8"
model_with notpsd S '[[1.0], [1.0]]'
expect_error "field 'S'.*joint covariance" -- simulate "$tmp/notpsd.json" --steps 2 --input "$cart_g" -o "$tmp/e9"
# 4. `kfx analyze --input`: the exact-performance engine with the known input against Monte Carlo (|z| < 4.5
# at every printed step) and, for a design that ignores the input (no G, D; S kept), against the error
# recursion computed here with numpy (an independent algorithm): mean b_k = F_k b_{k-1} + ((I - K C) G - K D) g_k,
# covariance P_k = F_k P_{k-1} F_k^T + [I - K C, -K] [[Q, S], [S^T, R]] [I - K C, -K]^T, F_k = (I - K_k C) A.
/usr/bin/python3 - "$tmp" "$cart" <<'PY'
import json, sys
import numpy as np
tmp, cart = sys.argv[1:]
np.save(f"{tmp}/g30.npy", 2.0 * np.random.default_rng(8).standard_normal((30, 1)))
m = json.load(open(cart))
for f in ("G", "D"):
    del m[f]
json.dump(m, open(f"{tmp}/cart_plain.json", "w"))
json.dump(dict(m, G=[[0.5, 0.0], [1.0, 0.0]], D=[[0.5, 0.0]]), open(f"{tmp}/cart_q2.json", "w"))
PY
"$kfx" analyze "$cart" --input "$tmp/g30.npy" --monte-carlo 2000 --steps 30 --seed 3 --json "$tmp/a1.json" \
  > "$tmp/a1.txt"
"$kfx" analyze "$cart" --design "$tmp/cart_plain.json" --input "$tmp/g30.npy" --monte-carlo 2000 --steps 30 \
  --seed 4 --json "$tmp/a2.json" > "$tmp/a2.txt"
grep -q "none (MODEL has a known input" "$tmp/a1.txt"
/usr/bin/python3 - "$tmp" "$cart" <<'PY'
import json, sys
import numpy as np
tmp, cart = sys.argv[1:]
m = {k: np.array(v, float) for k, v in json.load(open(cart)).items() if k in "A C Q R G D S m0 P0".split()}
A, C, Q, R, G, D, S = (m[k] for k in "A C Q R G D S".split())
g = np.load(f"{tmp}/g30.npy")
J = np.block([[Q, S], [S.T, R]])
# Design gains (the design has S, not G, D): the correlated Kalman gain recursion.
P, b, Pe, exact, bias = m["P0"], np.zeros(2), m["P0"], [np.trace(m["P0"])], [np.zeros(2)]
for k in range(30):
    Pp = A @ P @ A.T + Q
    U = Pp @ C.T + S
    K = np.linalg.solve(C @ Pp @ C.T + C @ S + S.T @ C.T + R, U.T).T
    P = Pp - K @ U.T
    L = np.hstack([np.eye(2) - K @ C, -K])
    F = (np.eye(2) - K @ C) @ A
    b = F @ b + ((np.eye(2) - K @ C) @ G - K @ D) @ g[k]
    Pe = F @ Pe @ F.T + L @ J @ L.T
    exact.append(np.trace(Pe) + b @ b)
    bias.append(b)
for name, ignoring in (("a1", False), ("a2", True)):
    rows = json.load(open(f"{tmp}/{name}.json"))["monte_carlo"]["rows"]
    assert len(rows) >= 5, rows
    for r in rows:
        z = (r["monte_carlo"] - r["exact"]) / r["std_error"] if r["std_error"] > 0 else 0.0
        assert abs(z) < 4.5, (name, r)
        if ignoring:
            k = r["k"]
            assert abs(r["exact"] - exact[k]) <= 1e-9 * exact[k], (k, r["exact"], exact[k])
            np.testing.assert_allclose(r["exact_bias"], bias[k], rtol=1e-9, atol=1e-12)
        else:
            assert np.abs(r["exact_bias"]).max() < 1e-10, r  # the filter models the input: zero-mean error
assert np.abs(bias[30]).max() > 0.1  # ignoring the input is a real bias here
print("analyze --input ok")
PY
expect_error "--input: g: expected a known input" -- analyze "$cart" --monte-carlo 10 --steps 5
expect_error "--input: expected with --monte-carlo" -- analyze "$cart" --input "$tmp/g30.npy"
expect_error "--design: expected fields G, D with the 1 columns" -- \
  analyze "$cart" --design "$tmp/cart_q2.json" --input "$tmp/g30.npy" --monte-carlo 10 --steps 5
expect_error "model: expected a model without a known input" -- compare "$cart" --method kalman
exit $fail
