# The OpenMPI environment of the MPI tests, sourced by each of them after setting `exe`:
# root in containers and CI needs the two ALLOW variables; a container without a network
# still has loopback, so OpenMPI's TCP stays on it; containers often forbid cross-process
# memory access (CMA), so copies go through shared memory; ranks and threads share two busy
# cores in CI, so idle OpenMP threads sleep instead of spinning.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_btl_tcp_if_include=lo OMPI_MCA_oob_tcp_if_include=lo
export OMPI_MCA_btl_vader_single_copy_mechanism=none
export OMP_WAIT_POLICY=PASSIVE
# within SECONDS CMD...: CMD (an mpirun) under a time limit, in a session of its own, so that
# every process it started can be found afterwards. A rank that ignores mpirun's SIGTERM
# outlives a killed mpirun (seen: `timeout -k 2 3 mpirun -np 2 bash -c 'trap "" TERM; sleep
# 1001'` left both sleeps running, re-parented to init, each in its own process group but in
# the caller's session); whatever is still alive in the session when CMD returns is killed.
# Exit status as timeout's: 124 when the limit was reached (137 if mpirun had to be killed
# too). mpirun gets WITHIN_KILL_AFTER seconds (default 5) after the SIGTERM to stop its
# ranks before it is killed itself.
within() {
  local limit=$1; shift
  local sid_file rc=0 sid
  sid_file=$(mktemp)
  # timeout's child is not a process-group leader, so setsid execs in place: the session id
  # is the pid that bash writes before exec-ing CMD.
  timeout -k "${WITHIN_KILL_AFTER:-5}" "$limit" setsid bash -c 'echo $$ > "$0"; exec "$@"' "$sid_file" "$@" || rc=$?
  sid=$(cat "$sid_file"); rm -f "$sid_file"
  if [ -n "$sid" ]; then
    local left  # (zombies, already dead, are left to init)
    left=$(ps -o pid=,stat=,args= -s "$sid" | awk '$2 !~ /^Z/' || true)
    if [ -n "$left" ]; then
      echo "within: killing what the run left behind: $(echo "$left" | tr '\n' ';')" >&2
      pkill -KILL -s "$sid" || true
    fi
  fi
  return "$rc"
}
# mpi NP ARGS...: the grainbath under test on NP ranks (a hang fails the run after
# MPI_RUN_LIMIT seconds, before ctest's own timeout would kill the script and orphan ranks)
mpi() {
  local np=$1; shift
  within "${MPI_RUN_LIMIT:-240}" mpirun --oversubscribe --bind-to none -np "$np" "$exe" "$@"
}
# fresh_work_dir DIR: an empty work directory for the test (what a previous run left is removed)
fresh_work_dir() { rm -rf "$1"; mkdir -p "$1"; }
# same_results REF OTHER LABEL: the two runs' results.h5 identical (h5diff, exact; /parameters
# left out: run.threads may differ) and their summary.json numbers identical (same_summary.py,
# performance.* left out). A difference is printed and sets fail=1; $work holds the log.
same_results() {
  if ! h5diff --exclude-path /parameters "$1/results.h5" "$2/results.h5" > "$work/h5diff.log" 2>&1; then
    echo "FAIL $3: results.h5 differs from the plain run:"; head -20 "$work/h5diff.log"; fail=1; return 0
  fi
  if ! python3 "$(dirname "${BASH_SOURCE[0]}")/../same_summary.py" "$1/summary.json" "$2/summary.json"; then
    echo "FAIL $3: summary.json numbers differ"; fail=1; return 0
  fi
  echo "ok   $3: bitwise identical to the plain run"
}
# rank_of PID: the Open MPI rank of a process (from its environment), empty if it has none
rank_of() { tr '\0' '\n' < "/proc/$1/environ" 2>/dev/null | sed -n 's/^OMPI_COMM_WORLD_RANK=//p'; }
# catches_sigterm PID: true once the process handles SIGTERM (bit 15 of SigCgt in /proc)
catches_sigterm() {
  local mask
  mask=$(awk '/^SigCgt:/ {print $2}' "/proc/$1/status" 2>/dev/null || true)
  [ -n "$mask" ] && (( (16#$mask >> 14) & 1 ))
}
# rank_pid LAUNCHER PATTERN RANK READY...: the pid of rank RANK among the processes whose
# command line matches PATTERN (pgrep -f), as soon as the command READY... succeeds with that
# pid as its last argument; polled every 10 ms for up to a minute while LAUNCHER lives.
# Prints nothing if the launcher ended (or the minute passed) first.
rank_pid() {
  local launcher=$1 pattern=$2 rank=$3 pid
  shift 3
  for _ in $(seq 1 6000); do
    for pid in $(pgrep -f "$pattern" || true); do
      if [ "$(rank_of "$pid")" = "$rank" ] && "$@" "$pid"; then echo "$pid"; return 0; fi
    done
    kill -0 "$launcher" 2> /dev/null || return 0
    sleep 0.01
  done
}
# stop_rank LAUNCHER PATTERN RANK LOG WHAT READY...: SIGTERM to rank RANK's process (rank_pid)
# once READY... holds, then waits for the job: its exit code in $stopped_rc. If the rank was
# not seen ready before the job ended: "FAIL: WHAT before the job ended", LOG shown, exit 1.
stop_rank() {
  local launcher=$1 pattern=$2 rank=$3 log=$4 what=$5 target
  shift 5
  target=$(rank_pid "$launcher" "$pattern" "$rank" "$@")
  if [ -z "$target" ]; then
    echo "FAIL: $what before the job ended"; wait "$launcher" || true
    cat "$log"; exit 1
  fi
  kill -TERM "$target"
  stopped_rc=0
  wait "$launcher" || stopped_rc=$?
}
# same_ensemble A B N: the two ensemble.json identical (every value, nested keys flattened) and
# merged from N replicas with an error > 0. Prints the merged temperature and its error, or
# "FAIL: ..." and returns 1.
same_ensemble() {
  python3 - "$1" "$2" "$3" <<'PY'
import json, sys
def flat(d, p=""):
    out = {}
    for k, v in d.items():
        if isinstance(v, dict): out.update(flat(v, p + k + "."))
        else: out[p + k] = v
    return out
a, b = (flat(json.load(open(f))) for f in sys.argv[1:3])
if not a or a != b:
    print("FAIL: %s and %s differ:" % tuple(sys.argv[1:3]), [k for k in set(a) | set(b) if a.get(k) != b.get(k)][:10])
    sys.exit(1)
t = a["temperature.mean.ensemble_mean"], a["temperature.mean.ensemble_stderr"], a["temperature.mean.replicas"]
if t[2] != int(sys.argv[3]) or not t[1] > 0:
    print("FAIL: merged temperature (mean, error, replicas) %s, not from %s replicas" % (t, sys.argv[3]))
    sys.exit(1)
print("%.6g %.2g" % t[:2])
PY
}
