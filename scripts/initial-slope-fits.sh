#!/bin/sh
# Fit-order study behind DsmcPhysics.InitialSlopesMatchCollisionIntegrals (docs/VALIDATION.md,
# DSMC row 3): REPLICAS runs of the drifting-Maxwellian start (u - uB = 1, T = 2, alpha = 0.5,
# beta = 0.2, delta = 0.2, eps = 1, 4e5 grains, dt = 0.005 to t = 0.2), then least-squares
# polynomials of degree 2, 3, 4 in t through u(t), T(t) and the cumulative bath input and
# inelastic loss per grain; prints the mean slope at t = 0 with its standard error per degree.
#   scripts/initial-slope-fits.sh build/grainbath OUT_DIR [REPLICAS=48]
set -eu
gb=$1
out=$2
reps=${3:-48}
mkdir -p "$out"
r=1
while [ "$r" -le "$reps" ]; do
  d="$out/r$r"
  mkdir -p "$d"
  cat > "$d/case.toml" <<EOT
[run]
solver = "dsmc"
seed = $((2000 + r))
[grains]
density = 1.0
temperature = 2.0
drift = [1.0, 0.0, 0.0]
[background]
mass_ratio = 0.5
density = 1.0
temperature = 1.0
knudsen = 1.0
[restitution]
law = "power"
beta = 0.2
delta = 0.2
[dsmc]
particles = 400000
dt = 0.005
t_end = 0.2
[sampling]
every = 0.005
steady_from = 0.1
relaxation_theory = false
EOT
  "$gb" run "$d" -q > /dev/null
  r=$((r + 1))
done
/usr/bin/python3 - "$out" "$reps" <<'PY'
import sys, h5py, numpy as np
out, reps = sys.argv[1], int(sys.argv[2])
names = ("bath_in", "loss", "u", "T")
for deg in (2, 3, 4):
    rows = []
    for r in range(1, reps + 1):
        with h5py.File(f"{out}/r{r}/output/results.h5", "r") as f:
            t = f["/timeseries/t"][:]
            ys = (f["/timeseries/bath_energy_input_per_grain"][:], f["/timeseries/inelastic_loss_per_grain"][:],
                  f["/timeseries/velocity"][:, 0], f["/timeseries/temperature"][:])
            rows.append([np.polyfit(t, y, deg)[-2] for y in ys])
    a = np.array(rows)
    m, e = a.mean(0), a.std(0, ddof=1) / np.sqrt(len(a))
    print(f"degree {deg}, {len(a)} replicas: " + ", ".join(f"{n} {x:.4f} +- {s:.4f}" for n, x, s in zip(names, m, e)))
PY
