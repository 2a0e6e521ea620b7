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
#                           statistics share, device, date, commit
#
#   scripts/suspension_gpu.sh [-B DIR] [build] [CASE:STEPS ...]
#     -B DIR       the build folder (default $LBDEM_BUILD, else build-gpu/); lbdem is built there first
#                  (scripts/lib.sh lbdem_build: the `cuda` preset if new); `build` is accepted, not needed
#     CASE:STEPS   cases/suspension/<CASE>.yaml for STEPS steps (default: suspension_3d_small:200000
#                  suspension_2d_small:100000 suspension_3d_half:20000). The full sizes
#                  (suspension_3d:200, suspension_2d:200) are for speed and memory only: a run ends by
#                  writing its fields, ~20 GB in fp64 HDF5 at that size.
#   PRECISION=fp64 runs them in fp64 (a copy of the case with fluid.precision replaced).
#   One 10-minute device call holds about one 3d_small job of 200,000 steps; pass fewer cases per call.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
[ "${1:-}" = -B ] && { LBDEM_BUILD="${2:?-B needs a build folder}"; shift 2; }
[ "${1:-}" = build ] && shift
export OUT="${OUT:-$LBDEM_ROOT/out}/suspension"
lbdem_env
here="$LBDEM_ROOT"
lbdem_build "$LBDEM_BUILD" lbdem || { echo "build failed: $OUT/build.log"; exit 1; }
lbdem="$LBDEM_BUILD/cases/lbdem"
runs=("$@")
[ ${#runs[@]} -gt 0 ] || runs=(suspension_3d_small:200000 suspension_2d_small:100000 suspension_3d_half:20000)
py="$(plot_python)"
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
    "${py:-python3}" - "$OUT/$name/summary.json" "$name" "$rc" "$LBDEM_DEVICE" "$LBDEM_COMMIT" \
      >> "$OUT/suspension.jsonl" <<'PY'
import datetime, json, sys
s = json.load(open(sys.argv[1]))
st = s.get("statistics", {})
print(json.dumps({"case": sys.argv[2], "exit": int(sys.argv[3]), "device": sys.argv[4], "commit": sys.argv[5],
                  "date": datetime.date.today().isoformat(),
                  "steps": s["steps"], "seconds": s["seconds"], "coupled_mlups": s["coupled_mlups"],
                  "particles": s["particles"], "cells": s["lattice"]["cells"],
                  "statistics_fraction": st.get("fraction_of_run"), "mean_slip": st.get("mean_slip"),
                  "wen_yu_slip": st.get("wen_yu_slip"), "slip_over_wen_yu": st.get("slip_over_wen_yu"),
                  "mean_drag_over_weight": st.get("mean_drag_over_weight"),
                  "simulated_seconds": s["steps"] * s["conversion"]["dt_s"]}))
PY
  else
    json_line "$OUT/suspension.jsonl" case="$name" exit="$rc"
  fi
done
echo "results in $OUT (suspension.jsonl)"
