#!/usr/bin/env bash
# Fixed-sphere PSM drag sweep on the GPU (issue 4: the first paper's Table 1
# test against Sangani & Acrivos, chi = d/L = 0.5), in two parts sized for one
# device call (<= 10 min wall) each:
#
#   scripts/psm_sweep_gpu.sh BIN OUTDIR PART...      PART: small | large | scan | lambda | plot (one of small/large per call)
#
#   BIN     the CUDA build's lbdem_bench_psm
#   OUTDIR  receives psm_sweep_<part>_<k>.{json,md,log}; each JSON is rewritten after every run,
#           so a part cut off by its time limit keeps the rows it finished
#   env     PSM_SWEEP_LIMIT (s per part, default 470), PSM_SWEEP_BACKEND (default cuda)
#
# small (estimate ~3.5 min on an H200, limit 470 s): d/l 4-16 and 20, every fraction method x
#       fp64/fp32 x TRT/BGK at the accurate setting; the Lambda and sphere-position checks at d/l
#       4-20; d/l 30: every fraction method x fp64/fp32, TRT; BGK and the Lambda check (exact fp64).
# large (estimate ~5.5 min, limit 470 s): d/l 50 (1e6 cells, ~1.2e6 steps), the reduced matrix in
#       order of importance: exact fp64 TRT (the headline row), exact fp64 TRT at Lambda 1e-2 (the
#       small-d/l vs large-d/l trade-off, NOTES), table fp32 TRT (the paper's fractions), exact fp32 TRT.
# plot: scripts/plot_psm_sweep.py on every JSON under OUTDIR (needs python3-matplotlib).
#
# Accurate setting (bench/imb/NOTES.md, "Fixed-sphere drag: host study"): tau = 0.52, TRT Lambda =
# 1e-4, Noble-Torczynski B, NEBB, sphere centre on a cell centre (offset 0.5), Re_p = 0.2, fluid
# started from the Stokes estimate, steady when the estimated remaining relative change of the drag
# is < 1e-5. Steps to steady state ~ 9 T, T = 0.094 L^2 / nu (the slow mean-flow mode, measured on
# the host; nu = 1/150): d/l 20 2.1e5 (measured), 30 ~4.6e5, 50 ~1.2e6. Time per step assumed:
# ~10-15 us up to 40^3 cells (launch-bound), ~30 us at 60^3, ~90 us (fp64) / ~50 us (fp32) at 100^3.
set -uo pipefail
if [ $# -lt 3 ]; then sed -n 2,27p "$0"; exit 2; fi
bin="$1"
out="$2"
shift 2
parts=("$@")
here="$(cd "$(dirname "$0")/.." && pwd)"
mkdir -p "$out"
[ -x "$bin" ] || { echo "psm_sweep_gpu: $bin is not an executable"; exit 2; }

TAU=0.52
MAGIC=1e-4
OFFSET=0.5
common=(--backend "${PSM_SWEEP_BACKEND:-cuda}" --tau "$TAU" --re 0.2 --tol 1e-5 --start estimate)
t0=$SECONDS
limit=${PSM_SWEEP_LIMIT:-470}  # seconds per part (one device call: 10 min, less start-up)

# run NAME SECONDS_CAP ARGS...: one sweep, stopped at the part's deadline or its own cap.
run() {
  local name="$1" cap="$2"
  shift 2
  local left=$((limit - (SECONDS - t0)))
  [ "$left" -gt "$cap" ] && left=$cap
  if [ "$left" -lt 10 ]; then echo "$name: skipped (part time limit)"; return; fi
  timeout "$left" "$bin" sweep "${common[@]}" "$@" --out "$out/$name.json" > "$out/$name.md" 2> "$out/$name.log"
  local rc=$?
  echo "$name: exit $rc ($((SECONDS - t0)) s into the part)"
  grep '^| [0-9]' "$out/$name.md" | cut -d'|' -f2-13 | sed 's/^/  /'
}

for p in "${parts[@]}"; do
  t0=$SECONDS
  case "$p" in
    small)
      # Full matrix, d/l 4-16: 60 runs, ~45 s.
      run psm_sweep_small_1 200 --d 4,6,8,10,16 --magic "$MAGIC" --offset "$OFFSET" \
        --methods exact,table,linear --precisions fp64,fp32 --collisions trt,bgk
      # Full matrix, d/l 20 (40^3, 2.1e5 steps): 12 runs, ~40 s.
      run psm_sweep_small_2 150 --d 20 --magic "$MAGIC" --offset "$OFFSET" \
        --methods exact,table,linear --precisions fp64,fp32 --collisions trt,bgk
      # Lambda (1e-3: the earlier default; 1e-2) and the sphere on a cell corner, exact fp64 TRT: ~20 s.
      run psm_sweep_small_3 60 --d 4,6,8,10,16,20 --magic 1e-3,1e-2 --offset "$OFFSET" --methods exact \
        --precisions fp64 --collisions trt
      run psm_sweep_small_4 40 --d 4,6,8,10,16,20 --magic "$MAGIC" --offset 0 --methods exact \
        --precisions fp64 --collisions trt
      # d/l 30 (60^3, ~4.6e5 steps, ~10-15 s each): every method x fp64/fp32, TRT: ~75 s.
      run psm_sweep_small_5 150 --d 30 --magic "$MAGIC" --offset "$OFFSET" \
        --methods exact,table,linear --precisions fp64,fp32 --collisions trt
      # d/l 30: BGK (exact fp64), and Lambda 1e-3 / 1e-2 (exact fp64 TRT): ~45 s.
      run psm_sweep_small_6 60 --d 30 --magic "$MAGIC" --offset "$OFFSET" --methods exact --precisions fp64 \
        --collisions bgk
      run psm_sweep_small_7 60 --d 30 --magic 1e-3,1e-2 --offset "$OFFSET" --methods exact --precisions fp64 \
        --collisions trt
      ;;
    large)
      # d/l 50 (100^3 = 1e6 cells, ~1.2e6 steps): ~110 s per fp64 run, ~60 s per fp32 run.
      run psm_sweep_large_1 200 --d 50 --magic "$MAGIC" --offset "$OFFSET" --methods exact --precisions fp64 \
        --collisions trt
      run psm_sweep_large_2 170 --d 50 --magic 1e-2 --offset "$OFFSET" --methods exact --precisions fp64 \
        --collisions trt
      run psm_sweep_large_3 120 --d 50 --magic "$MAGIC" --offset "$OFFSET" --methods table --precisions fp32 \
        --collisions trt
      run psm_sweep_large_4 120 --d 50 --magic "$MAGIC" --offset "$OFFSET" --methods exact --precisions fp32 \
        --collisions trt
      ;;
    scan)
      # Drag against the solid operator and Lambda/tau at d/l 4-30 (exact fp64 TRT, sphere on a cell
      # centre): is there one setting whose O(1/d) error term is small enough for d/l 30 and 50 while
      # d/l 4 keeps its bar? (~3 min)
      run psm_sweep_scan_1 120 --d 4,6,8,10,16,20,30 --variants super --magic 1e-4,1e-3,1e-2 --offset "$OFFSET" \
        --methods exact --precisions fp64 --collisions trt
      run psm_sweep_scan_2 60 --d 4,6,8,10,16,20,30 --magic 3e-2 --offset "$OFFSET" --methods exact \
        --precisions fp64 --collisions trt
      run psm_sweep_scan_3 120 --d 4,6,8,10,16,20,30 --tau 0.505 --magic 1e-2,3e-2 --offset "$OFFSET" \
        --methods exact --precisions fp64 --collisions trt
      ;;
    lambda)
      # Resolution-dependent Lambda (the scan: 3e-2 meets the bars from d/l 16 up, 1e-4 up to d/l 20):
      # d/l 50 at 3e-2 (~120 s), and 2e-2 at d/l 16-30 (sensitivity, ~15 s). Exact fp64 TRT.
      run psm_sweep_lambda_1 200 --d 50 --magic 3e-2 --offset "$OFFSET" --methods exact --precisions fp64 \
        --collisions trt
      run psm_sweep_lambda_2 60 --d 16,20,30 --magic 2e-2 --offset "$OFFSET" --methods exact --precisions fp64 \
        --collisions trt
      ;;
    plot)
      shopt -s nullglob
      files=("$out"/psm_sweep_*.json)
      if [ ${#files[@]} -gt 0 ]; then
        /usr/bin/python3 "$here/scripts/plot_psm_sweep.py" "$out/psm_sweep.png" "${files[@]}" &&
          echo "plot: $out/psm_sweep.png" || echo "plot: failed (python3-matplotlib missing?)"
      fi
      ;;
    *) echo "psm_sweep_gpu: unknown part $p (small, large, plot)"; exit 2 ;;
  esac
done
