#!/usr/bin/env bash
# Checkpoints and results of a multi-rank run without gathering the grains to rank 0
# (docs/dsmc.md, "MPI domain decomposition"; src/dsmc/checkpoint.hpp):
#  1. a 2-rank run's checkpoint file is the plain process's, byte for byte (the ranks write
#     their grains in turn into the file rank 0 created), and its results.h5 and
#     summary.json are bitwise the plain run's;
#  2. rank 0 never held every grain: its peak resident memory is within 15% of rank 1's
#     (gathering the 300,000 grains for the output made it 1.3x; measured in
#     docs/performance/mpi.md), and no rank's particle arrays held the whole population;
#  3. the plain checkpoint resumed with 1, 2 and 3 ranks ends bitwise where the plain run
#     ended, no rank held the whole population, and each rank read only its share of the
#     file (performance.checkpoint_read_bytes_*: each grain's bytes read by one rank only);
#     a flipped bit in rank 1's grains is reported as one process reports it, with the same
#     fallback to the previous checkpoint, or the same error on every rank without one;
#  4. a homogeneous run (rank 0 holds every grain, rank 1 none) writes the plain checkpoint,
#     and resumes from it with 2 ranks;
#  5. a rank that fails to write its part makes every rank stop with the same message
#     naming it (no hang): the test hook GRAINBATH_FAULT_CHECKPOINT_RANK, and a real HDF5
#     write error (rank 1 under a 1 MB file-size limit, SIGXFSZ ignored: EFBIG).
# usage: mpi_output.sh GRAINBATH CASE_DIR HOMOGENEOUS_CASE_DIR WORK_DIR
set -euo pipefail
exe=$1
case_dir=$2
homogeneous=$3
work=$4
source "$(dirname "$0")/mpi_env.sh"
fresh_work_dir "$work"
fail=0
ck=(--set checkpoint.every=0.05 --set checkpoint.keep=true)
first=  # the older of the two kept checkpoints (keep = true also keeps one of the end), set below

same_checkpoint() {  # same_checkpoint A B LABEL: the checkpoint files are the same bytes
  if cmp -s "$1" "$2"; then echo "ok   $3: checkpoint identical byte for byte"; return; fi
  echo "FAIL $3: checkpoint files differ"; h5diff "$1" "$2" | head -20 || true; fail=1
}
same_results() {  # same_results A B LABEL
  if h5diff --exclude-path /parameters "$1/results.h5" "$2/results.h5" > "$work/h5diff.log" 2>&1 &&
     python3 "$(dirname "$0")/../same_summary.py" "$1/summary.json" "$2/summary.json"; then
    echo "ok   $3: results.h5 and summary.json bitwise the plain run's"
  else
    echo "FAIL $3: results differ"; head -20 "$work/h5diff.log"; fail=1
  fi
}

# 1 and 2: the spatial case
"$exe" run "$case_dir" --out "$work/plain" -q "${ck[@]}" > /dev/null
mpi 2 run "$case_dir" --out "$work/np2" -q "${ck[@]}" > /dev/null
first=$(ls "$work/plain.checkpoints" | sort | head -1)
[ -n "$first" ] || { echo "FAIL no checkpoint written"; exit 1; }
same_checkpoint "$work/plain.checkpoints/$first" "$work/np2.checkpoints/$first" "2 ranks"
same_results "$work/plain" "$work/np2" "2 ranks"
python3 - "$work/np2/summary.json" "$case_dir/case.toml" <<'PY' || fail=1
import json, re, sys
p = json.load(open(sys.argv[1]))["performance"]
n = int(re.search(r"^particles *= *(\d+)", open(sys.argv[2]).read(), re.M).group(1))
r0, r1 = p["rank0_peak_rss_bytes"], p["other_ranks_peak_rss_bytes"]
print("     2 ranks: peak RSS rank 0 %.1f MB, rank 1 %.1f MB (ratio %.3f); at most %d of %d grains on one rank; "
      "checkpoint %.3f s" % (r0 / 1e6, r1 / 1e6, r0 / r1, p["rank_peak_particles"], n, p["checkpoint_seconds"]))
if not r0 < 1.15 * r1:
    print("FAIL: rank 0's peak memory is %.2fx rank 1's: it held more than its own grains" % (r0 / r1)); sys.exit(1)
if not p["rank_peak_particles"] < n:
    print("FAIL: a rank held the whole population"); sys.exit(1)
print("ok   2 ranks: rank 0 held no more than its own grains")
PY

# 3: resumed with 1, 2 and 3 ranks, each reading its own grains' slabs of the file
for np in 1 2 3; do
  mkdir -p "$work/resume$np.checkpoints"
  cp "$work/plain.checkpoints/$first" "$work/resume$np.checkpoints/"
  mpi $np run "$case_dir" --out "$work/resume$np" -q "${ck[@]}" --resume > /dev/null 2>&1
  same_results "$work/plain" "$work/resume$np" "plain checkpoint resumed with $np rank(s)"
