#!/usr/bin/env bash
# The scan: eps = 0.2 ... 0.01 at fixed k = pi (L = 2); one output per eps in OUT/eps-EPS, then
# a table and a plot in OUT, compared with the shipped reference/table.md (table.py). OUT is
# cases/diffusion-limit/output (git ignores it) unless given first: run.sh --out DIR [eps ...].
# t_end = 0.3/eps so the mode decays by the same factor (about e^-2) at every eps; dt = eps/10
# keeps the velocity-sampling error of the splitting at (gamma dt)^2/12 ~ 0.2% (gamma ~ 1.5/eps:
# momentum relaxation rate).
# Cost grows as 1/eps^2: eps = 0.01 takes about 2e9 particle-steps. Pass eps values to run
# a subset: cases/diffusion-limit/run.sh 0.2 0.1 0.05
set -euo pipefail
# GRAINBATH names the binary (default: build/grainbath of this checkout).
cd "$(dirname "$0")/../.."
out=cases/diffusion-limit/output
if [ "${1:-}" = --out ]; then
  [ $# -ge 2 ] || { echo "run.sh: --out needs a directory" >&2; exit 2; }
  out=$2; shift 2
fi
values=("$@")
[ ${#values[@]} -gt 0 ] || values=(0.2 0.1 0.05 0.02 0.01)
for eps in "${values[@]}"; do
  # every: about 150 samples over the run, a whole number of steps (at eps = 0.2, t_end/150 is
  # half a step: one sample per step, 76, which the run says are too few to check the blocking)
  read -r t_end dt every fit_from < <(python3 -c "e=$eps; dt=round(e/10,6); n=max(1, round(0.3/e/150/dt)); print(round(0.3/e,6), dt, round(n*dt,6), round(2*e,6))")
  "${GRAINBATH:-./build/grainbath}" run cases/diffusion-limit --set background.knudsen="$eps" --set dsmc.t_end="$t_end" \
    --set dsmc.dt="$dt" --set sampling.every="$every" --set sampling.mode_fit_from="$fit_from" \
    --out "$out/eps-$eps" -q
done
/usr/bin/python3 cases/diffusion-limit/table.py --out "$out"
