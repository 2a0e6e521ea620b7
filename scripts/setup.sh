#!/usr/bin/env bash
# Installs what lbdem needs to build and test, with apt (Debian 12 / Ubuntu
# 24.04). Idempotent: installs only what is missing. Run as root or with sudo.
# CUDA is optional: with nvcc on the PATH (or at /usr/local/cuda) the build
# also has the GPU backend.
# clang is for the fuzz build (scripts/fuzz.sh, tests/fuzz), which CI runs briefly.
set -euo pipefail
pkgs=(build-essential cmake ninja-build pkg-config
      libopenmpi-dev openmpi-bin libhdf5-dev libeigen3-dev libyaml-cpp-dev
      libcli11-dev libspdlog-dev libfmt-dev libgtest-dev libgmock-dev libbenchmark-dev clang)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#pkgs[@]} packages present"
  exit 0
fi
echo "setup: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO=sudo
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