done
python3 - "$work" "$case_dir/case.toml" <<'PY' || fail=1
import json, re, sys
work, case = sys.argv[1], sys.argv[2]
n = int(re.search(r"^particles *= *(\d+)", open(case).read(), re.M).group(1))
perf = {np: json.load(open("%s/resume%d/summary.json" % (work, np)))["performance"] for np in (1, 2, 3)}
if not all(p["rank_peak_particles"] < n for np, p in perf.items() if np > 1):
    print("FAIL resumed: a rank held all %d grains (it read the whole checkpoint)" % n); sys.exit(1)
# Bytes of datasets read. One process reads every array once. Several ranks: the per-grain
# arrays (7 real ones with the bath residual, and the ids: 8 x 8 bytes a grain) are read by
# one rank each, the small arrays by every rank; the plan reads each rank's equal share of
# x, y, z (3D) and keeps it, so a position is read twice only where a rank's cells hold
# other grains than its share (and the grain before each share): a little. (Before: every
# rank read the whole file and all positions once more.)
whole = perf[1]["checkpoint_read_bytes_total"]
grains = 8 * 8 * n
small = whole - grains
ok = perf[1]["checkpoint_read_bytes_rank_max"] == whole and small > 0
for np in (2, 3):
    p = perf[np]
    once = whole + (np - 1) * small  # each grain's bytes once, the small arrays on every rank
    again = p["checkpoint_read_bytes_total"] - once
    share = 1.1 * grains / np + small  # 10 %: the cells are balanced, not the grains
    print("     %d ranks: at most %.2f MB read by one rank (its share: %.2f MB; one process: %.2f MB); "
          "by all %.2f MB, of which %d bytes of positions read twice" % (
              np, p["checkpoint_read_bytes_rank_max"] / 1e6, share / 1e6, whole / 1e6,
              p["checkpoint_read_bytes_total"] / 1e6, again))
    ok = ok and 0 <= again <= 0.1 * 3 * 8 * n and p["checkpoint_read_bytes_rank_max"] <= share
if not ok:
    print("FAIL resumed: the ranks did not each read their share of the checkpoint once"); sys.exit(1)
print("ok   resumed with 2 and 3 ranks: each rank read its share of the checkpoint")
PY

# 3b: a flipped bit in a grain of rank 1's slab (particles/vx near the end: the last cells)
# is caught by the checksum the ranks compute together, with the message one process gives,
# and the previous checkpoint is used (as one process does); with no other checkpoint every
# rank stops with the error (no hang).
flip_grain() {  # flip_grain FILE INDEX: one bit of particles/vx[INDEX] (contiguous layout)
  local offset
  offset=$(h5dump -p -H -d /particles/vx "$1" | awk '/OFFSET/ {print $2}')
  python3 -c '
import sys
path, at = sys.argv[1], int(sys.argv[2]) + 8 * int(sys.argv[3]) + 3
with open(path, "r+b") as f:
    f.seek(at); b = f.read(1)[0] ^ 0x10
    f.seek(at); f.write(bytes([b]))' "$1" "$offset" "$2"
}
n_grains=$(grep -E '^particles *=' "$case_dir/case.toml" | grep -oE '[0-9]+')
newest=$(cd "$work/plain.checkpoints" && ls checkpoint-*.h5 | sort | tail -1)
for who in plain np2 none; do
  mkdir -p "$work/corrupt-$who.checkpoints"
  cp "$work/plain.checkpoints"/checkpoint-*.h5 "$work/corrupt-$who.checkpoints/"
  flip_grain "$work/corrupt-$who.checkpoints/$newest" $((n_grains - 5))
done
# (the last case: only the corrupt newest one)
find "$work/corrupt-none.checkpoints" -name 'checkpoint-*.h5' ! -name "$newest" -delete
"$exe" run "$case_dir" --out "$work/corrupt-plain" -q "${ck[@]}" --resume > /dev/null 2> "$work/corrupt-plain.log"
set +e
within 120 mpirun --oversubscribe --bind-to none -np 2 "$exe" run "$case_dir" --out "$work/corrupt-np2" -q "${ck[@]}" \
  --resume > /dev/null 2> "$work/corrupt-np2.log"
code=$?
set -e
plain_said=$(grep "checksum mismatch" "$work/corrupt-plain.log" | sed "s|$work/corrupt-plain|DIR|g" || true)
np2_said=$(grep "checksum mismatch" "$work/corrupt-np2.log" | sed "s|$work/corrupt-np2|DIR|g" || true)
if [ "$code" -eq 0 ] && [ -n "$plain_said" ] && [ "$plain_said" = "$np2_said" ]; then
  echo "ok   a flipped bit in rank 1's grains: 2 ranks say what one process says, and fall back"
  same_results "$work/plain" "$work/corrupt-np2" "2 ranks resumed from the previous checkpoint"
