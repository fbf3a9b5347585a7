#!/bin/sh
# Before/after on a drifting VM: the issue-#7 single-thread figures of two builds, alternating
# process by process, so that both see the same minutes of the machine. Prints one line per
# process: round, build, time, 1-minute load, DSMC-1 CPU ns per particle-step (10^6), DSMC-2
# CPU ns per bath test, EDMD spheres phi = 0.3 collisions per CPU second at N = 1e5 and 1e4,
# EDMD disks nu = 0.5 at N = 1e6.
# usage: scripts/bench-interleaved.sh BASE_BENCH_DIR NEW_BENCH_DIR [ROUNDS]
#   (each DIR holds bench_dsmc and bench_edmd, e.g. a base worktree's build/bench and build/bench)
set -eu
base=$1
new=$2
rounds=${3:-5}
r=1
while [ "$r" -le "$rounds" ]; do
  for b in "$base" "$new"; do
    l=$(cut -d' ' -f1 /proc/loadavg)
    a=$("$b/bench_dsmc" --benchmark_filter='DSMC1_SpartaBox/1/' 2>/dev/null | grep -o 'cpu_ns_per_particle_step=[0-9.]*')
    c=$("$b/bench_dsmc" --benchmark_filter='DSMC2_HomogeneousBath/1/' 2>/dev/null | grep -o 'cpu_ns_per_bath_test=[0-9.]*')
    e=$("$b/bench_edmd" --benchmark_filter='BM_Edmd/spheres_phi0.30/100000/' 2>/dev/null | grep -o 'collisions_per_second=[0-9.kM]*')
    f=$("$b/bench_edmd" --benchmark_filter='BM_Edmd/spheres_phi0.30/10000/' 2>/dev/null | grep -o 'collisions_per_second=[0-9.kM]*')
    g=$("$b/bench_edmd" --benchmark_filter='BM_Edmd/disks_nu0.50/1000000/' 2>/dev/null | grep -o 'collisions_per_second=[0-9.kM]*')
    echo "$r $b $(date -u +%H:%M:%S) load=$l $a $c e5:$e e4:$f disks1e6:$g"
  done
  r=$((r + 1))
done
