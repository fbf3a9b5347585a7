#!/usr/bin/env bash
# The MPI tests' time limit (`within` in mpi_env.sh) must leave no rank behind. A rank that
# ignores SIGTERM (a stand-in for a rank stuck in a collective) outlives an mpirun that is
# killed before it has stopped its ranks (`timeout -k 0.5 3 mpirun ...`: both ranks left); `within` runs mpirun in a session of its own and kills what is left of
# that session. Checked: the limit is reported (exit 124), no process of the run survives,
# a run that finishes keeps its exit status, and a run that finishes leaves nothing either.
#
# usage: mpi_within.sh GRAINBATH
set -euo pipefail
exe=$1
source "$(dirname "$0")/mpi_env.sh"
fail=0
# a marker no other process on the machine carries: sleep's argument
marker="$((RANDOM % 900 + 100)).$$"
rc=0
# mpirun is killed half a second after its SIGTERM, before it can stop the ranks itself
WITHIN_KILL_AFTER=0.5 within 3 mpirun --oversubscribe --bind-to none -np 2 bash -c 'trap "" TERM; exec sleep "$0"' "$marker" \
  2> /dev/null || rc=$?
sleep 1
left=$(pgrep -f "sleep $marker" | tr '\n' ' ' || true)
if { [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; } && [ -z "$left" ]; then
  echo "ok   two ranks that ignore SIGTERM: limit reported (exit $rc), none left running"
else
  echo "FAIL two ranks that ignore SIGTERM: exit $rc (124 or 137 expected), left running: ${left:-none}"
  [ -n "$left" ] && kill -KILL $left
  fail=1
fi
rc=0
within 60 mpirun --oversubscribe --bind-to none -np 2 bash -c 'exit 3' || rc=$?
if [ "$rc" -ne 0 ] && [ "$rc" -ne 124 ]; then
  echo "ok   a failing run keeps its non-zero exit status ($rc)"
else
  echo "FAIL a failing run: exit $rc"; fail=1
fi
rc=0
within 60 mpirun --oversubscribe --bind-to none -np 2 "$exe" --version > /dev/null || rc=$?
if [ "$rc" -eq 0 ]; then
  echo "ok   a run that finishes: exit 0"
else
  echo "FAIL a run that finishes: exit $rc"; fail=1
fi
exit $fail
