#!/usr/bin/env bash
# The MPI sweep's own paths (src/cli/sweep.cpp, `mpi::active()`), beyond the ensemble merge
# of mpi_ensemble.sh: the ranks share the variants (rank r runs r, r + size, ...) and learn
# from each other, in collectives, what became of them.
#  1. A stop request that reaches one rank only, during one of its variants: that variant
#     stops with a checkpoint and the rank starts no more; the other rank finishes its own.
#     Rank 0 then says, once, exactly what became of each variant and the `mpirun -np 2 ...
#     --resume` that continues; every rank exits 130. The resumed sweep ends with the
#     ensemble of the process-parallel sweep of the same seeds, number for number.
#  2. A variant that fails on rank 1 (the fault hook GRAINBATH_FAULT_NONFINITE_SAMPLE, set in
#     rank 1's environment only): reported by rank 1 with its log, the sweep exits 1, and
#     rank 0's table and ensemble hold the replicas that finished.
#     2b: then a stop request to rank 1 while it waits in the collective for rank 0: it
#     survives it, rank 0 finishes, says that 2 failed (not "not started"), exits 130, and
#     --resume runs the failed ones again to the process-parallel sweep's ensemble.
#  3. A second sweep into the same --out moves the first aside once (rank 0 alone moves and
#     says so); a move aside that fails stops every rank with exit 2, said once, the earlier
#     sweep kept; a --resume where no sweep was is refused on every rank (exit 2), said once,
#     and nothing is written.
#  4. A stop request to a rank that has no variant (3 ranks, 2 variants), waiting for the
#     others in a collective: the sweep's own handler takes it (the rank is not killed); the
#     others finish, and the sweep stops with 130 and no table.
#
# usage: mpi_sweep.sh GRAINBATH CASE_DIR WORK_DIR FAIL_RENAME_SHIM
set -euo pipefail
exe=$1
case_dir=$2
work=$3
shim=$4  # libgrainbath_test_fail_rename.so (tests/cli/fail_rename.cpp)
source "$(dirname "$0")/mpi_env.sh"
# ld.so ignores a preload it cannot find, with a warning, and the failed-move check below would
# then see a move that succeeded: without the shim there is nothing to test
[ -f "$shim" ] || { echo "FAIL: no rename shim at $shim (cmake --build build-mpi --target grainbath_mpi_tests)"; exit 1; }
fresh_work_dir "$work"
fail=0
seeds=1,2,3,4
# ≈ 2 s a variant on one core; a checkpoint every 2 time units (the stop must find one)
long=(--set run.seed=$seeds --set dsmc.t_end=60 --set dsmc.particles=20000 --set checkpoint.every=2)

"$exe" sweep "$case_dir" "${long[@]}" --out "$work/fork" -j 2 > /dev/null 2>&1

# ---- 1. a stop request to rank 1 only, once its variant (variant 1) has written a checkpoint
mpi 2 sweep "$case_dir" "${long[@]}" --out "$work/mpi" > "$work/stopped.out" 2> "$work/stopped.err" &
launcher=$!
variant1_checkpointed() { ls "$work"/mpi/variant-1_*.checkpoints/*.h5 > /dev/null 2>&1; }
stop_rank "$launcher" "^$exe sweep .* --out $work/mpi\$" 1 "$work/stopped.err" "variant 1 wrote no checkpoint on rank 1" variant1_checkpointed
rc=$stopped_rc
if [ "$rc" != 130 ]; then echo "FAIL: the stopped sweep exited with $rc, not 130"; cat "$work/stopped.err"; fail=1; fi
said=$(grep -c "sweep: interrupted: " "$work/stopped.err" || true)
expected="sweep: interrupted: 2 of 4 variants finished, 1 stopped with a checkpoint, 1 not started; no table was made."
if [ "$said" != 1 ] || ! grep -qF "$expected" "$work/stopped.err"; then
  echo "FAIL: expected once: '$expected'; the sweep said:"; cat "$work/stopped.err"; fail=1
fi
if ! grep -qE "^  mpirun -np 2 .* sweep .* --resume" "$work/stopped.err"; then
  echo "FAIL: no 'mpirun -np 2 ... --resume' to continue with:"; cat "$work/stopped.err"; fail=1
fi
grep -q "rank 1: stopped     variant-1_.*, with a checkpoint" "$work/stopped.err" ||
  { echo "FAIL: rank 1 did not say that variant 1 stopped with a checkpoint:"; cat "$work/stopped.err"; fail=1; }
if [ -e "$work/mpi/sweep.tsv" ]; then echo "FAIL: an interrupted sweep wrote a table"; fail=1; fi
[ "$fail" = 0 ] && echo "ok   SIGTERM to rank 1 during variant 1: 2 finished, 1 stopped with a checkpoint, 1 not started, exit 130"

# the variants that finished are kept as they are (not run again)
kept() { for k in 0 2; do stat -c "%i %Y %s" "$work"/mpi/variant-${k}_*/summary.json "$work"/mpi/variant-${k}_*/results.h5; done; }
before=$(kept)
mpi 2 sweep "$case_dir" "${long[@]}" --out "$work/mpi" --resume > "$work/resumed.out" 2> "$work/resumed.err" ||
  { echo "FAIL: the resumed sweep failed:"; cat "$work/resumed.err"; exit 1; }
