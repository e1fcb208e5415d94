#!/usr/bin/env bash
# The main job of `make demo`: every paper's reproduction that kfx has, then a
# simulate -> filter -> smooth -> analyze pipeline on bundled models, with the exact error of a
# correct and a mismatched filter beside Monte Carlo. Usage: demo.sh KFX [--full]
set -euo pipefail
kfx=${1:?usage: demo.sh path/to/kfx [--full]}
full=${2:-}
here=$(cd "$(dirname "$0")" && pwd)
out=${KFX_DEMO_OUT:-demo-out}
mkdir -p "$out"
quick=--quick
[[ "$full" == "--full" ]] && quick=
section() { printf '\n\033[1m== %s\033[0m\n' "$*"; }

section "kfx reproduce all $quick --brief  (published numbers beside kfx's; JSON in $out/reproduce.json)"
# --out: the CLI draws the figures itself through kfx.plots (PNG + SVG), or says why it could not.
# --brief: per paper the counts and key rows; the full tables go to $out/figures/<paper>/table.txt
# (KFX_DEMO_TABLES=1 prints them here instead).
brief=--brief
[[ -n "${KFX_DEMO_TABLES:-}" ]] && brief=
"$kfx" reproduce all $quick $brief --json "$out/reproduce.json" --out "$out/figures"

models="$here/models"
section "simulate -> filter -> smooth: constant-velocity target, 200 steps"
"$kfx" simulate "$models/constant_velocity.json" --steps 200 --seed 7 -o "$out/cv"
"$kfx" filter "$models/constant_velocity.json" --data "$out/cv/y.npy" -o "$out/cv/filter"
"$kfx" smooth "$models/constant_velocity.json" --data "$out/cv/y.npy" -o "$out/cv/smooth"

section "analyze: steady state of the 4-mass spring chain, exact vs Monte Carlo MSE"
"$kfx" analyze "$models/mass_spring_chain.json" --monte-carlo 2000 --steps 50 --seed 3 --json "$out/chain_analysis.json"

section "analyze: a filter designed with 10x too little process noise, run on the true chain"
"$kfx" analyze "$models/mass_spring_chain.json" --design "$models/mass_spring_chain_low_q.json" \
  --monte-carlo 2000 --steps 50 --seed 3
bindir="$(cd "$(dirname "$kfx")" && pwd)"
if [[ -x "$bindir/kfx_example_wave" ]]; then
  section "compare: the damped wave of 000 on a fine mesh (n = 62), every method in one command"
  wave="$out/wave"
  "$bindir/kfx_example_wave" "$wave" 31 3
  E="$wave/prolongation.npy" W="$wave/gram.npy"
  "$kfx" compare "$wave/fine.json" --steps 200 --weight "$W" --monte-carlo 100 --out "$wave/compare" \
    --method steady --method "coarse:model=$wave/coarse.json,prolongation=$E" \
    --method "subspace:mesh=3,gain=converged" --method "subspace61:basis=$E,gram=$W" \
    --method tau:order=2 --method tau:order=6 --method mu:order=2 --method mu:order=6
fi

section "compare: a continuous-time model (003) sampled every dt, 2 dt, 8 dt against the Kalman-Bucy filter"
"$kfx" compare "$here/continuous/oscillator.json" --steps 200 --method kalman --method sampled:dt=0.1 \
  --method sampled:dt=0.4 --method sampled:dt=0.4,gain=steady

section "compare: block-diagonal and banded filters of a coupled model (examples/coupled) vs the Kalman filter"
"$kfx" compare "$here/coupled/model.json" --steps 200 --method kalman --method blockdiag --method banded
"$kfx" blockdiag "$here/coupled/model.json" --data "$here/coupled/y.npy" -o "$out/coupled-bd"

pydir="$(cd "$(dirname "$kfx")/.." && pwd)/python"
python=${KFX_PYTHON:-/usr/bin/python3}
if compgen -G "$pydir/kfx/_core*.so" > /dev/null; then
  section "Python: the same filter through import kfx (docs/python.md)"
  PYTHONPATH="$pydir" "$python" - "$models/constant_velocity.json" <<'PY'
import json, sys
import numpy as np
import kfx
d = json.load(open(sys.argv[1]))
model = kfx.Model(A=d["A"], C=d["C"], Q=d["Q"], R=d["R"], m0=d["m0"], P0=d["P0"])
x, y = kfx.simulate(model, steps=200, seed=7)
run = kfx.run_filter(model, y, store_covariances="full")  # every P_{k|k}: the smoother needs them
sm = kfx.rts_smooth(model, run)
f = kfx.kalman_as_linear_filter(model, 200)
print(f"kfx {kfx.__version__}: log-likelihood {run.log_likelihood:.6f} (as kfx filter above)")
print(f"RMSE filter {np.sqrt(np.mean((run.x_filt - x) ** 2)):.4f}, smoother {np.sqrt(np.mean((sm.x - x) ** 2)):.4f}")
print(f"exact MSE at k = 200: {kfx.exact_performance(model, f).mse[-1]:.6f}")
PY
else
  echo "(Python package not built: see docs/python.md)"
fi
printf '\nOutputs are in %s/\n' "$out"
