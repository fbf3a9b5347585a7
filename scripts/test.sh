#!/usr/bin/env bash
# Install what is missing, build (Release) and run the default test tiers.
# Long validation runs carry the ctest label "long" and are excluded here:
#   ctest --test-dir build -L long
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
ctest --test-dir build --output-on-failure -LE long --timeout 900 -j "$(nproc)"
# The fast subset again under AddressSanitizer + UndefinedBehaviorSanitizer (operators,
# cli, closures; docs/RELIABILITY.md). The whole default tier under the sanitizers:
#   cmake --preset asan-ubsan && cmake --build --preset asan-ubsan && ctest --preset asan-ubsan
cmake --preset asan-ubsan > /dev/null
cmake --build --preset asan-ubsan-fast --parallel "$(nproc)"
ctest --preset asan-ubsan-fast -j "$(nproc)"
