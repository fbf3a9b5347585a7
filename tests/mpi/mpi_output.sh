#!/usr/bin/env bash
# Checkpoints and results of a multi-rank run without gathering the grains to rank 0
# (docs/dsmc.md, "MPI domain decomposition"; src/dsmc/checkpoint.hpp):
#  1. a 2-rank run's checkpoint file is the plain process's, byte for byte (the ranks write
#     their grains in turn into the file rank 0 created), and its results.h5 and
#     summary.json are bitwise the plain run's;
#  2. rank 0 never held every grain: its peak resident memory is within 15% of rank 1's
#     (gathering the 300,000 grains for the output made it 1.3x; measured in
#     docs/performance/mpi.md), and no rank's particle arrays held the whole population;
#  3. the plain checkpoint resumed with 2 ranks ends bitwise where the plain run ended, and
#     no rank held the whole population (each rank reads only its own grains of the file);
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
rm -rf "$work"
mkdir -p "$work"
fail=0
ck=(--set checkpoint.every=0.05 --set checkpoint.keep=true)
first=checkpoint-000000000001.h5

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

# 3: resumed with 2 ranks, each reading its own grains
mkdir -p "$work/resume2.checkpoints"
cp "$work/plain.checkpoints/$first" "$work/resume2.checkpoints/"
mpi 2 run "$case_dir" --out "$work/resume2" -q "${ck[@]}" --resume > /dev/null 2>&1
same_results "$work/plain" "$work/resume2" "plain checkpoint resumed with 2 ranks"
python3 - "$work/resume2/summary.json" "$case_dir/case.toml" <<'PY' || fail=1
import json, re, sys
p = json.load(open(sys.argv[1]))["performance"]
n = int(re.search(r"^particles *= *(\d+)", open(sys.argv[2]).read(), re.M).group(1))
if not p["rank_peak_particles"] < n:
    print("FAIL resumed: a rank held all %d grains (it read the whole checkpoint)" % n); sys.exit(1)
print("ok   resumed with 2 ranks: at most %d of %d grains on one rank" % (p["rank_peak_particles"], n))
PY

# 4: the homogeneous case (every grain on rank 0, none on rank 1)
hk=(--set checkpoint.every=1.0 --set checkpoint.keep=true)
"$exe" run "$homogeneous" --out "$work/hplain" -q "${hk[@]}" > /dev/null
mpi 2 run "$homogeneous" --out "$work/hnp2" -q "${hk[@]}" > /dev/null 2>&1
hfirst=$(cd "$work/hplain.checkpoints" && ls checkpoint-*.h5 | head -1)
same_checkpoint "$work/hplain.checkpoints/$hfirst" "$work/hnp2.checkpoints/$hfirst" "homogeneous, 2 ranks"
same_results "$work/hplain" "$work/hnp2" "homogeneous, 2 ranks"
mkdir -p "$work/hresume2.checkpoints"
cp "$work/hplain.checkpoints/$hfirst" "$work/hresume2.checkpoints/"
mpi 2 run "$homogeneous" --out "$work/hresume2" -q "${hk[@]}" --resume > /dev/null 2>&1
same_results "$work/hplain" "$work/hresume2" "homogeneous plain checkpoint resumed with 2 ranks"

# 5: rank 1 fails to write its part
set +e
GRAINBATH_FAULT_CHECKPOINT_RANK=1 timeout 120 mpirun --oversubscribe --bind-to none -np 2 -x GRAINBATH_FAULT_CHECKPOINT_RANK \
  "$exe" run "$case_dir" --out "$work/fault" -q "${ck[@]}" > "$work/fault.log" 2>&1
code=$?
set -e
said=$(grep -c "writing a checkpoint failed on rank 1: .*test hook" "$work/fault.log" || true)
if [ "$code" -ne 0 ] && [ "$code" -ne 124 ] && [ "$said" -ge 1 ] && [ ! -e "$work/fault" ] &&
   ! ls "$work/fault.checkpoints"/*.partial > /dev/null 2>&1; then
  echo "ok   a failing rank: exit $code, the message on $said rank(s), no partial checkpoint or output left"
else
  echo "FAIL a failing rank: exit $code (124: hung), message on $said rank(s):"; tail -5 "$work/fault.log"; fail=1
fi
set +e
timeout 120 mpirun --oversubscribe --bind-to none -np 2 bash -c \
  'if [ "$OMPI_COMM_WORLD_RANK" = 1 ]; then trap "" XFSZ; ulimit -f 1000; fi; exec "$0" "$@"' \
  "$exe" run "$case_dir" --out "$work/efbig" -q "${ck[@]}" > "$work/efbig.log" 2>&1
code=$?
set -e
said=$(grep -c "writing a checkpoint failed on rank 1: .*cannot write" "$work/efbig.log" || true)
if [ "$code" -ne 0 ] && [ "$code" -ne 124 ] && [ "$said" -ge 1 ] && [ ! -e "$work/efbig" ] &&
   ! ls "$work/efbig.checkpoints"/*.partial > /dev/null 2>&1; then
  echo "ok   a rank that cannot write (EFBIG): exit $code, the message on $said rank(s), nothing left"
else
  echo "FAIL a rank that cannot write: exit $code (124: hung), message on $said rank(s):"; tail -5 "$work/efbig.log"; fail=1
fi
exit $fail
