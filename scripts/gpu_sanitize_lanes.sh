#!/usr/bin/env bash
# All four compute-sanitizer tools over the CUDA tests and the shipped scenes in one device call:
# several scripts/gpu_sanitize.sh runs side by side ("lanes"), each with its own tools, tests and
# gtest filter, started as soon as the executables it needs are built.
#   scripts/gpu_sanitize_lanes.sh [SECONDS] [SET]   SECONDS: wall-time budget of the whole call (default 560)
#     SET  all (default): every tool over every test executable and scene, in one pass
#          rest: a second call for what one call cannot hold: the long initcheck/racecheck runs split into
#          narrower lanes, the scenes that took longest, cfd_tests, the 16-bit storage tests
#          rest2: what `rest` could not finish: initcheck of lbm_tests split by suite, the 16-bit tests
#          under memcheck, dem_tests under memcheck and initcheck, cfd_tests under all four tools, and
#          racecheck of the fixed_disk scene, each lane with a longer limit
#          rest3: the same less what rest2 finished, with the builds staged (lbm_tests, then lbdem, then the
#          dem/cfd/cases tests) so that each lane starts as soon as its executable exists; cfd_tests without
#          the long bed simulations (the fluidized_bed scenes cover those kernels); the Restart tests of
#          cases_tests run as they are (no sanitizer) beside the lanes
#   OUT            logs, per-lane summaries and summary.txt (default ./out/sanitize)
#   LBDEM_COMMIT   the commit named in the summaries
# Every sanitizer run has its own time limit (CS_T seconds); a run cut off by it reports "exit 124,
# no summary" and counts as not covered, not as clean. racecheck checks shared-memory hazards only,
# so its test lanes cover the kernels that use shared memory (the fused PSM kernel, core/algorithms'
# block reductions and scans through the DEM neighbour build and the fluid diagnostics); the scenes
# run every kernel once under it.
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
budget="${1:-560}"
set_="${2:-all}"
OUT="${OUT:-$here/out/sanitize}"
mkdir -p "$OUT"
t0=$(date +%s)
left() { echo $((t0 + budget - $(date +%s))); }
build="$here/build-gpu"
cs_real="${SANITIZER:-/usr/local/cuda/bin/compute-sanitizer}"
wrap="$OUT/cs_wrap.sh"
printf '#!/bin/sh\nexec timeout "${CS_T:-120}" %s "$@"\n' "$cs_real" > "$wrap"
chmod +x "$wrap"
export SANITIZER="$wrap" SCENE_STEPS="${SCENE_STEPS:-5}" OMP_NUM_THREADS=1
S="$here/scripts/gpu_sanitize.sh"
if [ "$set_" = rest3 ]; then
  (cd "$here" && cmake --preset cuda > "$OUT/build.log" 2>&1 &&
    cmake --build build-gpu -j16 --target lbm_tests >> "$OUT/build.log" 2>&1)
  echo "build lbm_tests: exit $? at $(( $(date +%s) - t0 )) s"
else
(cd "$here" && cmake --preset cuda > "$OUT/build.log" 2>&1 &&
  cmake --build build-gpu -j16 --target lbdem lbm_tests >> "$OUT/build.log" 2>&1)
echo "build lbdem lbm_tests: exit $? at $(( $(date +%s) - t0 )) s"
fi
targets2="dem_tests imb_tests cfd_tests"
[ "$set_" = rest2 ] && targets2="dem_tests cfd_tests cases_tests"
if [ "$set_" = rest3 ]; then
  (cd "$here" && cmake --build build-gpu -j16 --target lbdem >> "$OUT/build2.log" 2>&1
   echo "build lbdem: exit $? at $(( $(date +%s) - t0 )) s" >> "$OUT/build2.log"; touch "$OUT/.lbdem_built"
   cmake --build build-gpu -j16 --target dem_tests cfd_tests cases_tests >> "$OUT/build2.log" 2>&1
   echo "build dem_tests cfd_tests cases_tests: exit $? at $(( $(date +%s) - t0 )) s" >> "$OUT/build2.log") &
  builder=$!
