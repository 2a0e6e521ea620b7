#!/usr/bin/env bash
# Fixed-sphere PSM drag sweep on the GPU: the first paper's Table 1 test against Sangani & Acrivos
# (1982), chi = d/L = 0.5, in parts sized for one device call (10 min) each.
#
#   scripts/psm_sweep_gpu.sh BIN|BUILD OUTDIR PART...      PART: small | large | scan | lambda | merge | plot
#
#   BIN     the CUDA build's lbdem_bench_psm; or BUILD, a build folder where it is built first
#           (scripts/lib.sh lbdem_build; the `cuda` preset if new)
#   OUTDIR  receives psm_sweep_<part>_<k>.{json,md,log}; each JSON is rewritten after every run,
#           so a part cut off by its time limit keeps the rows it finished
#   env     PSM_SWEEP_LIMIT (s per part, default 470), PSM_SWEEP_BACKEND (default cuda)
#
# small   d/l 4-20: every fraction method x fp64/fp32 x TRT/BGK; Lambda and sphere-position checks;
#         d/l 30: every method x fp64/fp32 (TRT), BGK, Lambda checks.
# large   d/l 50 (1e6 cells), in order of importance: exact fp64 TRT, the same at Lambda 1e-2,
#         table fp32 TRT, exact fp32 TRT.
# scan    drag against the solid operator, Lambda and tau at d/l 4-30 (exact fp64 TRT).
# lambda  the resolution-dependent Lambda: d/l 50 at 3e-2, 2e-2 at d/l 16-30.
# merge   every OUTDIR/psm_sweep_*.json into OUTDIR/psm_fixed_sphere_sweep.json (rows with their source).
# plot    scripts/plot_psm_sweep.py on every OUTDIR/psm_sweep_*.json into OUTDIR/psm_sweep.png
#         (needs python3-matplotlib).
#
# Accurate setting (bench/imb/NOTES.md, "Fixed-sphere drag"): tau = 0.52, TRT Lambda = 1e-4,
# Noble-Torczynski B, NEBB, sphere centre on a cell centre (offset 0.5), Re_p = 0.2, fluid started
# from the Stokes estimate, steady when the estimated remaining relative change of the drag is < 1e-5.
# The per-run caps below follow the steps to steady state (~9 T, T = 0.094 L^2 / nu) and the time per
# step at each grid size (bench/imb/NOTES.md).
set -uo pipefail
if [ $# -lt 3 ]; then sed -n "2,/^set -uo/p" "$0" | grep "^#"; exit 2; fi
source "$(dirname "$0")/lib.sh"
bin="$1"
out="$2"
shift 2
parts=("$@")
here="$LBDEM_ROOT"
mkdir -p "$out"
if [ -d "$bin" ]; then
  LBDEM_BUILD_LOG="$out/build.log" lbdem_build "$bin" lbdem_bench_psm || exit 2
  bin="$bin/bench/imb/lbdem_bench_psm"
fi
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
      # Full matrix, d/l 4-16.
      run psm_sweep_small_1 200 --d 4,6,8,10,16 --magic "$MAGIC" --offset "$OFFSET" \
        --methods exact,table,linear --precisions fp64,fp32 --collisions trt,bgk
      # Full matrix, d/l 20 (40^3).
      run psm_sweep_small_2 150 --d 20 --magic "$MAGIC" --offset "$OFFSET" \
        --methods exact,table,linear --precisions fp64,fp32 --collisions trt,bgk
      # Lambda 1e-3 and 1e-2, and the sphere on a cell corner, exact fp64 TRT.
      run psm_sweep_small_3 60 --d 4,6,8,10,16,20 --magic 1e-3,1e-2 --offset "$OFFSET" --methods exact \
        --precisions fp64 --collisions trt
      run psm_sweep_small_4 40 --d 4,6,8,10,16,20 --magic "$MAGIC" --offset 0 --methods exact \
        --precisions fp64 --collisions trt
      # d/l 30 (60^3): every method x fp64/fp32, TRT.
      run psm_sweep_small_5 150 --d 30 --magic "$MAGIC" --offset "$OFFSET" \
        --methods exact,table,linear --precisions fp64,fp32 --collisions trt
      # d/l 30: BGK (exact fp64), and Lambda 1e-3 / 1e-2 (exact fp64 TRT).
      run psm_sweep_small_6 60 --d 30 --magic "$MAGIC" --offset "$OFFSET" --methods exact --precisions fp64 \
        --collisions bgk
      run psm_sweep_small_7 60 --d 30 --magic 1e-3,1e-2 --offset "$OFFSET" --methods exact --precisions fp64 \
        --collisions trt
      ;;
    large)
      # d/l 50 (100^3 = 1e6 cells).
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
      # d/l 4 keeps its bar?
      run psm_sweep_scan_1 120 --d 4,6,8,10,16,20,30 --variants super --magic 1e-4,1e-3,1e-2 --offset "$OFFSET" \
        --methods exact --precisions fp64 --collisions trt
      run psm_sweep_scan_2 60 --d 4,6,8,10,16,20,30 --magic 3e-2 --offset "$OFFSET" --methods exact \
        --precisions fp64 --collisions trt
      run psm_sweep_scan_3 120 --d 4,6,8,10,16,20,30 --tau 0.505 --magic 1e-2,3e-2 --offset "$OFFSET" \
        --methods exact --precisions fp64 --collisions trt
      ;;
    lambda)
      # Resolution-dependent Lambda: d/l 50 at 3e-2, and 2e-2 at d/l 16-30 (sensitivity). Exact fp64 TRT.
      run psm_sweep_lambda_1 200 --d 50 --magic 3e-2 --offset "$OFFSET" --methods exact --precisions fp64 \
        --collisions trt
      run psm_sweep_lambda_2 60 --d 16,20,30 --magic 2e-2 --offset "$OFFSET" --methods exact --precisions fp64 \
        --collisions trt
      ;;
    merge)
      python3 - "$out" <<'PY' && echo "merge: $out/psm_fixed_sphere_sweep.json" || echo "merge: failed"
import glob, json, os, sys
out = sys.argv[1]
head, rows = None, []
for f in sorted(glob.glob(os.path.join(out, "psm_sweep_*.json"))):
    j = json.load(open(f))
    head = head or {k: v for k, v in j.items() if k != "rows"}
    rows += [dict(r, source=os.path.basename(f)) for r in j.get("rows", [])]
json.dump(dict(head or {}, rows=rows), open(os.path.join(out, "psm_fixed_sphere_sweep.json"), "w"), indent=1)
PY
      ;;
    plot)
      shopt -s nullglob
      files=("$out"/psm_sweep_*.json)
      py="$(plot_python)"
      if [ ${#files[@]} -gt 0 ]; then
        "${py:-python3}" "$here/scripts/plot_psm_sweep.py" "$out/psm_sweep.png" "${files[@]}" &&
          echo "plot: $out/psm_sweep.png" || echo "plot: failed (python3-matplotlib missing?)"
      fi
      ;;
    *) echo "psm_sweep_gpu: unknown part $p (small, large, scan, lambda, merge, plot)"; exit 2 ;;
  esac
done
