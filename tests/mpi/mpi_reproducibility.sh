#!/usr/bin/env bash
# Bitwise reproducibility of the MPI domain decomposition (docs/dsmc.md, "MPI domain
# decomposition"): the same case and seed run
#   - as a plain process (no launcher: MPI is not initialised),
#   - under mpirun with 1 rank, with 2 ranks, and with 2 ranks x 2 OpenMP threads,
#   - and, if PLAIN_GRAINBATH names a non-MPI build, by the plain build,
# must give results.h5 files whose datasets and attributes are identical (h5diff, exact;
# /parameters is left out because run.threads differs) and identical summary.json numbers
# (performance.* left out). Then checkpoint/restart across rank counts: a 2-rank run that
# keeps its checkpoints, resumed from its mid-run checkpoint with 1 rank, and a plain run's
# checkpoint resumed with 2 ranks, must both end bitwise where the uninterrupted run ended.
# Every fresh multi-rank run must also have started distributed: no rank ever held the
# whole population (performance.rank_peak_particles < dsmc.particles).
#
# usage: mpi_reproducibility.sh GRAINBATH CASE_DIR WORK_DIR CHECK...
#   CHECK: np1 | np2 | np2t2 | np3 | np4 | np4t2 | np3tiled | np2unfused | checkpoint (each compared with the plain run)
#          rebalance (the 2-rank run must have moved its boundary at least once)
#          multihop (the 4-rank run must have forwarded grains across two ranks in a step)
set -euo pipefail
exe=$1
case_dir=$2
work=$3
shift 3
checks=("$@")
plain=${PLAIN_GRAINBATH:-}
source "$(dirname "$0")/mpi_env.sh"

fresh_work_dir "$work"
fail=0
same() { same_results "$@"; }  # same REF OTHER LABEL (mpi_env.sh)
particles=$(sed -n 's/^particles *= *//p' "$case_dir/case.toml")
distributed() {  # distributed RUN_DIR LABEL: a fresh multi-rank run never held every grain on one rank
  python3 - "$1/summary.json" "$2" "$particles" "$work/plain/summary.json" <<'PY' || fail=1
import json, sys
p = json.load(open(sys.argv[1]))["performance"]
n = int(sys.argv[3])
# the particle-steps behind the rates are every rank's, as in the plain run (rank 0's own
# alone passed every other test: mutation audit of the decomposition, D46, D62)
plain = json.load(open(sys.argv[4]))["performance"]
steps, plain_steps = (q["particle_steps_per_second"] * q["wall_seconds"] for q in (p, plain))
if abs(steps / plain_steps - 1.0) > 1e-9:
    print("FAIL %s: %.6g particle-steps behind performance.particle_steps_per_second, the plain run %.6g"
          % (sys.argv[2], steps, plain_steps)); sys.exit(1)
print("     %s: at most %d of %d grains on one rank; %d migrations, at most %d rank(s) crossed in a step"
      % (sys.argv[2], p["rank_peak_particles"], n, p["migrants"], p["migration_max_hops"]))
if not p["rank_peak_particles"] < n:
    print("FAIL %s: a rank held the whole population (the start is not distributed)" % sys.argv[2]); sys.exit(1)
# the load imbalance is the heaviest rank's share over the mean share (docs/OUTPUT.md): never
# below 1 (it read 0.5 with 2 ranks when the factor of the rank count was dropped)
if not p["rank_load_imbalance"] >= 1.0:
    print("FAIL %s: rank_load_imbalance = %g < 1" % (sys.argv[2], p["rank_load_imbalance"])); sys.exit(1)
PY
}

"$exe" run "$case_dir" --out "$work/plain" -q > /dev/null
if [ -n "$plain" ] && [ -x "$plain" ]; then
  "$plain" run "$case_dir" --out "$work/plainbuild" -q > /dev/null
  same "$work/plain" "$work/plainbuild" "plain (non-MPI) build"
