#!/bin/bash
# ab.sh FILTER ROUNDS BIN...  : per round each binary once, in turn; CPU and wall ns per particle-step
f=$1; r=$2; shift 2
for i in $(seq $r); do for b in "$@"; do
  out=$($b --benchmark_filter="$f" --benchmark_format=json 2>/dev/null)
  cpu=$(echo "$out" | python3 -c "import json,sys;d=json.load(sys.stdin)['benchmarks'][0];print('%.2f %.2f'%(d['cpu_ns_per_particle_step'],d['ns_per_particle_step']))")
  echo "$(date -u +%T) load=$(cut -d' ' -f1 /proc/loadavg) round=$i $b $cpu"
done; done
