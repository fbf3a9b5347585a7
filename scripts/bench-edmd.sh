#!/bin/sh
# EDMD-1 benchmark (issue #7), one configuration per process so that peak RSS is per
# configuration; `uptime` is recorded before every configuration (the machine may be shared:
# times are then upper bounds, rates lower bounds). Usage:
#   scripts/bench-edmd.sh BUILD_DIR OUT_DIR [REPETITIONS]
# Writes OUT_DIR/<config>.json (Google Benchmark JSON) and OUT_DIR/uptime.log.
set -eu
build=$1
out=$2
reps=${3:-5}
mkdir -p "$out"
for cfg in spheres_phi0.30/10000 spheres_phi0.30/100000 spheres_phi0.45/10000 spheres_phi0.45/100000 \
           disks_nu0.50/10000 disks_nu0.50/1000000 disks_nu0.70/10000 disks_nu0.70/1000000; do
  name=$(echo "$cfg" | tr '/' '_')
  echo "$name $(date -u +%H:%M:%S) $(uptime)" >> "$out/uptime.log"
  nice "$build/bench/bench_edmd" --benchmark_filter="BM_Edmd/$cfg/" --benchmark_repetitions="$reps" \
    --benchmark_out="$out/$name.json" --benchmark_out_format=json > /dev/null
done
echo "end $(date -u +%H:%M:%S) $(uptime)" >> "$out/uptime.log"
