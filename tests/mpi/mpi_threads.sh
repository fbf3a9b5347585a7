#!/usr/bin/env bash
# `[run] threads = 0` on a run split over MPI ranks (src/cli/commands.cpp): the ranks on one
# machine share its cores, cores / ranks threads each, at least 1 (all cores per rank made 2
# ranks x 2 threads spin on 2 cores). Checked with 2 ranks: performance.threads in
# summary.json (rank 0's count) is max(1, nproc / 2); an explicit count is kept.
# usage: mpi_threads.sh GRAINBATH CASE_DIR WORK_DIR
set -euo pipefail
exe=$1
case_dir=$2
work=$3
source "$(dirname "$0")/mpi_env.sh"
fresh_work_dir "$work"
fail=0
threads_of() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['performance']['threads'])" "$1/summary.json"; }
expected=$(( $(nproc) / 2 )); [ "$expected" -ge 1 ] || expected=1
mpi 2 run "$case_dir" --out "$work/auto" -q --set run.threads=0 > /dev/null
got=$(threads_of "$work/auto")
if [ "$got" = "$expected" ]; then
  echo "ok   2 ranks, threads = 0: $got thread(s) per rank on $(nproc) cores"
else
  echo "FAIL 2 ranks, threads = 0: $got thread(s) per rank, expected $expected on $(nproc) cores"; fail=1
fi
mpi 2 run "$case_dir" --out "$work/two" -q --set run.threads=2 > /dev/null 2>&1
got=$(threads_of "$work/two")
if [ "$got" = 2 ]; then
  echo "ok   2 ranks, threads = 2: kept"
else
  echo "FAIL 2 ranks, threads = 2: $got thread(s)"; fail=1
fi
exit $fail
