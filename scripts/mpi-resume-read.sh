#!/usr/bin/env bash
# What each rank reads from a checkpoint on an MPI resume (docs/performance/mpi.md,
# 2026-11-26): writes the DSMC-1 checkpoint (bench/mpi-dsmc1, step 1 of 2) with the first
# binary, then resumes it for one step with each binary at 1 and 2 ranks under strace and
# prints, per rank, the bytes of read/pread64 on the checkpoint's descriptor and the time
# from its first open to its last close.
# usage: scripts/mpi-resume-read.sh WORK_DIR GRAINBATH_MPI [GRAINBATH_MPI ...]
set -euo pipefail
cd "$(dirname "$0")/.."
work=$1
shift
exe=$1
source tests/mpi/mpi_env.sh
rm -rf "$work"
mkdir -p "$work"
"$exe" run bench/mpi-dsmc1 --out "$work/ck" -q --set dsmc.t_end=0.17724 --set checkpoint.every=0.08862 \
  --set checkpoint.keep=true > /dev/null 2>&1
file=checkpoint-000000000001.h5
k=0
for exe in "$@"; do
  k=$((k + 1))
  for np in 1 2; do
    out=$work/resume-$k-np$np
    mkdir -p "$out.checkpoints"
    cp "$work/ck.checkpoints/$file" "$out.checkpoints/"
    mpirun --oversubscribe --bind-to none -np "$np" bash -c \
      "exec strace -f -tt -y -e trace=openat,read,pread64,close -o $out.strace.\$OMPI_COMM_WORLD_RANK \"\$0\" \"\$@\"" \
      "$exe" run bench/mpi-dsmc1 --out "$out" -q --set dsmc.t_end=0.17724 --set checkpoint.every=0.08862 --resume \
      > /dev/null 2>&1 < /dev/null
    for trace in "$out".strace.*; do
      python3 - "$trace" "$file" "$exe" "$np" <<'PY'
import re, sys
trace, name, exe, np = sys.argv[1:]
def seconds(t):
    h, m, s = t.split(":")
    return int(h) * 3600 + int(m) * 60 + float(s)
total, first, last = 0, None, None
for line in open(trace):
    if name not in line:
        continue
    fields = line.split()
    t = seconds(fields[1])
    if fields[2].startswith("openat(") and first is None:
        first = t
    if fields[2].startswith("close("):
        last = t
    m = re.search(r"^\S+ \S+ (read|pread64)\(.*= (\d+)$", line.strip())
    if m:
        total += int(m.group(2))
print("%s, %s rank(s), rank %s: %.2f MB read from the checkpoint, open to close %.3f s"
      % (exe, np, trace.rsplit(".", 1)[1], total / 1e6, last - first))
PY
    done
  done
done
