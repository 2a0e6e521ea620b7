#!/usr/bin/env bash
# Host build with AddressSanitizer + UndefinedBehaviorSanitizer (-DLBDEM_SANITIZE=ON,
# the preset "host-sanitize") and the quick tests run under it. Any report ends the
# test that met it (halt_on_error / abort_on_error), so a pass means no report.
#   scripts/sanitize.sh [build-dir] [module ...]
#     build-dir   default build-sanitize
#     module      test executables to build and run (core cases lbm dem imb halo);
#                 default: all of them. E.g. scripts/sanitize.sh build-sanitize core cases
#   LBDEM_JOBS    parallel compile jobs (default: nproc)
# No CUDA: the sanitizers cover the host backend; scripts/gpu_sanitize.sh runs
# compute-sanitizer over the CUDA tests on a GPU machine.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build-sanitize}"
shift || true
mods=("$@")
[ ${#mods[@]} -eq 0 ] && mods=(core halo lbm dem imb cases)
jobs="${LBDEM_JOBS:-$(nproc)}"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DLBDEM_ENABLE_CUDA=OFF \
  -DLBDEM_SANITIZE=ON -DLBDEM_BUILD_BENCH=OFF "${launcher[@]}"
targets=()
for m in "${mods[@]}"; do targets+=("${m}_tests"); done
# The cases tests run the lbdem binary: it is built with them (tests/CMakeLists.txt).
cmake --build "$build" -j"$jobs" --target "${targets[@]}"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
export OMP_WAIT_POLICY=passive
cd "$build"
regex="$(IFS='|'; echo "${mods[*]}")"
# Labels: the module and quick (tests/CMakeLists.txt); the sanitizers slow the
# code 2-5x, hence the longer timeout.
ctest --output-on-failure -j"$jobs" --timeout 1800 -L "^quick\$" -L "^($regex)\$" \
  || { echo "sanitize: failures above (build $build)"; exit 1; }
echo "sanitize: ${mods[*]}: no ASan/UBSan report"
