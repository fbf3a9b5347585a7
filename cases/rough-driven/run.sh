#!/bin/bash
# EDMD runs of cases/rough-driven (README.md "Reproduce"): the two Fig. 10.9 cases from
# (Ttr, Trot) = (1, 0), then the steady R vs mu sweep at the same N, phi, e, beta0, q, each run
# started at model E's steady state (from `grainbath theory`) so that 100 collisions per
# particle of equilibration suffice even at small mu (Trot relaxes at a rate ~ mu there).
# Usage: bash cases/rough-driven/run.sh [path/to/grainbath]      (about 6 min on one core)
set -euo pipefail
GB=${1:-build/grainbath}
D=$(cd "$(dirname "$0")" && pwd)
"$GB" run "$D/mu-inf" -q
"$GB" run "$D/mu-0.5" -q
mkdir -p "$D/output-sweep"
for mu in 0.01 0.02 0.05 0.1 0.2 0.3 0.5 1 2 1e12; do
  set -- $("$GB" theory "$D/mu-0.5" --set restitution.mu=$mu |
           /usr/bin/python3 -c "import json,sys; m=json.load(sys.stdin)['edmd']['rough']['model_E']; print(m['Ttr'], m['R'] * m['Ttr'])")
  "$GB" run "$D/mu-0.5" -q --out "$D/output-sweep/mu-$mu" --set restitution.mu=$mu --set edmd.temperature=$1 \
    --set edmd.rotational_temperature=$2 --set edmd.equilibrate=100 --set edmd.collisions=400
done
/usr/bin/python3 "$D/collect.py"
/usr/bin/python3 "$D/plot.py"
