#!/usr/bin/env bash
# Runs lbdem on a GPU machine: logs, JSON and a summary go to $OUT (default ./out).
#   scripts/gpu_run.sh [-B DIR] [STEP...]     (default: build test bench)
#     -B DIR                the build folder (default $LBDEM_BUILD, else build-gpu/): the other GPU scripts take
#                           the same, so one build serves them all
#     build                 configure the `cuda` preset (sm_90, Release) into that folder and build everything
#     test                  every test of that build (ctest; both backends run inside the same tests)
#     bench                 the benchmarks of that build; JSON as $OUT/<bench>.json
#     bench-baseline DIR    builds only the benchmark targets of another source tree DIR (e.g. an older
#                           commit from `git archive`; its own `cuda` preset, tests off) in DIR/build-bench and
#                           runs the same benchmarks;
#                           JSON as $OUT/baseline_<bench>.json (commit: $BASELINE_COMMIT, else "baseline")
#     scaling [quick]       fluid-only scaling over MPI ranks (scripts/scaling_gpu.sh): $OUT/scaling.jsonl
#     profile               Nsight Compute per-kernel time and DRAM bytes of 3 coupled suspension steps
#     sanitize              compute-sanitizer over the CUDA tests and every shipped scene
#                           (scripts/gpu_sanitize.sh, which uses build-gpu/ whatever -B says; logs and
#                           summary.txt in $OUT/sanitize; SANITIZE_TOOLS
#                           picks the tools, TESTS / FILTER / SCENES / SCENE_STEPS pass through)
#     pack                  everything in $OUT into $OUT/out.tgz (for a runner that returns few files)
#   BENCHES selects benchmarks (default: lbm dem imb psm-susp psm-sweep); SUSP_FRACTIONS the psm-susp fractions
#   (default: table linear exact). psm-sweep alone needs two
#   device calls of 10 min: SWEEP_PARTS="small", then SWEEP_PARTS="large" (scripts/psm_sweep_gpu.sh).
#   LBDEM_COMMIT names the commit in every JSON (default: git rev-parse here). Set it from the caller when the
#   tree on the GPU machine is a copy whose .git may be stale (it reported an older commit in past runs).
set -uo pipefail
source "$(dirname "$0")/lib.sh"
[ "${1:-}" = -B ] && { LBDEM_BUILD="${2:?-B needs a build folder}"; shift 2; }
lbdem_env
here="$LBDEM_ROOT"
build="$(realpath -m "$LBDEM_BUILD")"
# Test processes use few cores each: 8 processes x 2 OpenMP threads fill 16 cores without spinning (lbdem_env
# sets passive OpenMP waits).

# run_benches BUILD PREFIX: every benchmark in BENCHES from build tree BUILD, JSON as $OUT/PREFIX<name>.json.
# The arguments are those of the numbers in bench/results (bench/results/CURRENT.md).
run_benches() {
  local b="$1/bench" p="$2" psm="$1/bench/imb/lbdem_bench_psm" prec fr pl f
  for x in ${BENCHES:-lbm dem imb psm-susp psm-sweep}; do
    case "$x" in
      lbm) timeout 300 "$b/lbm/lbdem_bench_lbm" --out "$OUT/${p}lbm.json" > "$OUT/${p}lbm.log" 2>&1 ;;
      dem) timeout 300 "$b/dem/lbdem_bench_dem" --host-sizes 100000,1000000 --out "$OUT/${p}dem.json" \
             > "$OUT/${p}dem.log" 2>&1 ;;
      imb) timeout 120 "$b/imb/lbdem_bench_imb" --out "$OUT/${p}imb_solid_fraction.json" \
             > "$OUT/${p}imb_solid_fraction.log" 2>&1 ;;
      psm-susp)
        # One JSON per run, then all of them as psm_suspension.json {"runs": [...]}.
        mkdir -p "$OUT/${p}psm_suspension"
        for prec in fp32 fp64; do for fr in ${SUSP_FRACTIONS:-table linear exact}; do for pl in fused mapped; do
          [ "$fr/$pl" = exact/fused ] && continue  # the fused pipeline has no exact fractions
          timeout 60 "$psm" suspension --n 256 --steps 100 --precision $prec --fraction $fr --pipeline $pl \
            --out "$OUT/${p}psm_suspension/${prec}_${fr}_${pl}.json" >> "$OUT/${p}psm_suspension.log" 2>&1
        done; done; done
        { echo '{"benchmark": "lbdem_bench_psm suspension", "runs": ['; f=""
          for j in "$OUT/${p}psm_suspension"/*.json; do [ -n "$f" ] && echo ','; cat "$j"; f=1; done
          echo ']}'; } > "$OUT/${p}psm_suspension.json"
        grep -A2 '^suspension' "$OUT/${p}psm_suspension.log" ;;
      psm-sweep) bash "$here/scripts/psm_sweep_gpu.sh" "$psm" "$OUT/${p}psm_fixed_sphere_sweep" \
                   ${SWEEP_PARTS:-small large} merge plot > "$OUT/${p}psm_fixed_sphere_sweep.log" 2>&1 ;;
      *) echo "unknown benchmark $x"; return 2 ;;
    esac
    echo "bench $p$x exit $?"
  done
}

[ $# -eq 0 ] && set -- build test bench
while [ $# -gt 0 ]; do
  s="$1"; shift
  case "$s" in
    build) lbdem_build "$build" ;;
    test)
      OMP_NUM_THREADS=2 timeout 540 ctest --test-dir "$build" --output-on-failure -j8 --timeout 300 \
        > "$OUT/ctest.log" 2>&1
      echo "ctest exit $?"; tail -15 "$OUT/ctest.log" ;;
    bench) run_benches "$build" "" ;;
    bench-baseline)
      dir="$(cd "${1:?bench-baseline needs a source tree}" && pwd)"; shift
      LBDEM_SRC="$dir" LBDEM_CMAKE_ARGS="-DLBDEM_BUILD_TESTS=OFF" LBDEM_BUILD_LOG="$OUT/baseline_build.log" \
        lbdem_build "$dir/build-bench" lbdem_bench_lbm lbdem_bench_dem lbdem_bench_imb lbdem_bench_psm
      LBDEM_COMMIT="${BASELINE_COMMIT:-baseline}" run_benches "$dir/build-bench" baseline_ ;;
    scaling)
      q=""; [ "${1:-}" = quick ] && { q=quick; shift; }
      bash "$here/scripts/scaling_gpu.sh" "$build" "$OUT/scaling.jsonl" $q; echo "scaling exit $?" ;;
    profile)
      for prec in fp32 fp64; do
        timeout 240 ncu --clock-control none --metrics gpu__time_duration.sum,dram__bytes.sum --print-summary per-kernel \
          "$build/bench/imb/lbdem_bench_psm" suspension --n 256 --steps 3 --precision $prec --fraction table \
          --pipeline fused > "$OUT/ncu_suspension_$prec.log" 2>&1
        echo "ncu $prec exit $?"
      done ;;
    sanitize)
      OUT="$OUT/sanitize" bash "$here/scripts/gpu_sanitize.sh" ${SANITIZE_TOOLS:-}; echo "sanitize exit $?" ;;
    pack) tar czf /tmp/gpu_run_out.tgz -C "$OUT" . && rm -rf "${OUT:?}"/* && mv /tmp/gpu_run_out.tgz "$OUT/out.tgz" ;;
    *) echo "unknown step $s"; exit 2 ;;
  esac
done
