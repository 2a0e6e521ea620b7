#!/usr/bin/env bash
# The DEM sub-step graphs (DemParams::substep_graphs, cfd/NOTES.md "Launches and host synchronisations") on 4 GPUs
# of one host, side by side, one GPU per lane (~4-5 min after the build; fewer GPUs: the lanes run one after another
# on GPU 0):
#   GPU 0  speed of Mueller's bed, STEPS gas steps each: u09 with the graphs off (LBDEM_DEM_GRAPHS=0, the step as
#          before), on, on with a skin of 0.2 d and 0.3 d (dem.skin 2.4e-4 / 3.6e-4 m, the shipped 0.1 d: fewer
#          rebuilds, longer report intervals, longer graph runs, longer neighbour lists), off with 0.3 d; u06 off
#          and on
#   GPU 1  speed of Link's spout-fluid bed, LINK_STEPS gas steps, graphs off and on; then the restart check on
#          the GPU: Mueller u09 RESTART_STEPS gas steps straight (A), half then `--restart` (B), and straight with the
#          graphs off (C); the final checkpoints, series and profiles of A and B, and of A and C, compared byte for
#          byte (B: a chained run ends where a straight one does; C: the graphs change no bit of the scene)
#   GPU 2  DemSubstepGraphs.* on the GPU (graphs against kernel-by-kernel launches, bitwise, with and without
#          friction), then the quick CUDA instances of the dem, cfd and imb suites under ctest (the resolved
#          mode's DEM runs through the same graphs; at most 5 min)
#   GPU 3  lbdem_bench_cfd (10^6 particles, Sec. 5.2): multigrid + graphs on the GPU and on HOST_THREADS host cores
#          (default 16), then the GPU alone with the graphs off and with the Jacobi CG of the earlier figures
#
#   scripts/cfd_graphs_gpu.sh BUILD_DIR [STEPS]
#     BUILD_DIR  a build folder of the `cuda` preset (configured and built here if needed: lbdem,
#                lbdem_bench_cfd, dem_tests, cfd_tests, imb_tests)
#     STEPS      gas steps per Mueller speed run (default 4000: 0.6 s simulated, the last 0.4 s bubbling; ~20 s each
#                at 33 s per simulated s)
#   env  LINK_STEPS (default 5000: 0.15 s simulated), RESTART_STEPS (default 400), HOST_THREADS (default 16);
#        LANES (default "0 1 2 3"), LANE_GPU_n (lane n's GPU), PARALLEL=1 (the lanes side by side on fewer GPUs)
# Output under $OUT/graphs: speed.jsonl (one JSON line per bed run: seconds per simulated second, particle-steps
# /s, per gas step the DEM's sub-steps, rebuilds, report reads and waits), restart.txt (the comparisons: "same" or
# "DIFFER" per file), dem_tests.log, suite.log, bench_*.{json,md,log}, each run's summary.json/series.csv/log.
# Prints one line per bed run, the restart verdicts, the test summary and the benchmark tables.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?usage: scripts/cfd_graphs_gpu.sh BUILD_DIR [STEPS]}"
steps="${2:-4000}"
link_steps="${LINK_STEPS:-5000}"
restart_steps="${RESTART_STEPS:-400}"
host_threads="${HOST_THREADS:-16}"
lbdem_env
out="$OUT/graphs"
mkdir -p "$out"
lbdem_build "$build" lbdem lbdem_bench_cfd dem_tests cfd_tests imb_tests || exit 1
build="$(realpath "$build")"
exe="$build/cases/lbdem"
ngpu="$(gpu_count)"
[ "$ngpu" -ge 1 ] || { echo "no GPU"; exit 1; }
# Lane n runs on GPU $LANE_GPU_n if set, else on GPU n (4 GPUs) or GPU 0.
gpu() { local v="LANE_GPU_$1"; if [ -n "${!v:-}" ]; then echo "${!v}"; elif [ "$ngpu" -ge 4 ]; then echo "$1"; else echo 0; fi; }
lanes="${LANES:-0 1 2 3}"

