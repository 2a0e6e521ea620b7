#!/usr/bin/env bash
# Speed of the two beds of issue 28 on one GPU, the pressure solve's device loop on and off, and where a gas step's
# time goes (~4-5 min after the build, one GPU, one run after another):
#   0. the GPU tests of what this touches (TESTS=0 leaves them out; ~1-2 min): cfd_tests' pressure tests on both
#      backends (the device loop against the host-polled loop and kernel-by-kernel launches, bitwise, converged
#      and cut by the iteration limit), dem_tests' GPU-against-host, sub-step graph and fused sub-step tests
#   1. Mueller's bed at 0.9 m/s (cases/fluidized_bed_muller_u09.yaml), MULLER_STEPS gas steps, twice: the host-polled
#      pressure loop (LBDEM_PRESSURE_DEVICE_LOOP=0, the step as before) and the device loop (the default); statistics
#      from 0.3 s (the bed has settled) so that both report a mean pressure drop over the bed weight
#   2. Link's spout-fluid bed (cases/fluidized_bed_link_spout.yaml), LINK_STEPS gas steps, the same two ways
#      (statistics from 0.1 s)
#   3. each bed again for PHASE_STEPS gas steps with LBDEM_STEP_PHASES=1 (a synchronisation after the gas step and
#      after the DEM sub-steps: the wall time of each, per gas step)
#   4. with BASE_BUILD set (a `cuda` build folder of the code before, e.g. of main): Mueller's bed for BASE_STEPS gas
#      steps with it and with BUILD_DIR, the final checkpoint (past its header, which names the build, and its
#      checksum), series and profiles compared byte for byte: this code's reordered reads in the DEM's force loop
#      and the device loop of the pressure solve must leave every bit as it was
#   5. where nsys exists: Mueller's bed for NSYS_STEPS gas steps under `nsys profile`, the GPU time per kernel
#      (cuda_gpu_kern_sum) and per API call (cuda_api_sum), the top lines printed
#
#   scripts/bed_speed_gpu.sh BUILD_DIR
#     BUILD_DIR  a build folder of the `cuda` preset (configured and built here if needed: lbdem, cfd_tests,
#                dem_tests)
#   env  MULLER_STEPS (default 8000: 1.2 s simulated, ~40 s at 32 s per simulated s), LINK_STEPS (default 14000:
#        0.42 s simulated, ~40 s at 95 s per simulated s), PHASE_STEPS (default 2000), NSYS_STEPS (default 600),
#        GPU (default 0), BASE_BUILD (default none: step 4 left out; built here if needed), BASE_STEPS (default 1000);
#        PAIR=tail compares the pressure solve's one-block tail in shared memory (the default) with the tail in global
#        memory (LBDEM_PRESSURE_TAIL_SHARED=0) in steps 1-2 instead of the two pressure loops; PAIR=fused compares
#        two DEM kernels per sub-step (LBDEM_DEM_FUSED_SUBSTEPS=0, the default) with the fused sub-steps (=1) in steps
#        1-2, and step 3 times Mueller's bed both ways; PHASE_STEPS=0 and NSYS_STEPS=0 leave steps 3 and 5 out
# Output under $OUT/bed_speed: speed.jsonl (one JSON line per run: seconds per simulated second, simulated time,
# mean pressure drop over bed weight, per gas step the DEM's rebuilds, report reads and waits; a line per bed
# "match": whether the two paths' final checkpoint, series and profiles are the same bytes), phases.jsonl (ms per
# gas step of the gas step and of the DEM sub-steps), nsys_*.txt, each run's summary.json/series.csv/profiles.csv/
# log (checkpoints and field snapshots are deleted once compared). Prints the JSON lines and the verdicts.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?usage: scripts/bed_speed_gpu.sh BUILD_DIR}"
muller_steps="${MULLER_STEPS:-8000}"
link_steps="${LINK_STEPS:-14000}"
phase_steps="${PHASE_STEPS:-2000}"
nsys_steps="${NSYS_STEPS:-600}"
g="${GPU:-0}"
lbdem_env
out="$OUT/bed_speed"
mkdir -p "$out"
if [ "${TESTS:-1}" = 1 ]; then lbdem_build "$build" lbdem cfd_tests dem_tests || exit 1; else lbdem_build "$build" lbdem || exit 1; fi
build="$(realpath "$build")"
exe="$build/cases/lbdem"
[ "$(gpu_count)" -ge 1 ] || { echo "no GPU"; exit 1; }

