#!/bin/bash
# The fused step in a box with walls against the separate passes and the periodic box
# (docs/PERFORMANCE.md, "boxes with walls take the fused step"): ROUNDS rounds, each running
# in turn DSMC-1's periodic box, the walled box fused and the walled box with
# GRAINBATH_DSMC_UNFUSED=1, on 1 and then 2 threads. One line per run: ns per particle-step
# (whole run, CPU, step loop), peak RSS in MiB and the 1-minute load before it.
# usage: scripts/bench-walls.sh BUILD_DIR [ROUNDS]
set -eu
bench=$1/bench/bench_dsmc
rounds=${2:-3}
for r in $(seq 1 "$rounds"); do
  for cfg in "SpartaBox/1/ fused" "WalledBox/1/ fused" "WalledBox/1/ separate" \
             "SpartaBox/2/ fused" "WalledBox/2/ fused" "WalledBox/2/ separate"; do
    set -- $cfg
    if [ "$2" = separate ]; then export GRAINBATH_DSMC_UNFUSED=1; else unset GRAINBATH_DSMC_UNFUSED; fi
    load=$(cut -d' ' -f1 /proc/loadavg)
    "$bench" --benchmark_filter="DSMC1_$1" 2>&1 | grep '^BM' | sed -E \
      "s/.*(BM_[A-Za-z0-9_]+\/[12]).* cpu_ns_per_particle_step=([0-9.]+) loop_ns_per_particle_step=([0-9.]+) ns_per_particle_step=([0-9.]+) peak_rss_MiB=([0-9.]+).*/round $r $2 \1 wall_ns=\4 cpu_ns=\2 loop_ns=\3 rss_MiB=\5 load=$load/"
  done
done