if [ "$(kept)" != "$before" ]; then echo "FAIL: the resume ran the finished variants again"; fail=1; fi
if [ "$(grep -c "^table: " "$work/resumed.out" || true)" != 1 ]; then
  echo "FAIL: the table should be made once, by rank 0:"; cat "$work/resumed.out"; fail=1
fi
grep -q "sweep: resuming: 2 of 4 variants finished earlier" "$work/resumed.err" ||
  { echo "FAIL: the resume did not count the 2 finished variants:"; cat "$work/resumed.err"; fail=1; }
if merged=$(same_ensemble "$work/fork/ensemble.json" "$work/mpi/ensemble.json" 4); then
  echo "ok   resumed on 2 ranks: ensemble.json identical to the process-parallel sweep's (4 replicas)"
else
  echo "FAIL: the resumed MPI sweep's ensemble: $merged"; fail=1
fi

# ---- 2. the variants of rank 1 fail (a non-finite sample at its third sample); rank 0's finish
short=(--set run.seed=$seeds --set dsmc.t_end=1 --set sampling.steady_from=0.5)
rc=0
within "${MPI_RUN_LIMIT:-240}" mpirun --oversubscribe --bind-to none \
  -np 1 "$exe" sweep "$case_dir" "${short[@]}" --out "$work/failing" : \
  -np 1 env GRAINBATH_FAULT_NONFINITE_SAMPLE=3 "$exe" sweep "$case_dir" "${short[@]}" --out "$work/failing" \
  > "$work/failing.out" 2> "$work/failing.err" || rc=$?
if [ "$rc" != 1 ]; then echo "FAIL: a sweep with failed variants exited with $rc, not 1"; cat "$work/failing.err"; fail=1; fi
for k in 1 3; do
  grep -q "rank 1: FAILED      variant-${k}_.*exit code 1: see $work/failing/variant-${k}_.*\.log" "$work/failing.err" ||
    { echo "FAIL: rank 1 did not report variant $k as failed with its log:"; cat "$work/failing.err"; fail=1; }
done
grep -q "ensemble of 2 replicas" "$work/failing.out" ||
  { echo "FAIL: the table should merge the 2 replicas that finished:"; cat "$work/failing.out"; fail=1; }
if [ "$(grep -c "^variant-[0-3]_seed_[1-4]	[1-4]	" "$work/failing/sweep.tsv" || true)" != 4 ]; then
  echo "FAIL: sweep.tsv should list all 4 variants:"; cat "$work/failing/sweep.tsv"; fail=1
fi
if grep -q "stop requested" "$work/failing.err"; then
  echo "FAIL: rank 0 got a stop request nobody sent (mpirun aborting the job?):"; cat "$work/failing.err"; fail=1
fi
grep -q "non-finite" "$work"/failing/variant-1_*.log ||
  { echo "FAIL: variant 1's log does not say why it failed:"; cat "$work"/failing/variant-1_*.log; fail=1; }
[ "$fail" = 0 ] && echo "ok   variants failing on rank 1: reported with their logs, exit 1, the 2 finished replicas merged"

# ---- 2b. the same failures on rank 1, then a stop request to rank 1 while it waits for rank 0
# (its loop done, in the collective): it must not die of it (the sweep's own handlers hold
# between and after variants), rank 0 finishes its own variants, and rank 0 says what became
# of rank 1's: failed, not "not started". --resume then runs the failed ones again.
within "${MPI_RUN_LIMIT:-240}" mpirun --oversubscribe --bind-to none \
  -np 1 "$exe" sweep "$case_dir" "${long[@]}" --out "$work/failstop" : \
  -np 1 env GRAINBATH_FAULT_NONFINITE_SAMPLE=3 "$exe" sweep "$case_dir" "${long[@]}" --out "$work/failstop" \
  > "$work/failstop.out" 2> "$work/failstop.err" &
launcher=$!
both_failed() { grep -q "rank 1: FAILED      variant-3_" "$work/failstop.err" 2> /dev/null; }
stop_rank "$launcher" "^$exe sweep .* --out $work/failstop\$" 1 "$work/failstop.err" "rank 1 did not report variant 3 as failed" both_failed
rc=$stopped_rc
expected="sweep: interrupted: 2 of 4 variants finished, 0 stopped with a checkpoint, 0 not started, 2 failed (their .log says why; --resume runs them again); no table was made."
if [ "$rc" != 130 ] || ! grep -qF "$expected" "$work/failstop.err"; then
  echo "FAIL: exit $rc (want 130); expected '$expected'; the sweep said:"; cat "$work/failstop.err"; fail=1
