#!/usr/bin/env bash
# Builds lbdem and runs the whole test suite (the README's test command).
#   scripts/test.sh [build-dir]     (LBDEM_CUDA=ON|OFF, default: detect nvcc)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build}"
bash "$here/scripts/setup.sh"
cuda="${LBDEM_CUDA:-}"
args=()
[ -n "$cuda" ] && args+=("-DLBDEM_ENABLE_CUDA=$cuda")
cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "${args[@]}"
cmake --build "$build" -j"$(nproc)"
cd "$build"
OMP_WAIT_POLICY=passive ctest --output-on-failure -j"$(nproc)" --timeout 900
