#!/bin/sh
# Rough grains (Walton's rule) in homogeneous DSMC, collision groups against one cell, both
# against the Huthmann-Zippelius model A (docs/rough.md sec. 7; docs/VALIDATION.md):
#  1. a Gaussian start, Ttr = Trot = 1, to t = 0.2 (20000 grains, dt 0.002), seeds 1..24;
#  2. free cooling from (Ttr, Trot) = (1, 0) to t = 5 (10000 grains, dt 0.01), seeds 1..16.
# e 0.8, beta0 0.4, mu = inf, q 0.4. Prints the seed means of DSMC - model (1) and DSMC/model - 1
# (2) with standard errors from the seed scatter. Usage: scripts/collision-groups-rough.sh BUILD_DIR OUT_DIR
set -eu
build=$1
out=$2
mkdir -p "$out/early" "$out/cooling"
cat > "$out/early/case.toml" <<'TOML'
[run]
solver = "dsmc"
threads = 1
[grains]
density = 1.0
temperature = 1.0
rotational_temperature = 1.0
[restitution]
law = "walton"
e = 0.8
beta0 = 0.4
q = 0.4
[dsmc]
particles = 20000
dt = 0.002
t_end = 0.2
[sampling]
every = 0.1
steady_from = 0.0
TOML
sed -e 's/rotational_temperature = 1.0/rotational_temperature = 0.0/' -e 's/particles = 20000/particles = 10000/' \
  -e 's/dt = 0.002/dt = 0.01/' -e 's/t_end = 0.2/t_end = 5.0/' "$out/early/case.toml" > "$out/cooling/case.toml"
for g in 0 4096; do
  for s in $(seq 1 24); do
    "$build/grainbath" run "$out/early" --out "$out/early/o-$g-$s" --set run.seed=$s --set dsmc.collision_group=$g -q > /dev/null 2>&1
  done
  for s in $(seq 1 16); do
    "$build/grainbath" run "$out/cooling" --out "$out/cooling/o-$g-$s" --set run.seed=$s --set dsmc.collision_group=$g -q > /dev/null 2>&1
  done
done
/usr/bin/python3 - "$out" <<'PY'
import sys
import h5py
import numpy as np
out = sys.argv[1]
def series(path):
    with h5py.File(path, "r") as f:
        return (f["/timeseries/temperature"][:], f["/timeseries/rotational_temperature"][:],
                f["/theory/rough_model_A/Ttr"][:], f["/theory/rough_model_A/Trot"][:])
se = lambda x: x.std(ddof=1) / np.sqrt(len(x))
for g in ("0", "4096"):
    d = np.array([[T[2] - M[2], R[2] - MR[2]] for T, R, M, MR in
                  (series(f"{out}/early/o-{g}-{s}/results.h5") for s in range(1, 25))])
    print(f"collision_group = {g}, Gaussian start, t = 0.2: Ttr - A = {d[:, 0].mean():.2e} +- {se(d[:, 0]):.1e}, "
          f"Trot - A = {d[:, 1].mean():.2e} +- {se(d[:, 1]):.1e}")
    runs = [series(f"{out}/cooling/o-{g}-{s}/results.h5") for s in range(1, 17)]
    for k in (10, 30, 50):
        r = 100 * np.array([[T[k] / M[k] - 1, R[k] / MR[k] - 1] for T, R, M, MR in runs])
        print(f"collision_group = {g}, free cooling, t = {k / 10:.0f}: Ttr/A - 1 = {r[:, 0].mean():+.2f} +- {se(r[:, 0]):.2f} %, "
              f"Trot/A - 1 = {r[:, 1].mean():+.2f} +- {se(r[:, 1]):.2f} %")
PY
