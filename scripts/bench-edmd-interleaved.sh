#!/bin/sh
# Before/after of chosen EDMD benchmarks on a drifting VM: two (or more) bench_edmd
# binaries alternating process by process, ROUNDS times, one line per process with the
# rate and the 1-minute load. A configuration is either a BM_Edmd argument ("disks_nu0.50/1000000"
# runs --benchmark_filter='BM_Edmd/disks_nu0.50/1000000/') or a whole filter starting with
# "BM_" ("BM_Calendar/1000000/"). Used for the before/after figures of docs/performance/edmd.md.
# usage: scripts/bench-edmd-interleaved.sh ROUNDS "CFG1 CFG2 ..." BASE/bench_edmd NEW/bench_edmd
set -eu
rounds=$1
cfgs=$2
shift 2
r=1
while [ "$r" -le "$rounds" ]; do
  for c in $cfgs; do
    case $c in BM_*) f=$c ;; *) f="BM_Edmd/$c/" ;; esac
    for b in "$@"; do
      v=$("$b" --benchmark_filter="$f" 2>/dev/null | grep '^BM' | head -1 |
        grep -o 'collisions_per_second=[0-9.]*[kM]*\|events_per_second=[0-9.]*[kM]*\|pairs_per_second=[0-9.]*[kM]*' | head -1)
      echo "r$r $c $b $v load $(cut -d' ' -f1 /proc/loadavg) $(date -u +%H:%M:%S)"
    done
  done
  r=$((r + 1))
done
