#!/usr/bin/env bash
# Fused DEM sub-steps against two kernels per sub-step on one GPU (dem/README.md, "Fused sub-steps"): the CUDA
# instances of DemFusedSubsteps.* (with and without friction, 1-16 lanes, with and without sub-step graphs; the
# whole checkpoint state compared bit for bit), FirstDifferingSubstep (the first sub-step whose fused state differs
# and the largest relative difference of positions, velocities and angular velocities, one line per friction flag
# and lane count), and DemCrossBackend.* and DemSubstepGraphs.* (the rest of the DEM's GPU-against-reference tests).
# One GPU, ~1-2 min after the build (dem_tests only).
#
#   scripts/dem_fused_gpu.sh BUILD_DIR
#     BUILD_DIR  a build folder of the `cuda` preset (configured and built here if needed: dem_tests)
# Output under $OUT/dem_fused: tests.log (the whole gtest output), first_difference.txt (the FirstDifferingSubstep
# lines), result.jsonl (one JSON line: tests passed and failed, the CUDA frictional verdict).
# Prints the FirstDifferingSubstep lines and the gtest summary. Expected: every test passes and each line says
# "first sub-step whose fused state differs: none" with differences of 0. A line with a first sub-step and
# differences near 1e-16 is a rounding difference left somewhere; differences of 1e-4 or more, an ordering error.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?usage: scripts/dem_fused_gpu.sh BUILD_DIR}"
lbdem_env
out="$OUT/dem_fused"
mkdir -p "$out"
lbdem_build "$build" dem_tests || exit 1
filter='*DemFusedSubsteps*:DemCrossBackend.*:*DemSubstepGraphs*'
timeout 900 "$build/tests/dem/dem_tests" --gtest_filter="$filter" > "$out/tests.log" 2>&1
rc=$?
grep 'first sub-step whose fused state differs' "$out/tests.log" > "$out/first_difference.txt"
cat "$out/first_difference.txt"
grep -E '^\[  (PASSED|FAILED|SKIPPED) +\]|tests ran' "$out/tests.log" | tail -20
passed=$(grep -c '^\[       OK \]' "$out/tests.log")
failed=$(grep -cE '^\[  FAILED  \] .* \([0-9]+ ms\)$' "$out/tests.log")
frictional=$(grep -E '^\[  FAILED  \] .*cuda_frictional.* \([0-9]+ ms\)$' "$out/tests.log" | wc -l)
json_line "$out/result.jsonl" what=dem_fused_substeps filter="$filter" exit=$rc passed="$passed" failed="$failed" \
  cuda_frictional_failed="$frictional"
exit $rc
