#!/bin/sh
# Every benchmark of issue #7 in one go, for the tables of docs/PERFORMANCE.md. Run it on an
# otherwise idle machine (the 1-minute load average is logged before every run; on a shared
# machine wall times are upper bounds). Usage:
#   scripts/bench-issue7.sh BUILD_DIR OUT_DIR [REPEATS] [MPI_BUILD_DIR]
# BUILD_DIR needs the targets bench_dsmc, bench_edmd, bench_memory and grainbath; MPI_BUILD_DIR (optional) a grainbath
# built with -DGRAINBATH_MPI=ON, for the 1-process vs 2-rank figure of the DSMC-1 case.
# Writes OUT_DIR/machine.txt (CPU model, caches, git commit), OUT_DIR/dsmc.txt (medians, bench/dsmc_medians.py), OUT_DIR/edmd/*.json
# (scripts/bench-edmd.sh; table: scripts/bench-edmd-table.py OUT_DIR/edmd), OUT_DIR/edmd-case.txt
# (10^6 disks as a case: engine and whole-run rates), OUT_DIR/free-cooling.txt (10^6 grains, one
# cell against collision groups) and OUT_DIR/mpi.txt.
set -eu
build=$1
out=$2
reps=${3:-3}
mpibuild=${4:-}
here=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"
py=/usr/bin/python3

# The machine first: the VM under this project changed between sessions (AMD EPYC to Intel
# Xeon on 2026-11-26) and the tables are only comparable on the same hardware.
{
  echo "== machine ($(date -u '+%Y-%m-%d %H:%M:%S') UTC)"
  grep -m1 'model name' /proc/cpuinfo || true
  lscpu 2>/dev/null | grep -E '^(CPU\(s\)|Model|CPU family|L1d|L2|L3|CPU max MHz|CPU MHz)' || true
  echo "AVX2: $(grep -qw avx2 /proc/cpuinfo && echo yes || echo no), AVX-512F: $(grep -qw avx512f /proc/cpuinfo && echo yes || echo no)"
  echo "git: $(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)"
} | tee "$out/machine.txt"

echo "== DSMC ($(date -u +%H:%M:%S), $(uptime))" | tee "$out/dsmc.txt"
"$py" "$here/bench/dsmc_medians.py" "$build/bench/bench_dsmc" "$reps" 'DSMC1_SpartaBox/1/' 'DSMC1_SpartaBox/2/' 'DSMC1_SpartaBox_Bird/1/' 'DSMC1_SpartaBox_Bird/2/' \
  'DSMC1_WalledBox/1/' 'DSMC1_WalledBox/2/' \
  'DSMC2_HomogeneousBath/1/' 'DSMC2_HomogeneousBath/2/' 'StreamTriad' | tee -a "$out/dsmc.txt"
"$py" "$here/bench/dsmc_medians.py" "$build/bench/bench_dsmc" 1 'DSMC1_SpartaBox_1e7/1/' 'DSMC1_SpartaBox_1e7/2/' \
  | tee -a "$out/dsmc.txt"

echo "== DSMC free cooling as a case ($(date -u +%H:%M:%S), $(uptime))" | tee "$out/free-cooling.txt"
# bench/dsmc-free-cooling1e6: 10^6 grains, no medium, 300 steps; one cell (collision_group = 0)
# against the collision groups (the default), 1 and 2 threads: step-loop ns per grain-step
r=1
while [ "$r" -le "$reps" ]; do
  for cfg in "1 0" "1 4096" "2 0" "2 4096"; do
    set -- $cfg
    dir="$out/free-cooling-r$r"
    load=$(cut -d' ' -f1 /proc/loadavg)
    "$build/grainbath" run "$here/bench/dsmc-free-cooling1e6" --out "$dir" --set run.threads="$1" \
      --set dsmc.collision_group="$2" -q > /dev/null
    "$py" -c "import json,sys; d=json.load(open(sys.argv[1])); p=d['performance']; print('rep $r load=$load threads=$1 collision_group=$2 wall_seconds=%.3f loop_seconds=%.3f loop_ns_per_grain_step=%.2f grain_candidates=%d' % (p['wall_seconds'], p['loop_seconds'], 1e9 / p['loop_particle_steps_per_second'], d['counters']['grain_candidates']))" "$dir/summary.json" | tee -a "$out/free-cooling.txt"
  done
  r=$((r + 1))
