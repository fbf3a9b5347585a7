#!/usr/bin/env bash
# MPI ensemble mode: `mpirun -np 2 grainbath sweep CASE --set run.seed=...` runs the replicas
# on the ranks (each alone) and rank 0 merges them; the merged ensemble.json (mean over
# replicas and its standard error) must equal the one of the process-parallel sweep of the
# same seeds, number for number, and every replica directory must hold its results.
#
# usage: mpi_ensemble.sh GRAINBATH CASE_DIR WORK_DIR
set -euo pipefail
exe=$1
case_dir=$2
work=$3
source "$(dirname "$0")/mpi_env.sh"
fresh_work_dir "$work"
seeds=1,2,3,4,5
"$exe" sweep "$case_dir" --set run.seed=$seeds --out "$work/fork" -j 2 > /dev/null 2>&1
mpi 2 sweep "$case_dir" --set run.seed=$seeds --out "$work/mpi" > /dev/null 2>&1
for k in 0 1 2 3 4; do
  d=$(ls -d "$work"/mpi/variant-${k}_* | grep -v '\.log$')
  [ -s "$d/results.h5" ] && [ -s "$d/summary.json" ] || { echo "FAIL: replica $k has no results ($d)"; exit 1; }
done
merged=$(same_ensemble "$work/fork/ensemble.json" "$work/mpi/ensemble.json" 5) || { echo "$merged"; exit 1; }
read -r T T_se <<< "$merged"
echo "ok   MPI ensemble of 5 replicas: T = $T +- $T_se, identical to the process-parallel sweep"

# The notes of an MPI sweep's variants (review 3): the ranks run the variants in-process,
# each into its .log, after the sweep has validated them all in that process; a note
# (here: the file's restitution.e, which --set restitution.law=elastic drops) must be in the
# log of the variant it concerns, not only on the sweep's stderr.
mpi 2 sweep "$case_dir" --set restitution.law=elastic,constant --set dsmc.t_end=0.2 --set sampling.steady_from=0.1 \
  --out "$work/notes" > /dev/null 2>&1
log=$(ls "$work"/notes/variant-0_*.log)
grep -q "note: .*restitution.e: ignored" "$log" || { echo "FAIL: the elastic variant's log lacks its note ($log):"; cat "$log"; exit 1; }
# (other notes, e.g. that the short window is too short to check the blocked errors, are the
# variant's own)
if grep -q "note: .*restitution" "$(ls "$work"/notes/variant-1_*.log)"; then echo "FAIL: the constant-e variant's log has the elastic variant's note"; exit 1; fi
echo "ok   MPI sweep: each variant's notes in its own log"
