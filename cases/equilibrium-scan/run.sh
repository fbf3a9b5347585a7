#!/usr/bin/env bash
# The scan: 6 values of eps x 2 values of delta, run in parallel (`grainbath sweep`; other
# options are passed on, e.g. -j 1). Variants, table and plot go to OUT (--out OUT; default
# cases/equilibrium-scan/output, which git ignores), and the table is compared, variant by
# variant, with the shipped sweep/sweep.tsv (scripts/compare_tables.py); `--out
# cases/equilibrium-scan/sweep` replaces the shipped one.
set -euo pipefail
# GRAINBATH names the binary (default: build/grainbath of this checkout).
cd "$(dirname "$0")/../.."
out=cases/equilibrium-scan/output
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
if [ "$(realpath -m "$out")" != "$(realpath cases/equilibrium-scan/sweep)" ]; then
  /usr/bin/python3 scripts/compare_tables.py cases/equilibrium-scan/sweep/sweep.tsv "$out/sweep.tsv"
fi
