#!/usr/bin/env bash
# Install what is missing, build (Release) and run the default test tiers.
# Long validation runs carry the ctest label "long" and are excluded here:
#   ctest --test-dir build -L long
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
ctest --test-dir build --output-on-failure -LE long --timeout 900 -j "$(nproc)"
