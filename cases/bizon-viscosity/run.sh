#!/bin/sh
# Runs every state point of this case, then plots them (plot.py).
#   GRAINBATH=build/grainbath sh cases/bizon-viscosity/run.sh
set -e
here=$(cd "$(dirname "$0")" && pwd)
exe=${GRAINBATH:-build/grainbath}
for d in "$here"/nu*/; do
  d=${d%/}
  /usr/bin/time -f "$(basename "$d"): %e s wall" "$exe" run "$d" --out "$d/output" -q
done
/usr/bin/python3 "$here/plot.py"