fi
checked_2ranks=""
for check in "${checks[@]}"; do
  case "$check" in
    np1)
      mpi 1 run "$case_dir" --out "$work/np1" -q > /dev/null
      same "$work/plain" "$work/np1" "1 rank" ;;
    np2)
      mpi 2 run "$case_dir" --out "$work/np2" -q > /dev/null
      same "$work/plain" "$work/np2" "2 ranks"
      distributed "$work/np2" "2 ranks"
      checked_2ranks="$work/np2" ;;
    np2t2)
      mpi 2 run "$case_dir" --out "$work/np2t2" -q --set run.threads=2 > /dev/null
      same "$work/plain" "$work/np2t2" "2 ranks x 2 threads"
      distributed "$work/np2t2" "2 ranks x 2 threads"
      checked_2ranks="$work/np2t2" ;;
    np3|np4|np4t2)
      np=${check#np}
      np=${np%t2}
      threads=()
      label="$np ranks"
      if [[ $check == *t2 ]]; then threads=(--set run.threads=2); label="$np ranks x 2 threads"; fi
      mpi "$np" run "$case_dir" --out "$work/$check" -q "${threads[@]}" > /dev/null
      same "$work/plain" "$work/$check" "$label"
      distributed "$work/$check" "$label" ;;
    np3tiled)
      # the fused step's tiled block order (GRAINBATH_DSMC_TILE_ROWS forces it in a small 3D
      # box; each rank takes its own blocks in that order): still the plain run's bits
      GRAINBATH_DSMC_TILE_ROWS=2 mpi 3 run "$case_dir" --out "$work/np3tiled" -q > /dev/null
      same "$work/plain" "$work/np3tiled" "3 ranks, tiled block order"
      distributed "$work/np3tiled" "3 ranks, tiled block order" ;;
    np2unfused)
      # the separate passes on 2 ranks (stream, migrate, sort, collide: GRAINBATH_DSMC_UNFUSED)
      # against the plain run's fused step: boxes with walls take the fused step since
      # 2026-12-05, and both paths must still give the same bits
      GRAINBATH_DSMC_UNFUSED=1 mpi 2 run "$case_dir" --out "$work/np2unfused" -q > /dev/null
      same "$work/plain" "$work/np2unfused" "2 ranks, separate passes"
      distributed "$work/np2unfused" "2 ranks, separate passes" ;;
    multihop)
      # after np4: some grain must have crossed two ranks' cells in one step (forwarded)
      python3 - "$work/np4/summary.json" <<'PY' || fail=1
import json, sys
h = json.load(open(sys.argv[1]))["performance"]["migration_max_hops"]
if h < 2:
    print("FAIL multihop: no grain crossed more than one rank in a step (max %d): the test does not test forwarding" % h)
    sys.exit(1)
