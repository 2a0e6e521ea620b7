#!/usr/bin/env bash
# Particle load imbalance of the coupled 3D suspension over a run long enough for clusters to form (issue 27):
# the half box (cases/suspension/suspension_3d_half.yaml: 256 x 1008 x 256 cells, 16,128 spheres, the paper's
# phi 0.128 and d/l 10) on N GPUs cut along the long axis for STEPS steps (default 30,000: about two particle
# relaxation times rho_s d^2 / (18 mu) = 0.0094 s at dt 6e-7 s), no snapshots, a series row every SERIES steps.
#   scripts/suspension_imbalance_gpu.sh BUILD_DIR [N]
# BUILD_DIR: a build folder (configured from the `cuda` preset and built here if missing); N: GPUs (default 2).
# Time: ~2.6 ms per step on two H200s, about 80 s for 30,000 steps after the build.
# Writes $OUT/suspension_imbalance/{imbalance.jsonl (one line: particles per rank max / mean at the worst series
# row, the phases, GLUPS), series.csv, run.log}; never field files.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
lbdem_env
build="${1:?usage: scripts/suspension_imbalance_gpu.sh BUILD_DIR [N]}"
n="${2:-2}"
lbdem_build "$build" lbdem || exit 1
out="$OUT/suspension_imbalance"
work="${WORK:-/tmp/lbdem_suspension_imbalance}"
mkdir -p "$out" "$work"
steps="${STEPS:-30000}"
series="${SERIES:-500}"
yaml="$work/half.yaml"
sed -e 's/^output: {/output: {final: false, /' -e 's/interval: [0-9]*}/interval: 0}/' \
    -e "s/series_interval: [0-9]*/series_interval: $series/" \
    "$LBDEM_ROOT/cases/suspension/suspension_3d_half.yaml" > "$yaml"
echo "parallel: {decomposition: [1, $n, 1]}" >> "$yaml"
rm -rf "${work:?}/run"
"${MPIRUN[@]}" -np "$n" "$build/cases/lbdem" run "$yaml" --backend cuda --steps "$steps" --output "$work/run" \
  --quiet > "$out/run.log" 2>&1
rc=$?
echo "run exit $rc"
cp "$work/run/series.csv" "$out/" 2>/dev/null
python3 "$LBDEM_ROOT/scripts/coupled_summary.py" "$work/run/summary.json" > "$out/fields.txt"
# shellcheck disable=SC2046
json_line "$out/imbalance.jsonl" case=suspension_3d_half gpus="$n" steps="$steps" exit="$rc" $(cat "$out/fields.txt")
tail -1 "$out/imbalance.jsonl"
