#!/usr/bin/env bash
# Builds the libFuzzer target for the case loader (tests/fuzz) with clang,
# ASan and UBSan, and fuzzes it for N seconds from the seed corpus
# tests/fuzz/corpus (the shipped cases) and tests/fuzz/regressions (inputs of earlier findings).
# Needs clang (scripts/setup.sh installs it).
#   scripts/fuzz.sh [seconds] [build-dir]
#     seconds     default 60
#     build-dir   default build-fuzz
#   LBDEM_JOBS    parallel compile jobs (default: nproc)
# Extra libFuzzer flags go in LBDEM_FUZZ_FLAGS (e.g. "-runs=1000000 -jobs=2").
# LBDEM_FUZZ_TIMEOUT: seconds one input may take before it is a finding (default 1;
# CI's short run allows more, as its shared machine can stall any process for a while).
# Exit status non-zero: a finding (crash-*, leak-*, timeout-*, oom-* file in
# the build dir's fuzz-artifacts/) or a build failure.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
secs="${1:-60}"
build="${2:-$here/build-fuzz}"
jobs="${LBDEM_JOBS:-$(nproc)}"
command -v clang++ >/dev/null || { echo "fuzz: clang++ not found (apt-get install -y clang)"; exit 1; }
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
CC=clang CXX=clang++ cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DLBDEM_ENABLE_CUDA=OFF -DLBDEM_ENABLE_MPI=OFF -DLBDEM_BUILD_BENCH=OFF -DLBDEM_SANITIZE=ON -DLBDEM_FUZZ=ON \
  -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link" -DCMAKE_C_FLAGS="-fsanitize=fuzzer-no-link" "${launcher[@]}"
cmake --build "$build" -j"$jobs" --target fuzz_case
# The grown corpus stays in the build dir; the seeds in the source tree are read only.
mkdir -p "$build/fuzz-corpus" "$build/fuzz-artifacts"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
export OMP_NUM_THREADS=1
# shellcheck disable=SC2086
"$build/tests/fuzz/fuzz_case" -max_total_time="$secs" -timeout="${LBDEM_FUZZ_TIMEOUT:-1}" -rss_limit_mb=2048 \
  -artifact_prefix="$build/fuzz-artifacts/" ${LBDEM_FUZZ_FLAGS:-} \
  "$build/fuzz-corpus" "$here/tests/fuzz/corpus" "$here/tests/fuzz/regressions"
