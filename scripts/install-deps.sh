#!/usr/bin/env bash
# Installs the Debian packages grainbath needs, only those that are missing.
# Safe to run repeatedly; needs root (or sudo) only when something is missing.
set -euo pipefail
pkgs=(cmake g++ make pkg-config ninja-build
      libeigen3-dev libfftw3-dev libhdf5-dev hdf5-tools libgsl-dev
      librandom123-dev libtomlplusplus-dev libcli11-dev libfmt-dev libspdlog-dev
      libgtest-dev libgmock-dev libbenchmark-dev clang libclang-rt-14-dev
      python3-numpy python3-h5py python3-matplotlib
      libopenmpi-dev openmpi-bin)  # MPI build and its tests (scripts/test.sh, build-mpi)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#pkgs[@]} Debian packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
