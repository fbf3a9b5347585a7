#!/usr/bin/env bash
# The scan: 6 values of eps x 2 values of delta, run in parallel; table and plot in sweep/.
set -euo pipefail
# GRAINBATH names the binary (default: build/grainbath of this checkout).
cd "$(dirname "$0")/../.."
"${GRAINBATH:-./build/grainbath}" sweep cases/equilibrium-scan \
  --set background.knudsen=0.005,0.01,0.02,0.05,0.1,0.2 \
  --set restitution.delta=0,0.2 "$@"