print("ok   4 ranks: grains forwarded across %d ranks in one step" % h)
PY
      ;;
    checkpoint)
      # checkpoint/restart across rank counts: checkpoints at mid-run plus one step, kept (a
      # step after a sample: in a medium the second bath half is then still owed,
      # State::bath_half_pending, and must travel in the checkpoint); the 2-rank run with
      # checkpoints is itself compared with the plain run
      t_end=$(sed -n 's/^t_end *= *//p' "$case_dir/case.toml")
      dt=$(sed -n 's/^dt *= *//p' "$case_dir/case.toml")
      half=$(python3 -c "print($t_end / 2 + $dt)")
      ck=(--set checkpoint.every=$half --set checkpoint.keep=true)
      mpi 2 run "$case_dir" --out "$work/ck2" -q "${ck[@]}" > /dev/null
      same "$work/plain" "$work/ck2" "2 ranks writing checkpoints"
      distributed "$work/ck2" "2 ranks writing checkpoints"
      # the mid-run checkpoint: the older of the two kept (keep = true also keeps the end's)
      mid=$(ls "$work/ck2.checkpoints" | sort | head -1)
      if grep -q '^\[background\]' "$case_dir/case.toml"; then
        # the 13th of the checkpoint's integer scalars (src/dsmc/checkpoint.cpp, pack; the
        # field batch segments follow it)
        pending=$(h5dump -y -w 0 -d /scalars/integer "$work/ck2.checkpoints/$mid" \
          | sed -n '/DATA {/,/}/p' | tr -d ' ' | grep -v 'DATA\|}' | awk -F, '{print $13}')
        [ "$pending" = 1 ] || { echo "FAIL the mid-run checkpoint does not owe a bath half (flag '$pending'): the test does not test it"; exit 1; }
        echo "ok   the mid-run checkpoint owes the second bath half of its step"
      fi
      checked_2ranks="$work/ck2"
      mkdir -p "$work/resume1.checkpoints"
      cp "$work/ck2.checkpoints/$mid" "$work/resume1.checkpoints/"
      mpi 1 run "$case_dir" --out "$work/resume1" -q "${ck[@]}" --resume > /dev/null 2>&1
      same "$work/plain" "$work/resume1" "2-rank checkpoint resumed with 1 rank"
      "$exe" run "$case_dir" --out "$work/ck1" -q "${ck[@]}" > /dev/null
      mkdir -p "$work/resume2.checkpoints"
      cp "$work/ck1.checkpoints/$(ls "$work/ck1.checkpoints" | sort | head -1)" "$work/resume2.checkpoints/"
      mpi 2 run "$case_dir" --out "$work/resume2" -q "${ck[@]}" --resume > /dev/null 2>&1
      same "$work/plain" "$work/resume2" "plain checkpoint resumed with 2 ranks" ;;
    rebalance) ;;
    *) echo "unknown check $check"; exit 2 ;;
  esac
done
# the test must exercise what it claims: 2 ranks, and (if asked) boundaries that moved
if [ -n "$checked_2ranks" ]; then
  need=0
  [[ " ${checks[*]} " == *" rebalance "* ]] && need=1
  calls=0  # the balances tried: one every rebalance_every steps (default 50, docs/CASE_FILE.md)
  if [ "$need" = 1 ]; then
    every=$(sed -n 's/^rebalance_every *= *//p' "$case_dir/case.toml")
    calls=$(python3 -c "print(round($(sed -n 's/^t_end *= *//p' "$case_dir/case.toml") / \
$(sed -n 's/^dt *= *//p' "$case_dir/case.toml")) // ${every:-50})")
  fi
  python3 - "$checked_2ranks/summary.json" $need "$calls" <<'PY' || fail=1
import json, sys
p = json.load(open(sys.argv[1]))["performance"]
calls = int(sys.argv[3])
print("     2 ranks: %d rebalances in %d balances tried, load imbalance %.3f at the last"
      % (p["rank_rebalances"], calls, p["rank_load_imbalance"]))
if p["ranks"] != 2 or p["rank_rebalances"] < int(sys.argv[2]):
    print("FAIL: expected 2 ranks and at least %s rebalance(s)" % sys.argv[2]); sys.exit(1)
# a balance that keeps the boundaries moves nothing and is not counted: in these cases most
# balances keep them (a no-op counted as a rebalance passed every test: mutation audit of the
# decomposition, D44)
if int(sys.argv[2]) and p["rank_rebalances"] >= calls:
    print("FAIL: every one of the %d balances counted as a move of the boundaries" % calls); sys.exit(1)
# both ranks must hold grains (imbalance 2 = one rank had everything: the decomposition bug
# fixed on 2026-11-27, under which "2 ranks" ran on one)
if p["rank_load_imbalance"] >= 1.99:
    print("FAIL: one rank held every grain (load imbalance %.3f)" % p["rank_load_imbalance"]); sys.exit(1)
PY
fi
exit $fail