# yaml CASE NAME STEPS START: CASE for STEPS gas steps, statistics from START s, snapshots only at the first and
# last step, a checkpoint at the end.
yaml() {
  sed -e "s/^time: {end\(_time\)\?: [0-9.e+-]*}/time: {steps: $3}/" -e "s/^  start: [0-9.e+-]*/  start: $4/" \
    -e "s/^output: {directory: \([^,]*\), interval: [0-9]*/output: {directory: \1, interval: 0/" \
    "$LBDEM_ROOT/cases/$1" > "$out/$2.yaml"
  echo "checkpoint: {interval: 100000000}" >> "$out/$2.yaml"
  echo "$out/$2.yaml"
}
# bed NAME LOOP YAML: one run (LOOP 0: the host-polled pressure loop), its line into speed.jsonl.
bed() {
  local name="$1" loop="$2" y="$3" var=LBDEM_PRESSURE_DEVICE_LOOP
  [ "${PAIR:-loop}" = tail ] && var=LBDEM_PRESSURE_TAIL_SHARED
  [ "${PAIR:-loop}" = fused ] && var=LBDEM_DEM_FUSED_SUBSTEPS
  CUDA_VISIBLE_DEVICES="$g" env "$var=$loop" timeout -s TERM -k 30 240 "$exe" run "$y" \
    --backend cuda --output "$out/$name" --overwrite --quiet > "$out/$name.log" 2>&1
  local rc=$? s="$out/$name/summary.json"
  [ -f "$s" ] || { echo "$name exit $rc, no summary"; tail_log "$out/$name.log" 8; return; }
  get() { grep -o "\"$1\": [^,}]*" "$s" | head -1 | sed 's/^[^:]*: //; s/"//g'; }
  local gs; gs="$(get gas_steps)"
  per() { awk -v a="$1" -v b="$gs" 'BEGIN { printf "%.4g", (b > 0 ? a / b : 0) }'; }
  local which=pressure_device_loop; [ "${PAIR:-loop}" = tail ] && which=pressure_tail_shared
  [ "${PAIR:-loop}" = fused ] && which=dem_fused_substeps
  json_line "$out/speed.jsonl" run="$name" "$which=$loop" exit="$rc" gas_steps="$gs" \
    simulated_s="$(get time_s)" s_per_simulated_s="$(get seconds_per_simulated_second)" \
    particle_steps_per_s="$(get particle_steps_per_second)" dp_over_weight="$(get mean_pressure_drop_over_weight)" \
    statistics_samples="$(get statistics_samples)" dem_substeps="$(get dem_substeps)" \
    dem_rebuilds_per_gas_step="$(per "$(get dem_rebuilds)")" \
    dem_report_reads_per_gas_step="$(per "$(get dem_report_reads)")" \
    dem_report_waits_per_gas_step="$(per "$(get dem_report_waits)")"
  tail -1 "$out/speed.jsonl"
}
# match BED A B: the final checkpoint, series and profiles of runs A and B byte for byte.
match() {
  local f same=true diff=""
  for f in checkpoint.lbdem series.csv profiles.csv; do
    [ -f "$out/$2/$f" ] || continue
    cmp -s "$out/$2/$f" "$out/$3/$f" || { same=false; diff+="$f "; }
  done
  json_line "$out/speed.jsonl" run="$1" match="$2 vs $3" bitwise="$same" differ="${diff:-none}"
  tail -1 "$out/speed.jsonl"
  clean "$2"; clean "$3"
}
# clean RUN: the run's checkpoints and field snapshots go (only small files come back).
clean() { find "$out/$1" -type f \( -name 'checkpoint*' -o -name '*.h5' -o -name '*.xdmf' \) -delete 2> /dev/null; }
# phases NAME YAML [VAR=VALUE...]: the gas step and the DEM sub-steps timed apart (LBDEM_STEP_PHASES=1).
phases() {
  CUDA_VISIBLE_DEVICES="$g" LBDEM_STEP_PHASES=1 env "${@:3}" timeout -s TERM -k 30 120 "$exe" run "$2" --backend cuda \
    --output "$out/$1" --overwrite --quiet > "$out/$1.log" 2>&1
  local rc=$? l
  l="$(grep -a '^step phases:' "$out/$1.log" | tail -1)"
  # "step phases: N steps, fluid A s, particles B s (a and b ms per step)"
  json_line "$out/phases.jsonl" run="$1" exit="$rc" steps="$(echo "$l" | awk '{print $3}')" \
    gas_ms_per_step="$(echo "$l" | sed -n 's/.*(\([0-9.e+-]*\) and.*/\1/p')" \
    dem_ms_per_step="$(echo "$l" | sed -n 's/.* and \([0-9.e+-]*\) ms per step.*/\1/p')"
  tail -1 "$out/phases.jsonl"
  clean "$1"
}

