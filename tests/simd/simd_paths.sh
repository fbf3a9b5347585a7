#!/usr/bin/env bash
# The SIMD paths give the same numbers as the baseline paths (docs/dsmc.md, "Random
# numbers"; docs/PERFORMANCE.md). The hot DSMC kernels pick AVX2 at run time where the CPU
# has it (Philox4x32 words of the bath tests and of the cell collisions, the fused step's
# cell index and gather) and SSE2 otherwise, and AVX-512 where it has AVX-512F (the bath's
# Philox words, the fused step's ranking and next-cell prediction, with VL the collision
# bound); GRAINBATH_SIMD=sse2 forces the baseline, GRAINBATH_SIMD=avx2 rules out AVX-512.
# Each case is run the three ways and results.h5 (every dataset and attribute except /provenance) and
# summary.json (performance.* left out; it holds state.hash, the fingerprint of every bit of
# the final particle state, src/core/state_hash.hpp) must be identical. On a CPU without AVX2 both runs
# take the baseline path and the test checks only determinism; it says so.
#
# usage: simd_paths.sh GRAINBATH CASES_DIR WORK_DIR
set -euo pipefail
exe=$1
cases=$2
work=$3
rm -rf "$work"
mkdir -p "$work"
if ! grep -qw avx2 /proc/cpuinfo 2>/dev/null; then
  echo "note: this CPU has no AVX2; both runs take the SSE2 paths (determinism only)"
fi
fail=0
for c in "$cases"/*/; do
  name=$(basename "$c")
  "$exe" run "$c" --out "$work/$name-auto" -q
  # sse2: the baseline; avx2: the AVX2 paths without the AVX-512 ones (on a CPU
  # without AVX-512 the same paths as auto)
  for forced in sse2 avx2; do
    GRAINBATH_SIMD=$forced "$exe" run "$c" --out "$work/$name-$forced" -q
    if ! h5diff --exclude-path /provenance "$work/$name-auto/results.h5" "$work/$name-$forced/results.h5" \
        > "$work/$name-$forced-h5diff.log" 2>&1; then
      echo "FAIL $name: results.h5 differs between the dispatched and the $forced paths:"
      head -20 "$work/$name-$forced-h5diff.log"
      fail=1
      continue
    fi
    if ! /usr/bin/env python3 "$(dirname "$0")/../same_summary.py" "$work/$name-auto/summary.json" "$work/$name-$forced/summary.json"
    then
      echo "FAIL $name: summary.json differs between the dispatched and the $forced paths"
      fail=1
      continue
    fi
    echo "ok $name: results.h5 and summary.json identical (dispatched vs GRAINBATH_SIMD=$forced)"
  done
done
exit $fail