else
(cd "$here" && cmake --build build-gpu -j12 --target $targets2 >> "$OUT/build2.log" 2>&1
 echo "build $targets2: exit $? at $(( $(date +%s) - t0 )) s" >> "$OUT/build2.log") &
builder=$!
fi
lane() {  # lane NAME [VAR=VALUE...] -- TOOL...
  local name="$1"; shift
  local env=()
  while [ "$1" != "--" ]; do env+=("$1"); shift; done
  shift
  # Each lane its own TMPDIR: tests write fixed names under the temporary directory.
  mkdir -p "$OUT/$name/tmp"
  env "${env[@]}" TMPDIR="$OUT/$name/tmp" OUT="$OUT/$name" timeout "$(left)" bash "$S" "$@" > "$OUT/$name/lane.log" 2>&1
}
if [ "$set_" = rest3 ]; then
  quick_cfd="All/Gas.*/cuda*:All/VoidFractionTest.*/cuda*"
  lane lbm_init_tg SCENES=0 TESTS=lbm CS_T=540 "FILTER=Backends/TaylorGreen*/cuda*:Backends/Poiseuille*/cuda*" -- initcheck &
  lane lbm_init_fp16 SCENES=0 TESTS=lbm CS_T=540 "FILTER=Lbm/Fp16Storage*/cuda*" -- initcheck &
  lane lbm_fp16 SCENES=0 TESTS=lbm CS_T=540 "FILTER=Lbm/Fp16Storage*/cuda*" -- memcheck &
  while [ ! -f "$OUT/.lbdem_built" ] && kill -0 $builder 2>/dev/null; do sleep 3; done
  tail -1 "$OUT/build2.log"
  lane disk_race SCENES=1 SCENE_GLOB=fixed_disk TESTS=none CS_T=480 -- racecheck &
  lane bed_race_sync SCENES=1 "SCENE_GLOB=fluidized_bed*" TESTS=none CS_T=120 -- racecheck synccheck &
  wait $builder
  tail -1 "$OUT/build2.log"
  lane dem_mem SCENES=0 TESTS=dem CS_T=400 -- memcheck &
  lane dem_init SCENES=0 TESTS=dem CS_T=400 -- initcheck &
  lane cfd_mem SCENES=0 TESTS=cfd CS_T=300 "FILTER=$quick_cfd" -- memcheck &
  lane cfd_init SCENES=0 TESTS=cfd CS_T=300 "FILTER=$quick_cfd" -- initcheck &
  lane cfd_race SCENES=0 TESTS=cfd CS_T=300 "FILTER=$quick_cfd" -- racecheck &
  lane cfd_sync SCENES=0 TESTS=cfd CS_T=300 "FILTER=$quick_cfd" -- synccheck &
  mkdir -p "$OUT/restart/tmp"
  (cd "$OUT/restart" && TMPDIR="$OUT/restart/tmp" timeout "$(left)" "$build/tests/cases/cases_tests" \
     --gtest_filter='Restart.*' > "$OUT/restart/restart.log" 2>&1
   echo "Restart tests (cases_tests, no sanitizer): exit $?" > "$OUT/restart/summary.txt") &
elif [ "$set_" = rest2 ]; then
  lane disk_race SCENES=1 SCENE_GLOB=fixed_disk TESTS=none CS_T=480 -- racecheck &
  lane lbm_init_cons SCENES=0 TESTS=lbm CS_T=480 "FILTER=Backends/Conservation*/cuda*" -- initcheck &
  lane lbm_init_tg SCENES=0 TESTS=lbm CS_T=480 "FILTER=Backends/TaylorGreen*/cuda*:Backends/Poiseuille*/cuda*" -- initcheck &
  lane lbm_init_scenes SCENES=0 TESTS=lbm CS_T=480 "FILTER=Scenes/StreamingEquivalence*/cuda*:All/LbmState*/cuda*:CpuGpu*" -- initcheck &
  lane lbm_init_fp16 SCENES=0 TESTS=lbm CS_T=480 "FILTER=Lbm/Fp16Storage*/cuda*" -- initcheck &
  lane lbm_fp16 SCENES=0 TESTS=lbm CS_T=480 "FILTER=Lbm/Fp16Storage*/cuda*" -- memcheck &
  wait $builder
  tail -1 "$OUT/build2.log"
  lane dem_mem SCENES=0 TESTS=dem CS_T=400 -- memcheck &
  lane dem_init SCENES=0 TESTS=dem CS_T=400 -- initcheck &
  lane cfd_mem SCENES=0 TESTS=cfd CS_T=400 -- memcheck &
  lane cfd_init SCENES=0 TESTS=cfd CS_T=400 -- initcheck &
  lane cfd_race_sync SCENES=0 TESTS=cfd CS_T=200 -- racecheck synccheck &
