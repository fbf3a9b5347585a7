#!/bin/bash
# EDMD runs of cases/rough-driven (README.md "Reproduce"): the two Fig. 10.9 cases from
# (Ttr, Trot) = (1, 0), then the steady R vs mu sweep at the same N, phi, e, beta0, q, each run
# started at model E's steady state (from `grainbath theory`) so that 100 collisions per
# particle of equilibration suffice even at small mu (Trot relaxes at a rate ~ mu there).
# Usage: [SEEDS="1 2 3 4"] bash cases/rough-driven/run.sh [path/to/grainbath [--set key=value ...]]
#   (about 2.4 min CPU on one core with one seed, 2026-12-07; the --set arguments go to every run, e.g.
#   --set run.threads=1). SEEDS (default 1) repeats every sweep point with these seeds
#   (output-sweep/mu-MU for seed 1, output-sweep/mu-MU-seedS for the others): the blocked
#   single-run errors of Ttr (and of R at small mu) understate the scatter between runs (slow
#   energy modes of a driven gas with weak losses; docs/edmd.md "Errors of the window means"),
#   so collect.py quotes the mean and standard error over the seeds when there are several.
set -euo pipefail
GB=${1:-build/grainbath}
shift || true
SEEDS=${SEEDS:-1}
D=$(cd "$(dirname "$0")" && pwd)
"$GB" run "$D/mu-inf" -q "$@"
"$GB" run "$D/mu-0.5" -q "$@"
mkdir -p "$D/output-sweep"
for mu in 0.01 0.02 0.05 0.1 0.2 0.3 0.5 1 2 1e12; do
  read -r T0 Trot0 < <("$GB" theory "$D/mu-0.5" --set restitution.mu=$mu |
           /usr/bin/python3 -c "import json,sys; m=json.load(sys.stdin)['edmd']['rough']['model_E']; print(m['Ttr'], m['R'] * m['Ttr'])")
  for s in $SEEDS; do
    out="$D/output-sweep/mu-$mu"; [ "$s" = 1 ] || out="$out-seed$s"
    "$GB" run "$D/mu-0.5" -q --out "$out" --set restitution.mu=$mu --set edmd.temperature=$T0 \
      --set edmd.rotational_temperature=$Trot0 --set edmd.equilibrate=100 --set edmd.collisions=400 \
      --set run.seed=$s "$@"
  done
done
/usr/bin/python3 "$D/collect.py"
/usr/bin/python3 "$D/plot.py"