fi
# (the failed variants' checkpoints, written at the failure, hold the hook's non-finite sample
# in their series; a real non-finite state would fail again: they start afresh here)
for k in 1 3; do
  [ -d "$(ls -d "$work"/failstop/variant-${k}_*.checkpoints)" ] ||
    { echo "FAIL: variant $k left no checkpoint at its failure"; fail=1; }
  rm -rf "$work"/failstop/variant-${k}_*.checkpoints
done
mpi 2 sweep "$case_dir" "${long[@]}" --out "$work/failstop" --resume > /dev/null 2> "$work/failstop-resumed.err" ||
  { echo "FAIL: the resume of the failed variants failed:"; cat "$work/failstop-resumed.err"; exit 1; }
python3 "$(dirname "$0")/../same_summary.py" "$work/fork/ensemble.json" "$work/failstop/ensemble.json" ||
  { echo "FAIL: the failed variants run again do not give the process-parallel sweep's ensemble"; fail=1; }
[ "$fail" = 0 ] && echo "ok   failures on rank 1, then a stop to rank 1 in the collective: 2 failed said, exit 130; --resume completes the ensemble"

# ---- 3. the earlier sweep moved aside by rank 0 alone; a --resume without a sweep refused
mpi 2 sweep "$case_dir" "${short[@]}" --out "$work/failing" > /dev/null 2> "$work/again.err" ||
  { echo "FAIL: the second sweep into the same --out failed:"; cat "$work/again.err"; fail=1; }
moved=$(grep -c "sweep: the previous sweep in $work/failing was moved to $work/failing.previous" "$work/again.err" || true)
if [ "$moved" != 1 ] || [ ! -f "$work/failing.previous/sweep.tsv" ] || [ ! -f "$work/failing/sweep.tsv" ]; then
  echo "FAIL: the earlier sweep should be moved aside once (said $moved times):"; cat "$work/again.err"; fail=1
fi
mkdir "$work/empty"
rc=0
mpi 2 sweep "$case_dir" "${short[@]}" --out "$work/empty" --resume > /dev/null 2> "$work/noresume.err" || rc=$?
said=$(grep -c "no sweep to resume here" "$work/noresume.err" || true)
if [ "$rc" != 2 ] || [ "$said" != 1 ] || [ -n "$(ls -A "$work/empty")" ]; then
  echo "FAIL: --resume without a sweep: exit $rc (want 2), said $said times (want 1), wrote: $(ls -A "$work/empty")"
  cat "$work/noresume.err"; fail=1
fi
# ... and a move aside that fails (here as across file systems, by the preloaded shim of
# tests/cli/fail_rename.cpp) stops every rank at once: rank 0 says it once and aborts the job,
# whose other ranks would otherwise wait for it in the barrier after the move (audit S20)
cp -r "$work/failing" "$work/failing.before"
rc=0
LD_PRELOAD=$shim GRAINBATH_TEST_FAIL_RENAME_TO=failing.previous MPI_RUN_LIMIT=60 \
  mpi 2 sweep "$case_dir" "${short[@]}" --out "$work/failing" > /dev/null 2> "$work/nomove.err" || rc=$?
said=$(grep -c "error: $work/failing: cannot move the previous sweep aside to $work/failing.previous (Invalid cross-device link)" \
  "$work/nomove.err" || true)
if [ "$rc" != 2 ] || [ "$said" != 1 ] || ! diff -r "$work/failing.before" "$work/failing" > /dev/null; then
  echo "FAIL: a failed move aside: exit $rc (want 2), said $said times (want 1), the earlier sweep kept:"
  diff -r "$work/failing.before" "$work/failing" | head; cat "$work/nomove.err"; fail=1
fi
[ "$fail" = 0 ] && echo "ok   a second sweep moves the first aside once; a failed move stops both ranks; --resume without a sweep refused on both ranks"

# ---- 4. a rank with no variant (3 ranks, 2 variants) waits for the others in a collective; a
# stop request to it there is the sweep's to handle (no run's handler was ever installed in
# that process): it stops the sweep once the others finish, instead of killing the rank
mpi 3 sweep "$case_dir" --set run.seed=1,2 --set dsmc.t_end=60 --set dsmc.particles=20000 --out "$work/idle" \
  > /dev/null 2> "$work/idle.err" &
launcher=$!
stop_rank "$launcher" "^$exe sweep .* --out $work/idle\$" 2 "$work/idle.err" "rank 2 was not seen catching SIGTERM" catches_sigterm
rc=$stopped_rc
expected="sweep: interrupted: 2 of 2 variants finished, 0 stopped with a checkpoint, 0 not started; no table was made."
if [ "$rc" != 130 ] || ! grep -qF "$expected" "$work/idle.err"; then
  echo "FAIL: exit $rc (want 130); expected '$expected'; the sweep said:"; cat "$work/idle.err"; fail=1
else
  echo "ok   a stop to the idle rank 2 (3 ranks, 2 variants): the others finish, the sweep stops with 130"
fi
exit $fail
