#!/bin/sh
# Runs the three heat baths of Bizon et al. Sec. III at nu = 0.5, T ~ 1, and an elastic
# reference at the same density, then plots them (plot.py).
#   GRAINBATH=build/grainbath sh cases/bizon-heat-baths/run.sh
set -e
here=$(cd "$(dirname "$0")" && pwd)
exe=${GRAINBATH:-build/grainbath}
# elastic: disks at the same density (Bizon Fig. 7 reference curve)
for bath in white-noise air-table boltzmann elastic; do
  "$exe" run "$here/$bath" --out "$here/$bath/output" -q
done
/usr/bin/python3 "$here/plot.py"
