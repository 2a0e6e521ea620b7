#!/usr/bin/env bash
# Drag and mass checks of issue 29 on one GPU (about 8 minutes after the build):
#
#   scripts/drag_gpu.sh BUILD_DIR [PART...]      PART: drift | map (default: both)
#
#   drift  the mean fluid density of a weight-balanced periodic suspension with the shipped 3D suspension's
#          physics (lbdem_bench_psm drift: tau 1.2386, d/l 10, solid fraction 0.128, density ratio 692.3,
#          g 4.704e-7, random speeds 5e-3, the default rule: wall weighting, Lambda auto, NEBB, table
#          fractions, fused pipeline), fp64, in the eighth box (64 x 252 x 64 cells, 252 particles,
#          cases/suspension/suspension_3d_eighth.yaml's box) for 1e5 steps, a sample every 5,000.
#          Bar (issue 29): |drift| = |fluid_rho(n) - fluid_rho(5,000)| <= 1e-6 up to n = 1e5. About 2-3 min.
#          Output: $OUT/drift.jsonl (one line per sample: step, fluid_rho, drift, mean_rho, superficial_u).
#   map    the fixed-sphere drag map where d/l >= 16 (scripts/drag_map.sh gpu-d): d/l 16, 20, 30 x tau
#          {1.5, 1.25, 1.0, 0.8, 0.6} and d/l 50 x tau {1.5, 1.25, 1.0, 0.8}, the default rule, exact
#          fractions, fp64, chi 0.5, Re_p 0.2. About 5 min (cut at 8 min). Output: $OUT/drag_map_gpu_d*.{json,md}
#          (copy the JSONs beside bench/results/drag_map_host.json; the rows fill imb/drag_error.hpp's map).
# Prints the drift lines and the map's table rows.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?usage: scripts/drag_gpu.sh BUILD_DIR [drift|map]...}"
shift
parts=("$@")
[ ${#parts[@]} -eq 0 ] && parts=(drift map)
lbdem_env
lbdem_build "$build" lbdem_bench_psm || exit 1
bin="$build/bench/imb/lbdem_bench_psm"
for p in "${parts[@]}"; do
  case "$p" in
    drift)
      timeout 300 "$bin" drift --backend cuda --precision fp64 --dims 64,252,64 --steps 100000 --every 5000 \
        > "$OUT/drift.jsonl" 2> "$OUT/drift.log"
      echo "drift: exit $?"
      cat "$OUT/drift.jsonl"
      ;;
    map)
      DRAG_MAP_LIMIT=480 "$LBDEM_ROOT/scripts/drag_map.sh" "$bin" "$OUT" gpu-d
      ;;
    *) echo "drag_gpu: unknown part $p (drift, map)"; exit 2 ;;
  esac
done
