#!/usr/bin/env bash
# Installs what lbdem needs to build and test, with apt (Debian 12 / Ubuntu
# 24.04). Idempotent: installs only what is missing. Run as root or with sudo.
# CUDA is optional: with nvcc on the PATH (or at /usr/local/cuda) the build
# also has the GPU backend.
# clang is for the fuzz build (scripts/fuzz.sh, tests/fuzz), which CI runs briefly.
# python3-matplotlib, -h5py and -numpy draw the pictures of a run (scripts/plot_*.py, e.g. the default
# case's snapshots.png and series.png, bench/cfd/compare_mueller.py); where they cannot be installed the set-up
# says so and still succeeds (the comparison's test is then skipped).
set -euo pipefail
pkgs=(build-essential cmake ninja-build pkg-config
      libopenmpi-dev openmpi-bin libhdf5-dev libeigen3-dev libyaml-cpp-dev
      libcli11-dev libspdlog-dev libfmt-dev libgtest-dev libgmock-dev libbenchmark-dev clang)
plot_pkgs=(python3-matplotlib python3-h5py python3-numpy)
missing_of() {  # the packages among the arguments that dpkg does not list as installed
  local p
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
  done
}
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO=sudo
updated=0
install() {  # apt-get install of the arguments, after one index update per run
  [ $updated -eq 1 ] || { $SUDO apt-get update -qq && updated=1; } || return 1
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "$@"
}
mapfile -t missing < <(missing_of "${pkgs[@]}")
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#pkgs[@]} build packages present"
else
  echo "setup: installing ${missing[*]}"
  install "${missing[@]}"
fi
mapfile -t missing < <(missing_of "${plot_pkgs[@]}")
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#plot_pkgs[@]} plotting packages present"
else
  echo "setup: installing ${missing[*]}"
  install "${missing[@]}" ||
    echo "setup: could not install ${missing[*]}: runs work, their pictures are not drawn"
fi
