#!/usr/bin/env bash
# The scan: 6 values of eps x 2 values of delta, run in parallel (`grainbath sweep`; other
# options are passed on, e.g. -j 1). Variants, table and plot go to OUT (--out OUT; default
# cases/equilibrium-scan/sweep, the sweep's own default, which git ignores), and the table is
# compared, variant by variant, with the shipped reference/sweep.tsv
# (scripts/compare_tables.py); `--out cases/equilibrium-scan/reference` replaces the reference.
set -euo pipefail
# GRAINBATH names the binary (default: build/grainbath of this checkout).
cd "$(dirname "$0")/../.."
out=cases/equilibrium-scan/sweep
args=("$@")
given=no
for ((k = 0; k < ${#args[@]}; k++)); do
  case ${args[k]} in
    --out) given=yes; [ $((k + 1)) -lt ${#args[@]} ] && out=${args[k + 1]} ;;
    --out=*) given=yes; out=${args[k]#--out=} ;;
  esac
done
[ "$given" = yes ] || args+=(--out "$out")
"${GRAINBATH:-./build/grainbath}" sweep cases/equilibrium-scan \
  --set background.knudsen=0.005,0.01,0.02,0.05,0.1,0.2 \
  --set restitution.delta=0,0.2 "${args[@]}"
if [ "$(realpath -m "$out")" != "$(realpath cases/equilibrium-scan/reference)" ]; then
  /usr/bin/python3 scripts/compare_tables.py cases/equilibrium-scan/reference/sweep.tsv "$out/sweep.tsv"
fi
