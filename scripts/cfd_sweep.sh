#!/usr/bin/env bash
# Pressure drop against superficial velocity for the small bed (cases/fluidized_bed_small.yaml): one run per
# inlet velocity, the time-averaged pressure drop over the bed's buoyant weight per area from each run's
# summary.json, then the curve against Ergun's law (at the settled packing) and the bed weight
# (scripts/plot_cfd.py sweep).
#
#   scripts/cfd_sweep.sh [OUTDIR] [U...]        default OUTDIR runs/cfd_sweep, U 0.05 0.1 ... 0.5 m/s
#   env  BACKEND (cpu | cuda | auto, default auto), END (simulated s per run, default 1.3),
#        START (s from which the average is taken, default 0.3)
# Writes OUTDIR/sweep.csv (U, pressure drop [Pa], its ratio to the weight per area, bed height [m]) and
# OUTDIR/sweep.png. On a busy host, OMP_NUM_THREADS=1 is often the fastest for this small bed.
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:-runs/cfd_sweep}"
[ $# -gt 0 ] && shift
speeds=("$@")
[ ${#speeds[@]} -eq 0 ] && speeds=(0.05 0.1 0.15 0.2 0.25 0.3 0.35 0.4 0.5)
lbdem="${LBDEM:-$here/build/cases/lbdem}"
[ -x "$lbdem" ] || { echo "cfd_sweep: no lbdem at $lbdem (build it, or set LBDEM)"; exit 2; }
mkdir -p "$out"
echo "velocity,pressure_drop,pressure_drop_over_weight,bed_height,weight_per_area" > "$out/sweep.csv"
for u in "${speeds[@]}"; do
  c="$out/u_$u.yaml"
  sed -e "s/z_lo: {type: inlet, velocity: [0-9.e+-]*}/z_lo: {type: inlet, velocity: $u}/" \
      -e "s/^time: {end: [0-9.e+-]*}/time: {end: ${END:-1.3}}/" \
      -e "s/^statistics: {start: [0-9.e+-]*,/statistics: {start: ${START:-0.3},/" \
      "$here/cases/fluidized_bed_small.yaml" > "$c"
  if ! "$lbdem" run "$c" --backend "${BACKEND:-auto}" --output "$out/u_$u" --overwrite --quiet > "$out/u_$u.log" 2>&1; then
    echo "U = $u m/s: run failed (see $out/u_$u.log)"; continue
  fi
  python3 - "$out/u_$u/summary.json" "$u" >> "$out/sweep.csv" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print(f"{sys.argv[2]},{s['mean_pressure_drop_pa']},{s['mean_pressure_drop_over_weight']},{s['mean_bed_height_m']},{s['weight_per_area_pa']}")
PY
  tail -1 "$out/sweep.csv"
done
python3 "$here/scripts/plot_cfd.py" sweep "$out/sweep.csv"
