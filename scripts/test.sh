#!/usr/bin/env bash
# Install what is missing, build (Release) and run the default test tiers.
# Long validation runs carry the ctest label "long" and are excluded here:
#   ctest --test-dir build -L long
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
ctest --test-dir build --output-on-failure -LE long --timeout 900 -j "$(nproc)"
# The MPI build (-DGRAINBATH_MPI=ON, docs/dsmc.md "MPI domain decomposition"): only what the
# MPI tests run (the grainbath binary and a test shim), then the tests labelled "mpi" (1 vs 2
# ranks bitwise, checkpoints across rank counts, the MPI ensemble; they also compare with the
# plain build's binary).
if [ ! -f build-mpi/CMakeCache.txt ]; then
  gen=()
  command -v ninja >/dev/null 2>&1 && gen=(-G Ninja)
  cmake -S . -B build-mpi "${gen[@]}" -DCMAKE_BUILD_TYPE=Release -DGRAINBATH_MPI=ON -DGRAINBATH_BENCH=OFF > /dev/null
fi
cmake --build build-mpi --parallel "$(nproc)" --target grainbath_mpi_tests
PLAIN_GRAINBATH="$PWD/build/grainbath" ctest --test-dir build-mpi --output-on-failure -L mpi --timeout 300
# The fast subset again under AddressSanitizer + UndefinedBehaviorSanitizer (operators,
# cli, closures; docs/RELIABILITY.md). The whole default tier under the sanitizers:
#   cmake --preset asan-ubsan && cmake --build --preset asan-ubsan && ctest --preset asan-ubsan
cmake --preset asan-ubsan > /dev/null
cmake --build --preset asan-ubsan-fast --parallel "$(nproc)"
ctest --preset asan-ubsan-fast -j "$(nproc)"
