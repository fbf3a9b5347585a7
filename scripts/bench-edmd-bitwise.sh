#!/bin/sh
# Bitwise regression check of the EDMD engine (docs/performance/edmd.md, 2026-11-25
# evening): runs eight short CLI cases covering the engine's features with two grainbath
# binaries and compares results.h5 byte for byte (h5diff, provenance excluded).
# Usage: scripts/bench-edmd-bitwise.sh BASE_GRAINBATH NEW_GRAINBATH OUT_DIR
# Exit status 0 when every case is identical.
set -eu
base=$1
new=$2
out=$3
src=$(cd "$(dirname "$0")/.." && pwd)/cases
mkdir -p "$out/cases"
cp -r "$src/hard-sphere-eos" "$out/cases/sph3d"
cp -r "$src/free-cooling-disks" "$out/cases/disks2d"
cp -r "$src/vibrated-walls" "$out/cases/walls"
cp -r "$src/bizon-conductivity/nu0.5-a0.03" "$out/cases/airtable"
cp -r "$src/rough-driven/mu-0.5" "$out/cases/rough"
cp -r "$src/dense-medium/nu0.30" "$out/cases/medium"
mkdir -p "$out/cases/sph1e5" "$out/cases/walls3d"
cat > "$out/cases/sph1e5/case.toml" <<'TOML'
[run]
solver = "edmd"
[edmd]
dimensions = 3
particles = 100000
packing_fraction = 0.3
equilibrate = 3
collisions = 2
TOML
cat > "$out/cases/walls3d/case.toml" <<'TOML'
[run]
solver = "edmd"
seed = 3
[edmd]
dimensions = 3
particles = 4096
packing_fraction = 0.3
equilibrate = 3
collisions = 10
[restitution]
law = "constant"
e = 0.95
[walls]
directions = ["x", "z"]
restitution = 0.9
TOML
overrides() {
  case $1 in
    sph3d) echo "--set edmd.equilibrate=5 --set edmd.collisions=20" ;;
    disks2d) echo "--set edmd.particles=4096" ;;
    walls|airtable) echo "--set edmd.equilibrate=20 --set edmd.collisions=30" ;;
    rough) echo "--set edmd.collisions=10 --set edmd.particles=2500" ;;
    medium) echo "--set edmd.equilibrate=5 --set edmd.collisions=20" ;;
    *) echo "" ;;
  esac
}
status=0
for c in sph3d disks2d walls airtable rough medium sph1e5 walls3d; do
  for tag in base new; do
    bin=$base
    [ "$tag" = new ] && bin=$new
    rm -rf "$out/$tag/$c"
    mkdir -p "$out/$tag"
    # shellcheck disable=SC2046
    "$bin" run "$out/cases/$c" --out "$out/$tag/$c" -q $(overrides $c) > "$out/$tag/$c.log" 2>&1
  done
  if h5diff --exclude-path /provenance "$out/base/$c/results.h5" "$out/new/$c/results.h5" > /dev/null 2>&1; then
    echo "$c identical"
  else
    echo "$c DIFFERS"
    status=1
  fi
done
exit $status
