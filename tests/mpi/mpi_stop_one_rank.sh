#!/usr/bin/env bash
# A stop request that reaches one rank only (SIGTERM sent to one process, not through mpirun:
# a user's `kill`, a scheduler's signal to one node) stops every rank at the same step with a
# checkpoint: the ranks agree on stop requests with a bitwise OR at every step
# (src/dsmc/driver.cpp, Decomposition::any_bits). The run then resumed on 2 ranks ends bitwise
# where the plain run ends. (Mutation audit of the decomposition, D20: with an AND there, the
# signalled rank ran on to the end without a checkpoint and every other test passed.)
#
# The signal goes to rank 1 (the rank that neither writes nor prints) as soon as it has
# installed its stop handlers (SIGTERM caught: bit 15 of SigCgt in /proc/PID/status), so it
# always arrives before the run's end; a request that early stops the run at its first step.
#
# usage: mpi_stop_one_rank.sh GRAINBATH CASE_DIR WORK_DIR
set -euo pipefail
exe=$1
case_dir=$2
work=$3
source "$(dirname "$0")/mpi_env.sh"
fresh_work_dir "$work"
fail=0

"$exe" run "$case_dir" --out "$work/plain" -q > /dev/null

mpi 2 run "$case_dir" --out "$work/stopped" -q > "$work/stopped.log" 2>&1 &
launcher=$!
stop_rank "$launcher" "^$exe run " 1 "$work/stopped.log" "rank 1 was not seen catching SIGTERM" catches_sigterm
rc=$stopped_rc
if [ "$rc" != 130 ]; then
  echo "FAIL: the stopped run exited with $rc, not 130 (stopped on request)"; cat "$work/stopped.log"; fail=1
fi
files=$(ls "$work/stopped.checkpoints" 2> /dev/null || true)
if [ "$(echo "$files" | grep -c 'h5$')" != 1 ]; then
  echo "FAIL: expected one checkpoint from the stop, found: ${files:-none}"; exit 1
fi
echo "ok   SIGTERM to rank 1 only: both ranks stopped with one checkpoint ($files), exit 130"

mpi 2 run "$case_dir" --out "$work/stopped" -q --resume > "$work/resumed.log" 2>&1 ||
  { echo "FAIL: the resume failed:"; cat "$work/resumed.log"; exit 1; }
same_results "$work/plain" "$work/stopped" "stopped on one rank, resumed on 2 ranks"
exit $fail
