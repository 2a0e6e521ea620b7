#!/usr/bin/env bash
# Mueller et al.'s bubbling bed against its MRI measurements, on up to 4 GPUs of one host, side by side:
#   GPU 0  muller_u06        cases/fluidized_bed_muller_u06.yaml as it is (U = 0.6 m/s)
#   GPU 1  muller_u09        cases/fluidized_bed_muller_u09.yaml as it is (U = 0.9 m/s)
#   GPU 2  u09_wall_friction U = 0.9 m/s with particle-wall friction 0.3 instead of 0.1 (material.wall_friction):
#                            the front and back walls of the 10 mm deep bed (8 particle diameters) hold back the
#                            down-flow at the walls and with it the whole circulation, which is too strong at 0.9 m/s
#   GPU 3  u09_quadratic     U = 0.9 m/s with the quadratic void-fraction kernel (27 cells) instead of the linear
#                            one (8 cells): the 2 mm cells are 1.7 particle diameters, so the linear kernel averages
#                            the solid fraction over ~(4 mm)^3 where the paper's centroid mapping on 2.9 mm cells
#                            sees ~3x more volume per cell; a wider kernel smooths the drag's steep dependence on
#                            the solid fraction in the bubble's wake
# then bench/cfd/compare_mueller.py: per measured profile the RMS difference, centre and wall values of
# simulation and experiment (comparison.md, printed; comparison.jsonl) and one PNG per profile, all runs overlaid.
#
#   scripts/cfd_validate_gpu.sh BUILD_DIR [END [START]]
#     BUILD_DIR  a build folder of the `cuda` preset (configured and built here if needed: target lbdem)
#     END        simulated seconds (default 15, the paper's); START: averages from (default 5, the last 10 s)
#   env  LIMIT   wall seconds per run (default 480): a run still going is stopped by SIGTERM, writes its
#                profiles (averaged so far), summary and a checkpoint, and the comparison uses what it has
#        RESUME=1  continue each run from the checkpoint a previous call left under $OUT/validate (the same
#                END and START): a 15 s run that does not fit one call finishes in two
# Output under $OUT/validate: <run>/{summary.json,series.csv,profiles.csv,checkpoint.lbdem} (no field snapshots
# but the first and last), <run>.log, comparison.{md,jsonl}, mueller_*.png, runs.jsonl (one JSON line per run:
# seconds per simulated second, simulated time reached, pressure drop over weight).
# Time: at the speed of main fb8d48a (34 s per simulated s on an H200) 15 s takes ~8.5 min; END=12 START=4 fits
# LIMIT=480 with the build already done. Needs 4 GPUs for the two variants (fewer: the variants are skipped).
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?usage: scripts/cfd_validate_gpu.sh BUILD_DIR [END [START]]}"
end="${2:-15}"
start="${3:-5}"
limit="${LIMIT:-480}"
lbdem_env
out="$OUT/validate"
mkdir -p "$out"
lbdem_build "$build" lbdem || exit 1
exe="$build/cases/lbdem"
ngpu="$(gpu_count)"
[ "$ngpu" -ge 1 ] || { echo "no GPU"; exit 1; }

# run NAME CASE GPU SED...: CASE with END/START, outputs only at the first and last step, under $limit s.
run() {
  local name="$1" case="$2" gpu="$3"; shift 3
  local yaml="$out/$name.yaml" mode=(--overwrite)
  sed -e "s/^time: {end: [0-9.e+-]*}/time: {end: $end}/" -e "s/^  start: [0-9.e+-]*$/  start: $start/" \
    -e "s/interval: 5000, series_interval/interval: 0, series_interval/" "$@" "$LBDEM_ROOT/cases/$case" > "$yaml"
  if [ "${RESUME:-0}" = 1 ] && [ -f "$out/$name/checkpoint.lbdem" ]; then mode=(--restart "$out/$name"); fi
  CUDA_VISIBLE_DEVICES="$gpu" timeout -s TERM -k 30 "$limit" "$exe" run "$yaml" --backend cuda \
    --output "$out/$name" "${mode[@]}" > "$out/$name.log" 2>&1
  echo "$name exit $? (0: done; 5: stopped at LIMIT, profiles and a checkpoint written)"
}

t0=$SECONDS
run muller_u06 fluidized_bed_muller_u06.yaml 0 &
if [ "$ngpu" -ge 2 ]; then run muller_u09 fluidized_bed_muller_u09.yaml 1 &
else wait; run muller_u09 fluidized_bed_muller_u09.yaml 0; fi
if [ "$ngpu" -ge 4 ]; then
  run u09_wall_friction fluidized_bed_muller_u09.yaml 2 \
    -e "s/^material: {\(.*\)}/material: {\1, wall_friction: 0.3}/" &
  run u09_quadratic fluidized_bed_muller_u09.yaml 3 -e "s/^  void_fraction: linear/  void_fraction: quadratic/" &
else
  echo "$ngpu GPUs: the two variants skipped"
fi
wait
echo "runs done in $((SECONDS - t0)) s"

runs=()
for name in muller_u06 muller_u09 u09_wall_friction u09_quadratic; do
  s="$out/$name/summary.json"
  [ -f "$s" ] || continue
  get() { grep -o "\"$1\": [^,}]*" "$s" | head -1 | sed 's/^[^:]*: //; s/"//g'; }
  json_line "$out/runs.jsonl" run="$name" simulated_s="$(get time_s)" end_s="$end" start_s="$start" \
    s_per_simulated_s="$(get seconds_per_simulated_second)" particle_steps_per_s="$(get particle_steps_per_second)" \
    dp_over_weight="$(get mean_pressure_drop_over_weight)" samples="$(get statistics_samples)" \
    interrupted="$(get interrupted)" restarted_from_step="$(get restarted_from_step)"
  tail -1 "$out/runs.jsonl"
  case "$name" in muller_u06) c=u06 ;; *) c=u09 ;; esac
  [ -f "$out/$name/profiles.csv" ] && runs+=(--run "$name" "$c" "$out/$name")
done
py=python3
python3 -c "import numpy" 2>/dev/null || py=/usr/bin/python3
if [ ${#runs[@]} -gt 0 ]; then
  "$py" "$LBDEM_ROOT/bench/cfd/compare_mueller.py" --out "$out" "${runs[@]}"
else
  echo "no profiles.csv: see the logs"; for f in "$out"/*.log; do tail_log "$f" 5; done
fi
