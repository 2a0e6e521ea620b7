#!/usr/bin/env bash
# Builds lbdem and runs the test suite (the README's test command).
#   scripts/test.sh [build-dir]     (LBDEM_CUDA=ON|OFF, default: detect nvcc)
#   LBDEM_TEST_LABELS="quick long"  the CTest labels to run, in order (default both: the whole suite)
# Every test is labelled `quick` or `long` (tests/CMakeLists.txt). CI (.ci/run) runs both: on 2 cores the
# host build's quick tests take about 1 minute and the long ones about 3 (measured with -j2 on a loaded
# machine), far inside the CI time limit, so nothing is left to a separate job. A developer runs
# `ctest -L quick` (or `ctest --preset quick`).
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
rc=0
for label in ${LBDEM_TEST_LABELS:-quick long}; do
  echo "== ctest -L $label"
  OMP_WAIT_POLICY=passive ctest --output-on-failure -j"$(nproc)" --timeout 900 -L "^$label\$" || rc=1
done
exit $rc
