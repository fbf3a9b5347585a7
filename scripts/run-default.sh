#!/usr/bin/env bash
# Install what is missing, build (Release) and run the default case.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
./build/grainbath run cases/equilibrium "$@"
