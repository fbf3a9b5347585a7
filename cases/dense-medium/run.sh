#!/bin/sh
# EDMD grains in the background medium at phi = 0.05 and 0.3, and the DSMC of the same
# physics (grain density mapped with the Enskog factor), then the comparison table.
#   GRAINBATH=build/grainbath sh cases/dense-medium/run.sh
# (DSMC_GRAINBATH may name a different binary for the DSMC runs; default: GRAINBATH.)
set -e
here=$(cd "$(dirname "$0")" && pwd)
exe=${GRAINBATH:-build/grainbath}
dsmc=${DSMC_GRAINBATH:-$exe}
for c in nu0.05 nu0.30; do "$exe" run "$here/$c" --out "$here/$c/output" -q; done
for c in dsmc-0.05 dsmc-0.30; do "$dsmc" run "$here/$c" --out "$here/$c/output" -q; done
/usr/bin/python3 "$here/compare.py"
