#!/usr/bin/env bash
# The production suspensions on one GPU (issue 16): runs the reduced boxes for a
# bounded wall time each and the full-size cases for a few steps, writing to
# $OUT (default ./out/suspension):
#   <case>/                 the run folder (series.csv, summary.json, fields/particles .h5 + .xdmf)
#   <case>.log              lbdem's output (progress with coupled MLUPS, the statistics' share, the
#                           mean slip against Wen-Yu)
#   <case>/snapshots.png, series.png   scripts/plot_suspension.py (when matplotlib and h5py are there)
#   check_<case>.log        `lbdem check` of each case (memory estimate per component once it prints one)
#   suspension.jsonl        one line per run: case, steps, seconds, coupled MLUPS, mean slip, Wen-Yu slip,
#                           statistics share, device, commit
#
#   scripts/suspension_gpu.sh [build] [CASE:STEPS ...]
#     build        configure and build the `cuda` preset in build-gpu/ first
#     CASE:STEPS   cases/suspension/<CASE>.yaml for STEPS steps (default: suspension_3d_small:200000
#                  suspension_2d_small:100000 suspension_3d_half:20000). The full sizes
#                  (suspension_3d:200, suspension_2d:200) are for speed and memory only: a run ends by
#                  writing its fields, ~20 GB in fp64 HDF5 at that size.
#   PRECISION=fp64 runs them in fp64 (a copy of the case with fluid.precision replaced).
#   One 10-minute device call holds about one 3d_small job of 200,000 steps; pass fewer cases per call.
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
OUT="${OUT:-$here/out}/suspension"
mkdir -p "$OUT"
build="$here/build-gpu"
commit="${LBDEM_COMMIT:-$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)}"
device="$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1)"
if [ "${1:-}" = build ]; then
  shift
  (cd "$here" && cmake --preset cuda && cmake --build --preset cuda --target lbdem) > "$OUT/build.log" 2>&1 ||
    { echo "build failed: $OUT/build.log"; exit 1; }
fi
lbdem="$build/cases/lbdem"
[ -x "$lbdem" ] || { echo "no $lbdem: run with 'build' first"; exit 1; }
runs=("$@")
[ ${#runs[@]} -gt 0 ] || runs=(suspension_3d_small:200000 suspension_2d_small:100000 suspension_3d_half:20000)
py=""
for p in python3 /usr/bin/python3; do
  if "$p" -c 'import matplotlib, h5py, numpy' 2>/dev/null; then py="$p"; break; fi
done
for r in "${runs[@]}"; do
  name="${r%%:*}" steps="${r##*:}"
  case_file="$here/cases/suspension/$name.yaml"
  if [ -n "${PRECISION:-}" ]; then
    sed "s/precision: fp32/precision: $PRECISION/" "$case_file" > "$OUT/$name.$PRECISION.yaml"
    case_file="$OUT/$name.$PRECISION.yaml"
    name="$name.$PRECISION"
  fi
  "$lbdem" check "$case_file" > "$OUT/check_$name.log" 2>&1
  "$lbdem" run "$case_file" --backend cuda --steps "$steps" --output "$OUT/$name" --overwrite > "$OUT/$name.log" 2>&1
  rc=$?
  [ -n "$py" ] && [ -f "$OUT/$name/series.csv" ] && "$py" "$here/scripts/plot_suspension.py" "$OUT/$name" \
    >> "$OUT/$name.log" 2>&1
  if [ -f "$OUT/$name/summary.json" ]; then
    "${py:-python3}" - "$OUT/$name/summary.json" "$name" "$rc" "$device" "$commit" >> "$OUT/suspension.jsonl" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
st = s.get("statistics", {})
print(json.dumps({"case": sys.argv[2], "exit": int(sys.argv[3]), "device": sys.argv[4], "commit": sys.argv[5],
                  "steps": s["steps"], "seconds": s["seconds"], "coupled_mlups": s["coupled_mlups"],
                  "particles": s["particles"], "cells": s["lattice"]["cells"],
                  "statistics_fraction": st.get("fraction_of_run"), "mean_slip": st.get("mean_slip"),
                  "wen_yu_slip": st.get("wen_yu_slip"), "slip_over_wen_yu": st.get("slip_over_wen_yu"),
                  "mean_drag_over_weight": st.get("mean_drag_over_weight"),
                  "simulated_seconds": s["steps"] * s["conversion"]["dt_s"]}))
PY
  else
    echo "{\"case\": \"$name\", \"exit\": $rc, \"device\": \"$device\", \"commit\": \"$commit\"}" >> "$OUT/suspension.jsonl"
  fi
done
echo "results in $OUT (suspension.jsonl)"
