#!/usr/bin/env bash
# Tiny spatial cases under MPI (docs/dsmc.md, "MPI domain decomposition"): fewer grains than
# ranks, ranks that own no cell (more ranks than reduction blocks), a rank whose slab empties
# during the run (and one that then receives grains again), ranks whose grains all leave
# through an open face. Every run must finish (each mpirun under a timeout: a rank that skips a
# collective hangs the others, and the test must then fail, not block), and its results.h5
# (h5diff, exact; /parameters left out: run.threads) and summary.json (same_summary.py:
# every number and state.hash) must be bitwise those of the plain process. Checkpoint and
# resume across rank counts too: a run with mid-run checkpoints on R ranks, resumed from
# them on R' ranks (1 process included), must end bitwise where the plain run ended.
#
# usage: mpi_tiny.sh GRAINBATH CASES_DIR WORK_DIR
#   CASES_DIR holds tiny/, emptyslab/, refillslab/, drainslab/ and fewblocks/ (tests/mpi/cases)
set -euo pipefail
exe=$1
cases=$2
work=$3
source "$(dirname "$0")/mpi_env.sh"
fresh_work_dir "$work"
fail=0
limit=${MPI_TINY_LIMIT:-120}  # seconds per run: each takes about one; a hang is a failure
run_plain() {  # run_plain OUT ARGS...
  local out=$1; shift
  if ! timeout -k 5 "$limit" "$exe" run "$@" --out "$work/$out" -q > "$work/$out.log" 2>&1; then
    echo "FAIL $out: the plain run failed or timed out"; tail -5 "$work/$out.log"; fail=1; return 1
  fi
}
run_np() {  # run_np NP OUT ARGS...
  local np=$1 out=$2; shift 2
  local rc=0
  within "$limit" mpirun --oversubscribe --bind-to none -np "$np" "$exe" run "$@" --out "$work/$out" -q \
    > "$work/$out.log" 2>&1 || rc=$?
  if [ $rc -eq 124 ] || [ $rc -eq 137 ]; then
    echo "FAIL $out: $np ranks did not finish within $limit s (a hang)"; fail=1; return 1
  elif [ $rc -ne 0 ]; then
    echo "FAIL $out: $np ranks exited with $rc"; tail -5 "$work/$out.log"; fail=1; return 1
  fi
}
same() {  # same REF OTHER LABEL
  if ! h5diff --exclude-path /parameters "$work/$1/results.h5" "$work/$2/results.h5" > "$work/h5diff.log" 2>&1; then
    echo "FAIL $3: results.h5 differs from the plain run:"; head -20 "$work/h5diff.log"; fail=1; return
  fi
  if ! python3 "$(dirname "$0")/../same_summary.py" "$work/$1/summary.json" "$work/$2/summary.json"; then
    echo "FAIL $3: summary.json differs from the plain run"; fail=1; return
  fi
  echo "ok   $3: bitwise identical to the plain run"
}
empty_steps() {  # empty_steps OUT MIN LABEL: some rank held no grain after at least MIN steps
  python3 - "$work/$1/summary.json" "$2" "$3" <<'PY' || fail=1
import json, sys
p = json.load(open(sys.argv[1]))["performance"]
e, need = p["rank_empty_steps"], int(sys.argv[2])
print("     %s: a rank held no grain after %d step(s); %d migrants, at most %d rank(s) crossed in a step"
      % (sys.argv[3], e, p["migrants"], p["migration_max_hops"]))
if e < need:
    print("FAIL %s: expected a rank without grains for at least %d step(s): the test does not test it" % (sys.argv[3], need))
    sys.exit(1)
PY
}
refills() {  # refills OUT LABEL: some rank held grains again after holding none
  python3 - "$work/$1/summary.json" "$2" <<'PY' || fail=1
import json, sys
p = json.load(open(sys.argv[1]))["performance"]
r, e = p["rank_refills"], p["rank_empty_steps"]
print("     %s: a rank received grains again %d time(s) after holding none (%d steps without)" % (sys.argv[2], r, e))
if r < 1:
    print("FAIL %s: expected a rank to hold grains again after holding none: the test does not test it" % sys.argv[2])
    sys.exit(1)
# every refill follows a step without grains on that rank, so no rank refills more often than
# the most steps any rank spent empty (a refill counted at every step with grains passed
# every test: mutation audit of the decomposition, D39)
if r > e:
    print("FAIL %s: %d refills but at most %d steps without grains on a rank" % (sys.argv[2], r, e))
    sys.exit(1)
PY
}
# unfused CASE TAG [ARGS...]: after check's 2-rank run TAG-np2, the separate passes on 2 ranks
# (GRAINBATH_DSMC_UNFUSED) must give the plain run's bits and count the same steps without
# grains and the same refills (performance.rank_empty_steps, rank_refills, which
# same_summary.py leaves out with performance.*)
unfused() {
  local case_dir=$cases/$1 tag=$2
  shift 2
  GRAINBATH_DSMC_UNFUSED=1 run_np 2 "$tag-np2unfused" "$case_dir" "$@" || return 0
  same "$tag-plain" "$tag-np2unfused" "$tag, 2 ranks, separate passes"
  python3 - "$work/$tag-np2/summary.json" "$work/$tag-np2unfused/summary.json" "$tag" <<'PY' || fail=1
import json, sys
bad = 0
for key in ("rank_empty_steps", "rank_refills"):
    fused, separate = (json.load(open(f))["performance"][key] for f in sys.argv[1:3])
    if fused != separate:
        print("FAIL %s: %s %d (fused step) != %d (separate passes)" % (sys.argv[3], key, fused, separate))
        bad = 1
    else:
        print("ok   %s: %s %d in the fused step and the separate passes" % (sys.argv[3], key, fused))
sys.exit(bad)
PY
}
# check CASE TAG NPS CK_NP RESUME_NPS [ARGS...]: plain run; NPS ranks each; a run with
# checkpoints on CK_NP ranks (0: the plain process) resumed on each of RESUME_NPS (1: the
# plain process); every result compared with the plain run's
check() {
  local case_dir=$cases/$1 tag=$2 nps=$3 ck_np=$4 resume_nps=$5
  shift 5
  local args=("$@")
  local t_end
  t_end=$(sed -n 's/^t_end *= *//p' "$case_dir/case.toml")
  local ck=(--set checkpoint.every="$(python3 -c "print($t_end * 0.8)")" --set checkpoint.keep=true)
  run_plain "$tag-plain" "$case_dir" "${args[@]}" || return 0
  local np
  for np in $nps; do
    run_np "$np" "$tag-np$np" "$case_dir" "${args[@]}" && same "$tag-plain" "$tag-np$np" "$tag, $np ranks" &&
      empty_steps "$tag-np$np" 1 "$tag, $np ranks"
  done
  local ckrun=$tag-ck$ck_np
  if [ "$ck_np" = 0 ]; then run_plain "$ckrun" "$case_dir" "${args[@]}" "${ck[@]}" || return 0
  else run_np "$ck_np" "$ckrun" "$case_dir" "${args[@]}" "${ck[@]}" || return 0; fi
  local who="$ck_np ranks"
  [ "$ck_np" = 0 ] && who="the plain process"
  same "$tag-plain" "$ckrun" "$tag, $who writing checkpoints"
  for np in $resume_nps; do
    local out=$tag-ck$ck_np-resume$np
    mkdir -p "$work/$out.checkpoints"
    cp "$work/$ckrun.checkpoints"/* "$work/$out.checkpoints/"
    if [ "$np" = 1 ]; then run_plain "$out" "$case_dir" "${args[@]}" "${ck[@]}" --resume || continue
    else run_np "$np" "$out" "$case_dir" "${args[@]}" "${ck[@]}" --resume || continue; fi
    same "$tag-plain" "$out" "$tag, checkpoint of $who resumed on $np rank(s)"
  done
}

# 2 grains in one cell: ranks 1.. own nothing at any step (with and without the medium)
check tiny tiny "2 3 4" 3 "1 2"
check tiny tiny-nomedium "3" 0 "3" --set background.density=0
# a slab that empties during the run; with 3 ranks one rank owns no block
check emptyslab emptyslab "2 3" 2 "1 3"
# a slab that empties and then receives grains again (the fused step's arrays on a rank with
# no grains), with the medium (the bath residuals migrate) and without it
check refillslab refillslab "2" 2 "1"
refills refillslab-np2 "refillslab, 2 ranks"
unfused refillslab refillslab
check refillslab refillslab-nomedium "2" 0 "2" --set background.density=0
refills refillslab-nomedium-np2 "refillslab-nomedium, 2 ranks"
unfused refillslab refillslab-nomedium --set background.density=0
# each rank's last grains leave through an open face (not by migration)
check drainslab drainslab "2" 2 "1"
unfused drainslab drainslab
# periodic (fused step), 2 blocks on 3 and 4 ranks
check fewblocks fewblocks "3 4" 4 "1 2"
# without a medium the fused step predicts the next step's cells (SortScratch::next_cell),
# also on ranks whose grains migrate
check fewblocks fewblocks-nomedium "3" 3 "2" --set background.density=0
exit $fail
