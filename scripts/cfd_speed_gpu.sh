#!/usr/bin/env bash
# Speed of the unresolved CFD-DEM beds and where their time goes, on up to 3 GPUs of one host side by side, then
# the 10^6-particle benchmark against all host cores:
#   GPU 0  Mueller's bed at 0.6 m/s (cases/fluidized_bed_muller_u06.yaml), STEPS gas steps
#   GPU 1  Mueller's bed at 0.9 m/s (cases/fluidized_bed_muller_u09.yaml), STEPS gas steps
#   GPU 2  Link's spout-fluid bed (cases/fluidized_bed_link_spout.yaml), STEPS gas steps
# Per run: seconds per simulated second, particle-steps/s, and per gas step the DEM's neighbour-list rebuilds
# (~10 launches and one blocking read each) and the rebuild-decision reads that found the device behind (host
# waits) - the launch and synchronisation counts of cfd/NOTES.md made concrete. Run it before and after a
# change to the step (the same STEPS, the same machine) for the before/after. Then lbdem_bench_cfd (the
# Sec. 5.2 system, 10^6 particles, CUDA and all host cores; GPU 0).
#
#   scripts/cfd_speed_gpu.sh BUILD_DIR [STEPS]
#     BUILD_DIR  a build folder of the `cuda` preset (configured and built here if needed: lbdem, lbdem_bench_cfd)
#     STEPS      gas steps per bed run (default 2000: Mueller 0.3 s simulated, Link 0.06 s)
#   env  BENCH_ARGS  arguments of lbdem_bench_cfd besides --out (default --steps 20 --host-steps 3)
# Output under $OUT/speed: <run>/{summary.json,series.csv}, <run>.log, speed.jsonl (one JSON line per run),
# bench_cfd.{json,md}. Time: ~1-3 min for the beds at the speed of main fb8d48a (34 and 98 s per simulated
# s), ~2 min for the benchmark; fewer than 3 GPUs: the runs go one after another on GPU 0.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?usage: scripts/cfd_speed_gpu.sh BUILD_DIR [STEPS]}"
steps="${2:-2000}"
lbdem_env
out="$OUT/speed"
mkdir -p "$out"
lbdem_build "$build" lbdem lbdem_bench_cfd || exit 1
exe="$build/cases/lbdem"
ngpu="$(gpu_count)"
[ "$ngpu" -ge 1 ] || { echo "no GPU"; exit 1; }

# run NAME CASE GPU: CASE for $steps gas steps, snapshots only at the first and last step.
run() {
  local name="$1" case="$2" gpu="$3" yaml="$out/$1.yaml"
  sed -e "s/^time: {end: [0-9.e+-]*}/time: {steps: $steps}/" \
    -e "s/^output: {directory: \([^,]*\), interval: [0-9]*/output: {directory: \1, interval: 0/" \
    "$LBDEM_ROOT/cases/$case" > "$yaml"
  CUDA_VISIBLE_DEVICES="$gpu" timeout -s TERM -k 30 420 "$exe" run "$yaml" --backend cuda --output "$out/$name" \
    --overwrite > "$out/$name.log" 2>&1
  echo "$name exit $?"
}
gpu() { if [ "$ngpu" -ge 3 ]; then echo "$1"; else echo 0; fi; }
par() { if [ "$ngpu" -ge 3 ]; then "$@" & else "$@"; fi; }

t0=$SECONDS
par run muller_u06 fluidized_bed_muller_u06.yaml "$(gpu 0)"
par run muller_u09 fluidized_bed_muller_u09.yaml "$(gpu 1)"
par run link_spout fluidized_bed_link_spout.yaml "$(gpu 2)"
wait
echo "bed runs done in $((SECONDS - t0)) s"
for name in muller_u06 muller_u09 link_spout; do
  s="$out/$name/summary.json"
  [ -f "$s" ] || { tail_log "$out/$name.log" 8; continue; }
  get() { grep -o "\"$1\": [^,}]*" "$s" | head -1 | sed 's/^[^:]*: //; s/"//g'; }
  gs="$(get gas_steps)"
  per() { awk -v a="$1" -v b="$gs" 'BEGIN { printf "%.3g", (b > 0 ? a / b : 0) }'; }
  json_line "$out/speed.jsonl" run="$name" gas_steps="$gs" simulated_s="$(get time_s)" \
    s_per_simulated_s="$(get seconds_per_simulated_second)" particle_steps_per_s="$(get particle_steps_per_second)" \
    dem_substeps="$(get dem_substeps)" dem_rebuilds_per_gas_step="$(per "$(get dem_rebuilds)")" \
    dem_report_reads_per_gas_step="$(per "$(get dem_report_reads)")" \
    dem_report_waits_per_gas_step="$(per "$(get dem_report_waits)")" interrupted="$(get interrupted)"
  tail -1 "$out/speed.jsonl"
done
CUDA_VISIBLE_DEVICES=0 timeout 300 "$build/bench/cfd/lbdem_bench_cfd" --out "$out" ${BENCH_ARGS:---steps 20 --host-steps 3} \
  > "$out/bench_cfd.log" 2>&1
echo "bench exit $?"
cat "$out/bench_cfd.md" 2>/dev/null || tail_log "$out/bench_cfd.log" 8