elif [ "$set_" = rest ]; then
  lane sc_sphere SCENES=1 "SCENE_GLOB=*sphere*" TESTS=none CS_T=150 -- initcheck memcheck &
  lane sc_disk SCENES=1 SCENE_GLOB=fixed_disk TESTS=none CS_T=200 -- initcheck &
  lane sc_susp SCENES=1 SCENE_GLOB=suspension TESTS=none CS_T=200 -- initcheck &
  lane sc_bed SCENES=1 "SCENE_GLOB=fluidized_bed*" TESTS=none CS_T=100 -- memcheck initcheck &
  lane lbm_init SCENES=0 TESTS=lbm CS_T=400 "FILTER=*/cuda*:-*FluidHaloExchange*:*GhostLayers*:*Sweep*" -- initcheck &
  lane lbm_fp16 SCENES=0 TESTS=lbm CS_T=300 "FILTER=*Fp16*/cuda*:*fp16*cuda*" -- memcheck &
  wait $builder
  tail -1 "$OUT/build2.log"
  lane imb_init SCENES=0 TESTS=imb CS_T=400 -- initcheck &
  lane dem_mem SCENES=0 TESTS=dem CS_T=300 -- memcheck &
  lane dem_init SCENES=0 TESTS=dem CS_T=300 -- initcheck &
  lane dem_race SCENES=0 TESTS=dem CS_T=300 "FILTER=*DemNeighbours*/cuda*" -- racecheck &
  lane cfd_all SCENES=0 TESTS=cfd CS_T=120 -- memcheck racecheck initcheck synccheck &
else
# Lanes on the fluid: they need only lbdem and lbm_tests.
lane scenes_init SCENES=1 TESTS=none CS_T=60 -- initcheck &
lane lbm_init SCENES=0 TESTS=lbm CS_T=300 -- initcheck &
lane lbm_race SCENES=0 TESTS=lbm CS_T=240 "FILTER=*Conservation.PeriodicBoxD2Q9/cuda*:*StreamingEquivalence*/cuda*" -- racecheck &
wait $builder
cat "$OUT/build2.log" | tail -1
lane imb_dem_mem SCENES=0 "TESTS=imb dem" CS_T=200 -- memcheck &
lane imb_dem_init SCENES=0 "TESTS=imb dem" CS_T=200 -- initcheck &
lane imb_race SCENES=0 TESTS=imb CS_T=240 "FILTER=*PsmFused*/cuda*:*PsmParts*:*CellSlots*/cuda*:*PsmPipeline*/cuda*" -- racecheck &
lane dem_race SCENES=0 TESTS=dem CS_T=200 -- racecheck &
lane imb_dem_sync SCENES=0 "TESTS=imb dem" CS_T=200 -- synccheck &
lane disk_race SCENES=1 SCENE_GLOB=fixed_disk TESTS=none CS_T=200 -- racecheck &
fi
wait
{ echo "# compute-sanitizer lanes, $(( $(date +%s) - t0 )) s"; cat "$OUT"/*/summary.txt 2>/dev/null; } > "$OUT/summary.txt"
grep -hE "^(memcheck|racecheck|initcheck|synccheck)" "$OUT/summary.txt" | sort
rm -rf "$OUT"/*/tmp