# yaml CASE NAME STEPS [SED...]: CASE for STEPS gas steps, snapshots only at the first and last step, a
# checkpoint at the end; further sed expressions change more.
yaml() {
  local case="$1" name="$2" n="$3"; shift 3
  sed -e "s/^time: {end: [0-9.e+-]*}/time: {steps: $n}/" \
    -e "s/^output: {directory: \([^,]*\), interval: [0-9]*/output: {directory: \1, interval: 0/" "$@" \
    "$LBDEM_ROOT/cases/$case" > "$out/$name.yaml"
  echo "checkpoint: {interval: 100000000}" >> "$out/$name.yaml"
  echo "$out/$name.yaml"
}
# bed NAME GPU GRAPHS YAML [ARGS...]: one run (graphs 0: off), its speed line into speed.jsonl.
bed() {
  local name="$1" g="$2" graphs="$3" y="$4"; shift 4
  CUDA_VISIBLE_DEVICES="$g" LBDEM_DEM_GRAPHS="$graphs" timeout -s TERM -k 30 300 "$exe" run "$y" --backend cuda \
    --output "$out/$name" --overwrite "$@" > "$out/$name.log" 2>&1
  local rc=$? s="$out/$name/summary.json"
  [ -f "$s" ] || { echo "$name exit $rc, no summary"; tail_log "$out/$name.log" 8; return; }
  get() { grep -o "\"$1\": [^,}]*" "$s" | head -1 | sed 's/^[^:]*: //; s/"//g'; }
  local gs; gs="$(get gas_steps)"
  per() { awk -v a="$1" -v b="$gs" 'BEGIN { printf "%.4g", (b > 0 ? a / b : 0) }'; }
  json_line "$out/speed.jsonl" run="$name" graphs="$graphs" exit="$rc" gas_steps="$gs" simulated_s="$(get time_s)" \
    s_per_simulated_s="$(get seconds_per_simulated_second)" particle_steps_per_s="$(get particle_steps_per_second)" \
    dem_substeps="$(get dem_substeps)" dem_rebuilds_per_gas_step="$(per "$(get dem_rebuilds)")" \
    dem_report_reads_per_gas_step="$(per "$(get dem_report_reads)")" \
    dem_report_waits_per_gas_step="$(per "$(get dem_report_waits)")" dp_over_weight="$(get mean_pressure_drop_over_weight)"
  tail -1 "$out/speed.jsonl"
}
same() {  # same A B FILE: byte comparison of one file of two runs
  if cmp -s "$out/$1/$3" "$out/$2/$3"; then echo "$1 vs $2 $3: same"; else echo "$1 vs $2 $3: DIFFER"; fi
}