done

echo "== memory latency ($(date -u +%H:%M:%S), $(uptime))" | tee "$out/memory.txt"
# pointer chase (bench/bench_memory.cpp): ns per dependent load, 1 and 8 chains, 4 KiB and
# 2 MiB pages, working sets from L2 to DRAM: the floor under the EDMD figures at large N;
# and BM_PrefetchedChain: what a software prefetch (into L1 or L2) saves on a dependent chain
# (the DSMC layout benchmarks BM_GatherLayout, BM_ScatterIds and BM_ScatterGather are not part
# of the table: their command is in docs/performance/dsmc1.md)
"$build/bench/bench_memory" --benchmark_filter='BM_PointerChase|BM_PrefetchedChain|BM_ReuseAfterTouch|BM_DiskNeighbourScan' \
  --benchmark_repetitions="$reps" --benchmark_report_aggregates_only=true 2>&1 \
  | grep -E '_median' | tee -a "$out/memory.txt"

echo "== EDMD ($(date -u +%H:%M:%S), $(uptime))"
sh "$here/scripts/bench-edmd.sh" "$build" "$out/edmd" "$reps"
"$py" "$here/scripts/bench-edmd-table.py" "$out/edmd" | tee "$out/edmd.txt"

echo "== EDMD as a case ($(date -u +%H:%M:%S), $(uptime))" | tee "$out/edmd-case.txt"
# bench/edmd-disks1e6: 10^6 disks over 13 collisions per disk with the default measurements
# (calendar re-bases, a rebuild, pair statistics included): engine and whole-run rates
r=1
while [ "$r" -le "$reps" ]; do
  dir="$out/edmd-case-r$r"
  load=$(cut -d' ' -f1 /proc/loadavg)
  "$build/grainbath" run "$here/bench/edmd-disks1e6" --out "$dir" -q > /dev/null
  "$py" -c "import json,sys; p=json.load(open(sys.argv[1]))['performance']; print('rep $r load=$load wall_seconds=%.2f engine_seconds=%.2f collisions_per_second=%.0f overall_collisions_per_second=%.0f' % (p['wall_seconds'], p['engine_seconds'], p['collisions_per_second'], p['overall_collisions_per_second']))" "$dir/summary.json" | tee -a "$out/edmd-case.txt"
  r=$((r + 1))
done

if [ -n "$mpibuild" ]; then
  # DSMC-1 as a case (bench/mpi-dsmc1, 200 steps): the same build as a plain process and as
  # 2 ranks; results.h5 must be identical (h5diff silent), the wall times give the speed-up.
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE
  : > "$out/mpi.txt"
  r=1
  while [ "$r" -le "$reps" ]; do
    for np in 1 2; do
      dir="$out/mpi-np$np-r$r"
      load=$(cut -d' ' -f1 /proc/loadavg)
      if [ "$np" = 1 ]; then
        "$mpibuild/grainbath" run "$here/bench/mpi-dsmc1" --out "$dir" --set dsmc.t_end=17.724 -q
      else
        mpirun --oversubscribe --bind-to none -np 2 "$mpibuild/grainbath" run "$here/bench/mpi-dsmc1" --out "$dir" \
          --set dsmc.t_end=17.724 -q
      fi
      wall=$("$py" -c "import json,sys; print(json.load(open(sys.argv[1]))['performance']['wall_seconds'])" "$dir/summary.json")
      echo "np=$np rep=$r load=$load wall_seconds=$wall" | tee -a "$out/mpi.txt"
    done
    h5diff --exclude-path /parameters "$out/mpi-np1-r$r/results.h5" "$out/mpi-np2-r$r/results.h5" \
      && "$py" "$here/tests/same_summary.py" "$out/mpi-np1-r$r/summary.json" "$out/mpi-np2-r$r/summary.json" \
      && echo "rep $r: results.h5 and summary.json (state.hash included) identical for 1 and 2 ranks" | tee -a "$out/mpi.txt"
    r=$((r + 1))
  done
fi
echo "== end ($(date -u +%H:%M:%S), $(uptime))"
