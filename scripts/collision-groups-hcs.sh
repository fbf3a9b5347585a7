#!/bin/sh
# The homogeneous cooling state with collision groups against one cell (docs/dsmc.md,
# "Collision groups"; docs/VALIDATION.md): cases/free-cooling at 4e5 grains to t = 12, seeds
# 21..28 (e = 0.8 unless given), [dsmc] collision_group = 0 (one cell) and 4096 (the default). Prints the mean over
# the seeds of a2 (steady window) and of T(t_end), with standard errors from the seed scatter.
# Usage: scripts/collision-groups-hcs.sh BUILD_DIR OUT_DIR [RESTITUTION_E, default 0.8]
set -eu
build=$1
out=$2
e=${3:-0.8}
here=$(cd "$(dirname "$0")/.." && pwd)
for s in 21 22 23 24 25 26 27 28; do
  for g in 0 4096; do
    "$build/grainbath" run "$here/cases/free-cooling" --out "$out/$g-$s" --set dsmc.particles=400000 \
      --set dsmc.t_end=12 --set sampling.every=0.25 --set sampling.steady_from=3 --set run.seed=$s \
      --set dsmc.collision_group=$g --set restitution.e="$e" -q > /dev/null
  done
done
/usr/bin/python3 - "$out" <<'PY'
import json, sys
import numpy as np
out = sys.argv[1]
for g in ("0", "4096"):
    runs = [json.load(open(f"{out}/{g}-{s}/summary.json")) for s in range(21, 29)]
    a2 = np.array([r["a2"]["mean"] for r in runs])
    T = np.array([r["temperature"]["final"] for r in runs])
    se = lambda x: x.std(ddof=1) / np.sqrt(len(x))
    print(f"collision_group = {g}: a2 = {a2.mean():.5f} +- {se(a2):.5f}, T(t_end) = {T.mean():.6f} +- {se(T):.6f}")
PY