t0=$SECONDS
lane0() {
  local g; g="$(gpu 0)"
  bed u09_graphs_off "$g" 0 "$(yaml fluidized_bed_muller_u09.yaml u09 "$steps")"
  bed u09_graphs_on "$g" 1 "$out/u09.yaml"
  bed u09_graphs_on_skin02d "$g" 1 "$(yaml fluidized_bed_muller_u09.yaml u09_skin02d "$steps" \
    -e 's/^dem: {steps_per_collision: 50}/dem: {steps_per_collision: 50, skin: 2.4e-4}/')"
  bed u09_graphs_on_skin03d "$g" 1 "$(yaml fluidized_bed_muller_u09.yaml u09_skin03d "$steps" \
    -e 's/^dem: {steps_per_collision: 50}/dem: {steps_per_collision: 50, skin: 3.6e-4}/')"
  bed u09_graphs_off_skin03d "$g" 0 "$out/u09_skin03d.yaml"
  bed u06_graphs_off "$g" 0 "$(yaml fluidized_bed_muller_u06.yaml u06 "$steps")"
  bed u06_graphs_on "$g" 1 "$out/u06.yaml"
}
lane1() {
  local g; g="$(gpu 1)"
  bed link_graphs_off "$g" 0 "$(yaml fluidized_bed_link_spout.yaml link "$link_steps")"
  bed link_graphs_on "$g" 1 "$out/link.yaml"
  local y h=$((restart_steps / 2))
  y="$(yaml fluidized_bed_muller_u09.yaml restart "$restart_steps" \
    -e 's/^  start: 5.0/  start: 0.0/')"
  {
    CUDA_VISIBLE_DEVICES="$g" "$exe" run "$y" --backend cuda --quiet --overwrite --output "$out/restart_A" \
      > "$out/restart_A.log" 2>&1; echo "A (straight, $restart_steps steps) exit $?"
    CUDA_VISIBLE_DEVICES="$g" "$exe" run "$y" --backend cuda --quiet --overwrite --output "$out/restart_B" \
      --steps "$h" > "$out/restart_B1.log" 2>&1; echo "B1 (to step $h) exit $?"
    CUDA_VISIBLE_DEVICES="$g" "$exe" run "$y" --backend cuda --quiet --restart "$out/restart_B" \
      > "$out/restart_B2.log" 2>&1; echo "B2 (restart to $restart_steps) exit $?"
    CUDA_VISIBLE_DEVICES="$g" LBDEM_DEM_GRAPHS=0 "$exe" run "$y" --backend cuda --quiet --overwrite \
      --output "$out/restart_C" > "$out/restart_C.log" 2>&1; echo "C (straight, graphs off) exit $?"
    for f in checkpoint.lbdem series.csv profiles.csv; do
      same restart_A restart_B "$f"
      same restart_A restart_C "$f"
    done
  } > "$out/restart.txt" 2>&1
}
lane2() {
  CUDA_VISIBLE_DEVICES="$(gpu 2)" timeout 180 "$build/tests/dem/dem_tests" --gtest_filter='*SubstepGraphs*' \
    > "$out/dem_tests.log" 2>&1
  echo "dem_tests (DemSubstepGraphs) exit $?" >> "$out/dem_tests.log"
  # The CUDA instances of the DEM, CFD and resolved suites, long ones left out (the resolved mode's DEM runs
  # through the same graphs).
  CUDA_VISIBLE_DEVICES="$(gpu 2)" timeout 300 ctest --test-dir "$build" -L 'dem|cfd|imb' -LE long -R 'cuda|Cuda' \
    --timeout 120 > "$out/suite.log" 2>&1
  echo "ctest (dem|cfd|imb CUDA instances, quick) exit $?" >> "$out/suite.log"
}
lane3() {
  local g; g="$(gpu 3)"
  CUDA_VISIBLE_DEVICES="$g" timeout 420 "$build/bench/cfd/lbdem_bench_cfd" --out "$out" --steps 20 --host-steps 3 \
    --host-threads "$host_threads" > "$out/bench_graphs_on.log" 2>&1
  echo "bench (multigrid, graphs on, cuda + $host_threads host cores) exit $?" >> "$out/bench_graphs_on.log"
  mv "$out/bench_cfd.json" "$out/bench_graphs_on.json"; mv "$out/bench_cfd.md" "$out/bench_graphs_on.md"
  for v in "graphs_off --dem-graphs 0" "cg --pressure-solver cg"; do
    set -- $v
    local tag="$1"; shift
    CUDA_VISIBLE_DEVICES="$g" timeout 200 "$build/bench/cfd/lbdem_bench_cfd" --out "$out" --steps 20 --backends cuda \
      "$@" > "$out/bench_$tag.log" 2>&1
    echo "bench ($tag) exit $?" >> "$out/bench_$tag.log"
    mv "$out/bench_cfd.json" "$out/bench_$tag.json"; mv "$out/bench_cfd.md" "$out/bench_$tag.md"
  done
}
if [ "$ngpu" -ge 4 ] || [ -n "${PARALLEL:-}" ]; then
  for l in $lanes; do "lane$l" & done
  wait
else
  for l in $lanes; do "lane$l"; done
fi
echo "all lanes done in $((SECONDS - t0)) s"
cat "$out/restart.txt"
grep -E "PASSED|FAILED|OK \]|exit" "$out/dem_tests.log" | tail -8
grep -E "tests passed|Failed|exit" "$out/suite.log" | tail -12
cat "$out/speed.jsonl"
for f in graphs_on graphs_off cg; do cat "$out/bench_$f.md" 2>/dev/null || tail_log "$out/bench_$f.log" 8; done
