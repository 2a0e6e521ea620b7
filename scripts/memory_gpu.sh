#!/usr/bin/env bash
# Device memory and coupled speed of a periodic suspension on one GPU, against
# lbdem's own estimate (issue 16: the estimate must be exact, the footprint
# <= 100 B/cell in fp32 and <= 175 B/cell in fp64, and output must not need
# device memory the run did not reserve at start).
#   scripts/memory_gpu.sh BUILD OUT_DIR [N] [steps]
#     BUILD    a CUDA build folder: lbdem is built there (scripts/lib.sh lbdem_build; configured with the
#              `cuda` preset if new), so the folder of scripts/gpu_run.sh -B serves
#     OUT_DIR  results: memory_gpu.jsonl (one line per precision), the case
#              files, the logs and the runs' summary.json
#     N        cells per axis of the cube (default 256)
#     steps    coupled steps (default 400)
#   CASE=FILE   instead of the N^3 cube: this case file (e.g. cases/suspension/suspension_3d.yaml, the paper's
#               full size), its precision, steps and output replaced per run (fields written once, at the end,
#               as float32); PRECS="fp32 fp64" picks the precisions (default both)
# The scene: N^3 cells, fully periodic, spheres of d/l = 10 at solid fraction
# 0.128 (the first paper's 3D suspension, Table 2), density ratio 100, table
# fractions, fused pipeline, K = 4. For fp32 and fp64: `lbdem check` prints
# the estimate by component; the run writes its fields at step 0 and at the
# end (the slab output path) while nvidia-smi samples the memory in use every
# 20 ms. Each JSON line: the used memory before the run (MiB), the peak during
# it, the peak minus the idle use per cell, the estimate's total per cell, the
# bytes the fluid and the coupling hold (summary.json memory_bytes) and the
# coupled MLUPS, with device, date and commit.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?build dir}"
out="${2:?output dir}"
n="${3:-256}"
steps="${4:-400}"
lbdem_env
[ "$(gpu_count)" -ge 1 ] || { echo "memory_gpu: no GPU"; exit 1; }
mkdir -p "$out"
LBDEM_BUILD_LOG="$out/build.log" lbdem_build "$build" lbdem || exit 1
lbdem="$build/cases/lbdem"
: > "$out/memory_gpu.jsonl"
for prec in ${PRECS:-fp32 fp64}; do
  case_file="$out/suspension_${n}_${prec}.yaml"
  if [ -n "${CASE:-}" ]; then
    case_file="$out/$(basename "$CASE" .yaml)_${prec}.yaml"
    python3 - "$CASE" "$case_file" "$prec" "$steps" "$out/run_$prec" <<'PY'
import re, sys
src, dst, prec, steps, outdir = sys.argv[1:]
t = open(src).read()
t = re.sub(r"precision: *fp\w+", "precision: " + prec, t)
t = re.sub(r"(?<![a-z_])steps: *\d+", "steps: " + steps, t)
t = re.sub(r"^output:.*$", "output: {directory: %s, series_interval: 100, interval: 0, field_precision: fp32}" % outdir, t, flags=re.M)
open(dst, "w").write(t)
PY
  else
  cat > "$case_file" <<EOF
scene: particles
units: lattice
domain: {cells: [$n, $n, $n], periodic: [1, 1, 1]}
fluid: {tau: 0.6, collision: trt, magic: 1.0e-3, precision: $prec}
physics: {gravity: [0, -1.0e-6, 0]}
particles: {init: random, diameter: 10, density_ratio: 100, solid_fraction: 0.128, seed: 7}
dem: {stiffness: 20000, restitution: 0.9, substeps: 25}
psm: {fraction: table, pipeline: fused}
time: {steps: $steps}
output: {directory: $out/run_$prec, series_interval: 100, interval: $steps}
EOF
  fi
  "$lbdem" check "$case_file" > "$out/check_$prec.log" 2>&1
  est=$(awk '$1 == "total" {print $2}' "$out/check_$prec.log")
  idle=$(nvidia-smi --query-gpu=memory.used --format=csv,noheader,nounits -i 0 | head -1 | tr -d ' ')
  rm -rf "$out/run_$prec"
  gpu_peak_mib "$out/samples_$prec.txt" "$lbdem" run "$case_file" --backend cuda --overwrite > "$out/run_$prec.log" 2>&1
  rc=$?
  peak=$(sort -n "$out/samples_$prec.txt" | tail -1)
  summary="$out/run_$prec/summary.json"
  mlups=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['coupled_mlups'])" "$summary" 2>/dev/null || echo null)
  held=$(python3 -c "import json,sys; print(json.dumps(json.load(open(sys.argv[1]))['memory_bytes']))" "$summary" 2>/dev/null || echo null)
  cp "$summary" "$out/summary_$prec.json" 2>/dev/null
  cells=$(grep -oE "[0-9.e+]+ cells" "$out/check_$prec.log" | head -1 | cut -d' ' -f1)
  python3 - "$prec" "$n" "$idle" "$peak" "${est:-null}" "$mlups" "$held" "$rc" "${CASE:-}" "$cells" "$LBDEM_DEVICE" \
    "$LBDEM_COMMIT" >> "$out/memory_gpu.jsonl" <<'PY'
import datetime, json, sys
prec, n, idle, peak, est, mlups, held, rc, case, cells_text, device, commit = sys.argv[1:]
cells = float(cells_text) if case and cells_text else int(n) ** 3
num = lambda s: None if s in ("", "null") else float(s)
idle, peak = num(idle), num(peak)
print(json.dumps({
    "case": case or "cube", "precision": prec, "cells": cells, "exit": int(rc),
    "device_used_before_mib": idle, "device_peak_mib": peak,
    "peak_minus_idle_bytes_per_cell": None if idle is None or peak is None else (peak - idle) * 1048576 / cells,
    "estimate_bytes_per_cell": num(est),
    "held_bytes": json.loads(held) if held not in ("", "null") else None,
    "coupled_mlups": num(mlups),
    "device": device, "date": datetime.date.today().isoformat(), "commit": commit,
}))
PY
done
cat "$out/memory_gpu.jsonl"
