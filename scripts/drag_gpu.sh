#!/usr/bin/env bash
# Drag and mass checks of issue 29 on one GPU:
#
#   scripts/drag_gpu.sh BUILD_DIR [PART...]      PART: map | lambda | re | random | drift | drift-even (default: map random)
#
#   map     the fixed-sphere drag map of the default rule where d/l >= 16 (scripts/drag_map.sh gpu-e):
#           d/l 16, 20, 30, 50 x tau {1.5, 1.25, 1.0, 0.8, 0.6}, chi 0.5, Re_p 0.2, exact fractions, fp64,
#           against Sangani & Acrivos; bar: half the first paper's Table 1 error. About 1.5 min on an H200
#           (d/l 50 at tau 0.6 alone ~30 s). Output: $OUT/drag_map_gpu_e*.{json,md,log}, $OUT/drag_map.json
#           (merged), $OUT/drag_map_rows.jsonl (one JSON line per run), $OUT/drag_map_ntw.png.
#   lambda  the same points at Lambda = 0.6 and 1.6 times the rule's (scripts/drag_map.sh gpu-lam): the
#           slope dE/dLambda at each point, to re-centre imb/drag_error.hpp's Lambda table for d/l >= 16
#           if the map misses. About 2.5 min. Output: $OUT/drag_map_gpu_lam*.{json,md,log}, rows in
#           $OUT/drag_map_rows.jsonl.
#   re      finite Re_p (targets 0.2-50) at tau 0.6: a converged reference of the method's own (d/l 16-48 at fixed
#           Lambda, extrapolated in 1/d; checked against Sangani & Acrivos at Re_p 0.2) and the default rule at
#           d/l 8-30 against it (scripts/drag_re.py). About 4 min (at most 7). Output:
#           $OUT/drag_re_{ref,rule}.{json,md,log}, $OUT/drag_re.{md,jsonl}.
#   random  random arrays of 27 spheres, d/l 10, against Beetstra et al. (2007) and Tenneti et al. (2011)
#           (lbdem_bench_psm random): phi 0.1, 0.2, 0.3, 0.4 at Re 0.2 (tau 0.8), two configurations each;
#           Re 10 and 50 at phi 0.2 and 0.4 (tau 0.55, d/l 16; Mach ~0.1 at Re 50). At most 130 s. Output: $OUT/random_array.jsonl
#           and its table $OUT/random_array.md.
#   drift   the mean fluid density of a weight-balanced periodic suspension with the shipped 3D suspension's
#           physics (lbdem_bench_psm drift: tau 1.2386, d/l 10, solid fraction 0.128, density ratio 692.3,
#           g 4.704e-7, random speeds 5e-3, the default rule), fp64, in the eighth box (64 x 252 x 64 cells,
#           252 particles) for 1e5 steps, a sample every 5,000. Bar (issue 29): |fluid_rho(n) - fluid_rho(5,000)|
#           <= 1e-6 up to n = 1e5. About 2-3 min. Output: $OUT/drift.jsonl. The last line is the trend: the
#           least-squares slope of the fluid density from step 5,000 on, per 1e5 steps, with its standard error
#           and the residuals' RMS (the moving particles make the density fluctuate), and the same for the
#           superficial velocity (relative).
#   drift-even  the same run with psm.even_relaxation phi = 0 (off, the default), 0.02 and 1 (imb/psm.hpp, "Even
#           relaxation"; DRIFT_EVEN="..." to choose others), one after another: about 30 s each on an H200 (3 x 1e5
#           steps, ~1.5 min). Output: $OUT/drift_even<phi>.jsonl, the trend lines printed together at the end.
# `map random` together: about 4 min on one H200 after the build. Prints the table rows.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?usage: scripts/drag_gpu.sh BUILD_DIR [map|lambda|re|random|drift|drift-even]...}"
shift
parts=("$@")
[ ${#parts[@]} -eq 0 ] && parts=(map random)
lbdem_env
lbdem_build "$build" lbdem_bench_psm || exit 1
bin="$(realpath "$build")/bench/imb/lbdem_bench_psm"

# Every sweep row of the map parts as one JSON line (device, commit added).
rows_jsonl() {
  /usr/bin/python3 - "$OUT" "$LBDEM_COMMIT" "$LBDEM_DEVICE" <<'PY' || echo "rows: failed"
import glob, json, os, sys
out, commit, device = sys.argv[1:4]
with open(os.path.join(out, "drag_map_rows.jsonl"), "w") as f:
    for p in sorted(glob.glob(os.path.join(out, "drag_map_gpu_*.json"))):
        for r in json.load(open(p)).get("rows", []):
            f.write(json.dumps(dict(r, source=os.path.basename(p), commit=commit, device=device)) + "\n")
PY
}

for p in "${parts[@]}"; do
  case "$p" in
    map)
      DRAG_MAP_LIMIT=150 "$LBDEM_ROOT/scripts/drag_map.sh" "$bin" "$OUT" gpu-e merge plot
      rows_jsonl
      ;;
    lambda)
      DRAG_MAP_LIMIT=200 "$LBDEM_ROOT/scripts/drag_map.sh" "$bin" "$OUT" gpu-lam
      rows_jsonl
      ;;
    re)
      # Finite Re_p: the chi 0.5 array at Re_p targets 0.2-50 (tau 0.6). The driving force is set from the
      # Stokes estimate, so a run falls short of its target by the drag's own Re dependence (tens of % at
      # 10-50): the targets come in triplets (0.9 R, R, 1.1 R) and scripts/drag_re.py compares every series at
      # the reference's reached Re_p of target R, inside each triplet's range. Reference: a series at fixed
      # Lambda 3e-2, d/l 16, 24, 32, 48, extrapolated to d -> infinity (d/l 48 takes most of its time); the
      # rule at d/l 8, 10, 16, 20, 30.
      res=0.2,0.9,1,1.1,9,10,11,45,50,55
      timeout 300 "$bin" sweep --backend cuda --re "$res" --tol 1e-6 --start estimate --offset 0.5 --chi 0.5 \
        --collisions trt --variants nebb --weights ntw --methods exact --precisions fp64 --tau 0.6 --magic 3e-2 \
        --d 16,24,32,48 --out "$OUT/drag_re_ref.json" > "$OUT/drag_re_ref.md" 2> "$OUT/drag_re_ref.log"
      echo "re reference: exit $?"
      timeout 120 "$bin" sweep --backend cuda --re "$res" --tol 1e-6 --start estimate --offset 0.5 --chi 0.5 \
        --collisions trt --variants nebb --weights ntw --methods exact --precisions fp64 --tau 0.6 --magic auto \
        --d 8,10,16,20,30 --out "$OUT/drag_re_rule.json" > "$OUT/drag_re_rule.md" 2> "$OUT/drag_re_rule.log"
      echo "re rule: exit $?"
      python3 "$LBDEM_ROOT/scripts/drag_re.py" "$OUT/drag_re_ref.json" "$OUT/drag_re_rule.json" \
        --out-json "$OUT/drag_re.jsonl" > "$OUT/drag_re.md"
      cat "$OUT/drag_re.md"
      ;;
    random)
      rm -f "$OUT/random_array.jsonl"
      {
        timeout 70 "$bin" random --backend cuda --n 3 --d 10 --phi 0.1,0.2,0.3,0.4 --re 0.2 --tau 0.8 --seeds 1,2 \
          --out "$OUT/random_array.jsonl"
        timeout 60 "$bin" random --backend cuda --n 3 --d 16 --phi 0.2,0.4 --re 10,50 --tau 0.55 --seeds 1 \
          --out "$OUT/random_array.jsonl"
      } > "$OUT/random_array.md" 2> "$OUT/random_array.log"
      echo "random: exit $?"
      cat "$OUT/random_array.md"
      ;;
    drift)
      timeout 300 "$bin" drift --backend cuda --precision fp64 --dims 64,252,64 --steps 100000 --every 5000 \
        > "$OUT/drift.jsonl" 2> "$OUT/drift.log"
      echo "drift: exit $?"
      cat "$OUT/drift.jsonl"
      ;;
    drift-even)
      for phi in ${DRIFT_EVEN:-0 0.02 1}; do
        timeout 300 "$bin" drift --backend cuda --precision fp64 --dims 64,252,64 --steps 100000 --every 5000 \
          --even-relaxation "$phi" > "$OUT/drift_even$phi.jsonl" 2> "$OUT/drift_even$phi.log"
        echo "drift-even $phi: exit $?"
      done
      for phi in ${DRIFT_EVEN:-0 0.02 1}; do
        echo "phi $phi: $(head -n 1 "$OUT/drift_even$phi.jsonl")"
        tail -n 1 "$OUT/drift_even$phi.jsonl"
      done
      ;;
    *) echo "drag_gpu: unknown part $p (map, lambda, re, random, drift, drift-even)"; exit 2 ;;
  esac
done
