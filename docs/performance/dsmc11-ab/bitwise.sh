#!/bin/bash
# usage: [BASE=/path/to/base/grainbath] [OUT=/tmp/dsmc11/bw] bitwise.sh NEWBIN LABEL
#   runs the base binary (once, cached) and NEWBIN on the cases, 1 and 2 threads
#   (h-dsmc11 ran it with BASE = main b8f08d6's binary in /tmp/base23)
NEW=$1; LABEL=$2; B=${OUT:-/tmp/dsmc11/bw}; BASE=${BASE:-/tmp/base23/grainbath}
ROOT=$(cd "$(dirname "$0")/../../.." && pwd)
for c in free-cooling relaxation density-mode equilibrium diffusion-limit dsmc1-20; do
  if [ "$c" = dsmc1-20 ]; then src=$ROOT/bench/mpi-dsmc1; extra="--set dsmc.t_end=1.7724 --set sampling.every=1.7724"; else src=$ROOT/cases/$c; extra=""; fi
  [ -d $B/cases/$c ] || { mkdir -p $B/cases; cp -r $src $B/cases/$c; rm -rf $B/cases/$c/output; }
  for T in 1 2; do
    if [ ! -f $B/base/$c-$T/summary.json ]; then
      $BASE run $B/cases/$c --out $B/base/$c-$T --set run.threads=$T $extra -q > /dev/null 2>&1 || echo "base $c $T failed"
    fi
    rm -rf $B/$LABEL/$c-$T
    $NEW run $B/cases/$c --out $B/$LABEL/$c-$T --set run.threads=$T $extra -q > /dev/null 2>&1 || echo "new $c $T failed"
    d=$(h5diff --exclude-path /provenance $B/base/$c-$T/results.h5 $B/$LABEL/$c-$T/results.h5 2>&1 | head -3)
    hb=$(python3 -c "import json;print(json.load(open('$B/base/$c-$T/summary.json'))['state']['hash'])")
    hn=$(python3 -c "import json;print(json.load(open('$B/$LABEL/$c-$T/summary.json'))['state']['hash'])")
    echo "$(date -u +%T) $c T=$T h5diff:[${d}] hash base $hb new $hn $([ "$hb" = "$hn" ] && echo EQUAL || echo DIFF)"
  done
done
