#!/usr/bin/env bash
# One call on the GPU machine: build with CUDA for sm_90, run the whole test
# suite (host and CUDA backends), run the benchmarks; logs and JSON go to $OUT.
#   scripts/gpu_run.sh [build] [test] [bench-lbm] [bench-dem] [bench-imb] [bench-psm] [bench-susp]
#                      [build-psm] [test-imb] [profile-susp] [profile-psm-kernel] [profile-fused] [profile-map] [scan] [lambda]
#                      [variants] [variants-f32] (FUSED_VARIANTS, VARIANT_CASES: see the steps)
#                      (quicker partial calls)
#   (default: all)
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
OUT="${OUT:-$here/out}"
mkdir -p "$OUT"
build="$here/build-gpu"
steps=("$@")
[ ${#steps[@]} -eq 0 ] && steps=(build test bench-lbm bench-dem bench-imb bench-psm bench-susp)
commit="${LBDEM_COMMIT:-$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)}"
echo "commit $commit" | tee "$OUT/env.txt"
nvidia-smi --query-gpu=name,memory.total,clocks.sm,clocks.mem --format=csv >> "$OUT/env.txt" 2>&1
nproc >> "$OUT/env.txt"
# Steps variants / variants-f32: the fused GPU tests of variant $1 (not for diag*: those drop work on purpose,
# nor with VARIANT_TESTS=0), and its suspension runs for VARIANT_CASES (default $2).
variant_tests() {
  case "$1:${VARIANT_TESTS:-1}" in diag*|*:0) return ;; esac
  (cd "$build" && OMP_NUM_THREADS=8 timeout 200 ./tests/imb/imb_tests --gtest_brief=1 \
    --gtest_filter='*PsmFused*:*PsmCrossBackend*:*Reordered*:*PsmGalilean*:*PsmHard*/cuda:*FloatLookups*' > "$vd/test_$1.log" 2>&1)
  echo "variant $1 tests exit $?: $(tail -1 "$vd/test_$1.log")"
}
variant_cases() {
  local c prec fr
  for c in ${VARIANT_CASES:-$2}; do
    prec="${c%/*}"; fr="${c#*/}"
    timeout 60 "$build/bench/imb/lbdem_bench_psm" suspension --n 256 --steps 100 --precision $prec --fraction $fr \
      --pipeline fused --out "$vd/susp_${1}_${prec}_${fr}.json" > "$vd/susp_${1}_${prec}_${fr}.log" 2>&1
    echo "variant $1 $prec $fr: $(grep -E 'fluid-only' "$vd/susp_${1}_${prec}_${fr}.log" | sed 's/^ *//')"
  done
}
for s in "${steps[@]}"; do
  case "$s" in
    build)
      cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLBDEM_ENABLE_CUDA=ON \
        -DCMAKE_CUDA_ARCHITECTURES=90 > "$OUT/build.log" 2>&1 &&
      cmake --build "$build" -j"$(nproc)" -- -k 0 >> "$OUT/build.log" 2>&1
      echo "build exit $?"; tail -3 "$OUT/build.log" ;;
    build-psm)
      # Only what the PSM benches and the imb/dem tests need (a quicker call).
      cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLBDEM_ENABLE_CUDA=ON \
        -DCMAKE_CUDA_ARCHITECTURES=90 > "$OUT/build.log" 2>&1 &&
      cmake --build "$build" -j"$(nproc)" --target lbdem_bench_psm imb_tests dem_tests -- -k 0 >> "$OUT/build.log" 2>&1
      echo "build-psm exit $?"; grep -E "error|FAILED" "$OUT/build.log" | head -20 ;;
    test-imb)
      (cd "$build" && OMP_NUM_THREADS=2 OMP_WAIT_POLICY=passive timeout 400 ctest --output-on-failure -j8 --timeout 300 \
        -L "imb|dem" > "$OUT/ctest_imb.log" 2>&1)
      echo "ctest-imb exit $?"; tail -15 "$OUT/ctest_imb.log" ;;
    profile-susp)
      # Per-kernel GPU time of a few coupled steps (Nsight Compute, clocks left alone).
      b="$build/bench/imb/lbdem_bench_psm"
      for prec in fp32 fp64; do
        timeout 240 ncu --clock-control none --metrics gpu__time_duration.sum,dram__bytes.sum \
          --print-summary per-kernel "$b" suspension --n 256 --steps 3 --precision $prec --fraction table \
          --pipeline ${PROFILE_PIPELINE:-fused} > "$OUT/ncu_susp_$prec.log" 2>&1
        echo "ncu $prec exit $?"
      done ;;
    profile-fused)
      # The fused PSM kernel (fp32 suspension, table fractions): occupancy, stalls, memory.
      b="$build/bench/imb/lbdem_bench_psm"
      timeout 240 ncu --clock-control none -k regex:psm_fused_kernel -c 2 --section Occupancy --section WarpStateStats \
        --section MemoryWorkloadAnalysis --section LaunchStats --section SpeedOfLight \
        "$b" suspension --n 256 --steps 3 --precision fp32 --fraction table --pipeline fused > "$OUT/ncu_fused_kernel.log" 2>&1
      echo "ncu-fused exit $?"; grep -E "Duration|Registers|Achieved Occupancy|Theoretical Occupancy|DRAM Throughput|Compute \(SM\)|Shared Memory Configuration Size|Dynamic Shared|Static Shared" "$OUT/ncu_fused_kernel.log" | head -30 ;;
    profile-psm-kernel)
      # Occupancy, warp stalls and memory of the PSM stream-collide kernel (fp32, table fractions).
      b="$build/bench/imb/lbdem_bench_psm"
      timeout 240 ncu --clock-control none -k regex:for_each_bounded_kernel -c 2 --section Occupancy --section WarpStateStats \
        --section MemoryWorkloadAnalysis --section LaunchStats --section SpeedOfLight \
        "$b" suspension --n 256 --steps 3 --precision fp32 --fraction table > "$OUT/ncu_psm_kernel.log" 2>&1
      echo "ncu-kernel exit $?" ;;
    profile-map)
      # The particle -> cell map kernel (fp32 suspension, table fractions): where its time goes.
      b="$build/bench/imb/lbdem_bench_psm"
      timeout 240 ncu --clock-control none --kernel-name-base demangled -k regex:MapKernel -c 2 --section Occupancy --section WarpStateStats \
        --section MemoryWorkloadAnalysis --section LaunchStats --section SpeedOfLight --section SourceCounters \
        "$b" suspension --n 256 --steps 3 --precision fp32 --fraction table > "$OUT/ncu_map_kernel.log" 2>&1
      echo "ncu-map exit $?" ;;
    scan|lambda)
      # Drag scans of the solid operator and Lambda/tau (scripts/psm_sweep_gpu.sh scan | lambda).
      mkdir -p "$OUT/$s"
      bash "$here/scripts/psm_sweep_gpu.sh" "$build/bench/imb/lbdem_bench_psm" "$OUT/$s" "$s" > "$OUT/$s.log" 2>&1
      echo "$s exit $?"; cat "$OUT/$s.log" ;;
    test)
      # Tiny test grids: 8 test processes x 2 OpenMP threads fill 16 cores;
      # 16 threads each would oversubscribe and spin (seen: 240 s for a 1 s test).
      (cd "$build" && OMP_NUM_THREADS=2 OMP_WAIT_POLICY=passive timeout 420 ctest --output-on-failure -j8 --timeout 300 > "$OUT/ctest.log" 2>&1)
      echo "ctest exit $?"; tail -15 "$OUT/ctest.log" ;;
    bench-lbm)
      "$build/bench/lbm/lbdem_bench_lbm" --out "$OUT/bench_lbm.json" > "$OUT/bench_lbm.log" 2>&1
      echo "bench-lbm exit $?"; tail -40 "$OUT/bench_lbm.log" ;;
    bench-dem)
      [ -x "$build/bench/dem/lbdem_bench_dem" ] &&
      timeout 300 "$build/bench/dem/lbdem_bench_dem" --out "$OUT/bench_dem.json" --host-sizes 100000,1000000 > "$OUT/bench_dem.log" 2>&1
      echo "bench-dem exit $?"; tail -30 "$OUT/bench_dem.log" ;;
    bench-imb)
      [ -x "$build/bench/imb/lbdem_bench_imb" ] &&
      timeout 120 "$build/bench/imb/lbdem_bench_imb" --out "$OUT/bench_imb.json" > "$OUT/bench_imb.log" 2>&1
      echo "bench-imb exit $?"; tail -20 "$OUT/bench_imb.log" ;;
    bench-psm)
      # Fixed-sphere drag sweep (first paper Table 1): the accurate line at every d/l,
      # the method x precision x collision grid up to d/l = 20.
      b="$build/bench/imb/lbdem_bench_psm"
      [ -x "$b" ] && {
        timeout 280 "$b" sweep --d 4,6,8,10,16,20 --tau 0.52 --magic 1e-3 --methods exact,table,linear \
          --precisions fp64,fp32 --collisions trt,bgk --out "$OUT/psm_sweep_small.json" > "$OUT/psm_sweep_small.log" 2>&1
        echo "sweep-small exit $?"
        timeout 280 "$b" sweep --d 30,50 --tau 0.52 --magic 1e-3 --methods exact --precisions fp64 \
          --collisions trt --out "$OUT/psm_sweep_large.json" > "$OUT/psm_sweep_large.log" 2>&1
        echo "sweep-large exit $?"; }
      tail -5 "$OUT/psm_sweep_small.log" "$OUT/psm_sweep_large.log" ;;
    bench-susp)
      b="$build/bench/imb/lbdem_bench_psm"
      # Pipelines: fused (table/linear) and mapped (any method); exact runs mapped only.
      [ -x "$b" ] && for prec in fp32 fp64; do for fr in ${SUSP_FRACTIONS:-table linear exact}; do
        for pl in ${SUSP_PIPELINES:-fused mapped}; do
          [ "$fr" = exact ] && [ "$pl" = fused ] && continue
          timeout 60 "$b" suspension --n 256 --steps 100 --precision $prec --fraction $fr --pipeline $pl \
            --out "$OUT/psm_susp_${prec}_${fr}_${pl}.json" >> "$OUT/psm_susp.log" 2>&1; echo "susp $prec $fr $pl exit $?"
        done; done; done
      cat "$OUT/psm_susp.log" | grep -v "^\[" ;;
    variants)
      # Build-time variants of the fused kernel (imb/CMakeLists.txt LBDEM_FUSED_DEFS), one after another
      # in the same build tree (only the fused translation units recompile):
      #   FUSED_VARIANTS="name:DEF=1,DEF2=2 name2:..." (an empty list after ':' is the default kernel).
      # Each: the fused GPU tests (not for names starting with diag: those drop work for attribution),
      # then the suspension benchmark for VARIANT_CASES ("prec/fraction ..."). JSONs in $OUT/variants.tgz.
      vd="$OUT/variants"; mkdir -p "$vd"
      for v in ${FUSED_VARIANTS:-base:}; do
        name="${v%%:*}"; defs="${v#*:}"; defs="${defs//,/;}"
        cmake -S "$here" -B "$build" -DLBDEM_FUSED_DEFS="$defs" >> "$vd/build_$name.log" 2>&1 &&
        cmake --build "$build" -j"$(nproc)" --target lbdem_bench_psm imb_tests -- -k 0 >> "$vd/build_$name.log" 2>&1
        echo "variant $name [$defs] build exit $?"; grep -E "error|spill" "$vd/build_$name.log" | head -5
        variant_tests "$name"
        variant_cases "$name" "fp32/table fp32/linear fp64/table fp64/linear"
      done
      cmake -S "$here" -B "$build" -DLBDEM_FUSED_DEFS="" > /dev/null 2>&1
      (cd "$OUT" && tar czf variants.tgz variants && rm -rf variants) ;;
    variants-f32)
      # As variants, but only the fp32 D3Q19 fused translation unit changes, and the variants' objects
      # compile in parallel first (nvcc with the build's own command plus -D...); each is then swapped
      # into the build tree and linked. fp32 cases only (VARIANT_CASES, default fp32/table fp32/linear).
      # On a fresh machine the build of the default tree runs beside the variants' compiles.
      vd="$OUT/variants"; mkdir -p "$vd"
      cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLBDEM_ENABLE_CUDA=ON \
        -DCMAKE_CUDA_ARCHITECTURES=90 -DLBDEM_FUSED_DEFS="" > "$vd/configure.log" 2>&1 || { echo "configure failed"; tail "$vd/configure.log"; }
      obj=$(cd "$build" && ninja -t targets all | grep -o '^[^:]*psm_fused_d3q19_f32.cu.o' | head -1)
      cmd=$(cd "$build" && ninja -t commands "$obj" | tail -1)
      tg="lbdem_bench_psm"; [ "${VARIANT_TESTS:-1}" = 1 ] && tg="$tg imb_tests"
      (cd "$build" && ninja -j8 $tg > "$vd/build_default.log" 2>&1; echo "default build exit $?") &
      for v in ${FUSED_VARIANTS:-base:}; do
        name="${v%%:*}"; defs="${v#*:}"; dflags=""
        IFS=',' read -ra dl <<< "$defs"; for d in "${dl[@]}"; do [ -n "$d" ] && dflags="$dflags -D$d"; done
        vcmd="$cmd "; vcmd="${vcmd/ -o $obj / -o $vd/$name.o $dflags }"
        (cd "$build" && eval "$vcmd" > "$vd/nvcc_$name.log" 2>&1; echo "nvcc $name exit $?") &
      done
      wait
      cp "$build/$obj" "$vd/default.o"
      for v in ${FUSED_VARIANTS:-base:}; do
        name="${v%%:*}"
        [ -f "$vd/$name.o" ] || { echo "variant $name: no object"; continue; }
        # Archive and link with the build's own commands (ninja would recompile the swapped object).
        cp "$vd/$name.o" "$build/$obj"
        (cd "$build" && for t in $tg; do ninja -t commands "$t" | grep -E "liblbdem_imb.a|-o [^ ]*/$t( |$)" |
           while read -r line; do eval "$line" || exit 1; done; done > "$vd/link_$name.log" 2>&1)
        echo "variant $name link exit $?"
        variant_tests "$name"
        variant_cases "$name" "fp32/table fp32/linear"
      done
      rm -f "$vd"/*.o "$build/$obj"  # ninja rebuilds the default object next time
      (cd "$OUT" && tar czf variants.tgz variants && rm -rf variants) ;;
    *) echo "unknown step $s"; exit 2 ;;
  esac
done