t0=$SECONDS
if [ "${TESTS:-1}" = 1 ]; then
  CUDA_VISIBLE_DEVICES="$g" timeout 300 "$build/tests/cfd/cfd_tests" --gtest_filter='*Pressure.*:PressureLoop.*' \
    > "$out/cfd_tests.log" 2>&1
  echo "cfd_tests (pressure) exit $?"
  CUDA_VISIBLE_DEVICES="$g" timeout 300 "$build/tests/dem/dem_tests" --gtest_filter='DemCrossBackend.*:*SubstepGraphs*:*DemFusedSubsteps*' \
    > "$out/dem_tests.log" 2>&1
  echo "dem_tests (GPU against host, sub-step graphs, fused sub-steps) exit $?"
  grep -a -E "^\[  (PASSED|FAILED) |^\[  FAILED  \]" "$out/cfd_tests.log" "$out/dem_tests.log"
fi
off=polled on=device_loop
[ "${PAIR:-loop}" = tail ] && off=tail_global on=tail_shared
[ "${PAIR:-loop}" = fused ] && off=two_kernels on=fused
ym="$(yaml fluidized_bed_muller_u09.yaml u09 "$muller_steps" 0.3)"
bed u09_$off 0 "$ym"
bed u09_$on 1 "$ym"
match u09 u09_$off u09_$on
yl="$(yaml fluidized_bed_link_spout.yaml link "$link_steps" 0.1)"
bed link_$off 0 "$yl"
bed link_$on 1 "$yl"
match link link_$off link_$on
if [ "$phase_steps" -gt 0 ]; then
  if [ "${PAIR:-loop}" = fused ]; then
    phases u09_phases_two_kernels "$(yaml fluidized_bed_muller_u09.yaml u09_p "$phase_steps" 0.3)" \
      LBDEM_DEM_FUSED_SUBSTEPS=0
    phases u09_phases_fused "$(yaml fluidized_bed_muller_u09.yaml u09_p "$phase_steps" 0.3)" \
      LBDEM_DEM_FUSED_SUBSTEPS=1
  fi
  phases u09_phases "$(yaml fluidized_bed_muller_u09.yaml u09_p "$phase_steps" 0.3)"
  phases link_phases "$(yaml fluidized_bed_link_spout.yaml link_p "$phase_steps" 0.1)"
fi
if [ -n "${BASE_BUILD:-}" ]; then
  lbdem_build "$BASE_BUILD" lbdem || exit 1
  yb="$(yaml fluidized_bed_muller_u09.yaml u09_b "${BASE_STEPS:-1000}" 0.0)"
  for v in base:"$(realpath "$BASE_BUILD")/cases/lbdem" this:"$exe"; do
    CUDA_VISIBLE_DEVICES="$g" timeout -s TERM -k 30 120 "${v#*:}" run "$yb" --backend cuda --output "$out/u09_${v%%:*}" \
      --overwrite --quiet > "$out/u09_${v%%:*}.log" 2>&1
    echo "u09_${v%%:*} exit $?"
  done
  # The checkpoint past its first 4 KB (the header, which names the build, is shorter) and before its 8-byte
  # checksum.
  body() { local n; n=$(stat -c %s "$1"); tail -c +4097 "$1" | head -c $((n - 4104)); }
  same=true diff=""
  cmp -s <(body "$out/u09_base/checkpoint.lbdem") <(body "$out/u09_this/checkpoint.lbdem") || { same=false; diff+="checkpoint "; }
  for f in series.csv profiles.csv; do cmp -s "$out/u09_base/$f" "$out/u09_this/$f" || { same=false; diff+="$f "; }; done
  json_line "$out/speed.jsonl" run=u09_against_base match="base vs this" bitwise="$same" differ="${diff:-none}"
  tail -1 "$out/speed.jsonl"
  clean u09_base; clean u09_this
fi
if [ "$nsys_steps" -gt 0 ] && command -v nsys > /dev/null 2>&1; then
  yn="$(yaml fluidized_bed_muller_u09.yaml u09_n "$nsys_steps" 0.3)"
  CUDA_VISIBLE_DEVICES="$g" timeout -s TERM -k 30 180 nsys profile -t cuda --force-overwrite true \
    -o "$out/u09_nsys" "$exe" run "$yn" --backend cuda --output "$out/u09_nsys_run" --overwrite --quiet \
    > "$out/nsys_run.log" 2>&1
  echo "nsys profile exit $?"
  for r in cuda_gpu_kern_sum cuda_api_sum; do
    timeout 120 nsys stats -r "$r" "$out/u09_nsys.nsys-rep" > "$out/nsys_$r.txt" 2>&1
    echo "== $r (Mueller u09, $nsys_steps gas steps)"; grep -a -v '^\s*$' "$out/nsys_$r.txt" | head -25
  done
  rm -f "$out/u09_nsys.nsys-rep" "$out/u09_nsys.sqlite"
  rm -rf "$out/u09_nsys_run"
else
  echo "nsys not found: no per-kernel times"
fi
echo "all runs done in $((SECONDS - t0)) s"
cat "$out/speed.jsonl" "$out/phases.jsonl"