else
  echo "FAIL a flipped bit in rank 1's grains: exit $code (124 or 137: hung); one process said:"
  echo "$plain_said"; echo "2 ranks said:"; tail -5 "$work/corrupt-np2.log"; fail=1
fi
set +e
within 120 mpirun --oversubscribe --bind-to none -np 2 "$exe" run "$case_dir" --out "$work/corrupt-none" -q "${ck[@]}" \
  --resume > /dev/null 2> "$work/corrupt-none.log"
code=$?
set -e
said=$(grep -c "error: --resume: no valid checkpoint" "$work/corrupt-none.log" || true)
# (every rank throws it; the first to print it aborts the others, which may not print it too)
if [ "$code" -ne 0 ] && [ "$code" -ne 124 ] && [ "$code" -ne 137 ] && [ "$said" -ge 1 ] && grep -q "checksum mismatch" "$work/corrupt-none.log"; then
  echo "ok   no valid checkpoint left: exit $code, the error on $said rank(s), no hang"
else
  echo "FAIL no valid checkpoint left: exit $code (124 or 137: hung), the error on $said rank(s):"
  tail -5 "$work/corrupt-none.log"; fail=1
fi

# 4: the homogeneous case (every grain on rank 0, none on rank 1), with 20000 grains so that
# they collide in collision groups (4 of ~5000; docs/dsmc.md "Collision groups")
hk=(--set checkpoint.every=1.0 --set checkpoint.keep=true --set dsmc.particles=20000)
"$exe" run "$homogeneous" --out "$work/hplain" -q "${hk[@]}" > /dev/null
mpi 2 run "$homogeneous" --out "$work/hnp2" -q "${hk[@]}" > /dev/null 2>&1
hfirst=$(cd "$work/hplain.checkpoints" && ls checkpoint-*.h5 | head -1)
same_checkpoint "$work/hplain.checkpoints/$hfirst" "$work/hnp2.checkpoints/$hfirst" "homogeneous, 2 ranks"
same_results "$work/hplain" "$work/hnp2" "homogeneous, 2 ranks"
mkdir -p "$work/hresume2.checkpoints"
cp "$work/hplain.checkpoints/$hfirst" "$work/hresume2.checkpoints/"
mpi 2 run "$homogeneous" --out "$work/hresume2" -q "${hk[@]}" --resume > /dev/null 2>&1
same_results "$work/hplain" "$work/hresume2" "homogeneous plain checkpoint resumed with 2 ranks"

# 5: a rank that cannot write its part. expect_stop NAME DIR PATTERN: the run into DIR
# (exit status in $code, log in DIR.log) must fail without hanging, with PATTERN on at
# least one rank's output, and leave neither DIR nor a partial checkpoint behind.
expect_stop() {
  local name=$1 dir=$2 pattern=$3 said
  said=$(grep -c "$pattern" "$dir.log" || true)
  if [ "$code" -ne 0 ] && [ "$code" -ne 124 ] && [ "$code" -ne 137 ] && [ "$said" -ge 1 ] && [ ! -e "$dir" ] &&
     ! ls "$dir.checkpoints"/*.partial > /dev/null 2>&1; then
    echo "ok   $name: exit $code, the message on $said rank(s), no partial checkpoint or output left"
  else
    echo "FAIL $name: exit $code (124 or 137: hung), message on $said rank(s):"; tail -5 "$dir.log"; fail=1
  fi
}
set +e
GRAINBATH_FAULT_CHECKPOINT_RANK=1 within 120 mpirun --oversubscribe --bind-to none -np 2 -x GRAINBATH_FAULT_CHECKPOINT_RANK \
  "$exe" run "$case_dir" --out "$work/fault" -q "${ck[@]}" > "$work/fault.log" 2>&1
code=$?
set -e
expect_stop "a failing rank (test hook)" "$work/fault" "writing a checkpoint failed on rank 1: .*test hook"
set +e
within 120 mpirun --oversubscribe --bind-to none -np 2 bash -c \
  'if [ "$OMPI_COMM_WORLD_RANK" = 1 ]; then trap "" XFSZ; ulimit -f 1000; fi; exec "$0" "$@"' \
  "$exe" run "$case_dir" --out "$work/efbig" -q "${ck[@]}" > "$work/efbig.log" 2>&1
code=$?
set -e
expect_stop "a rank that cannot write (EFBIG)" "$work/efbig" "writing a checkpoint failed on rank 1: .*cannot write"
exit $fail
