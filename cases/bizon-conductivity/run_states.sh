#!/bin/sh
# Runs every state point nu*/ of the case directory $1 with $GRAINBATH (default
# build/grainbath), printing each run's wall time, then the case's plot.py.
set -e
case_dir=$1
exe=${GRAINBATH:-build/grainbath}
for d in "$case_dir"/nu*/; do
  d=${d%/}
  /usr/bin/time -f "$(basename "$d"): %e s wall" "$exe" run "$d" --out "$d/output" -q
done
/usr/bin/python3 "$case_dir/plot.py"
