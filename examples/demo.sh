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

section "kfx reproduce all $quick  (published numbers beside kfx's; JSON in $out/reproduce.json)"
"$kfx" reproduce all $quick --json "$out/reproduce.json" --out "$out/figures"
if /usr/bin/python3 -c "import matplotlib" 2> /dev/null; then
  /usr/bin/python3 "$here/../python/kfx_figures.py" "$out/figures"
else
  echo "(figures: install python3-matplotlib, then python3 python/kfx_figures.py $out/figures)"
fi

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
printf '\nOutputs are in %s/\n' "$out"
