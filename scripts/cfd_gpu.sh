#!/usr/bin/env bash
# The unresolved CFD-DEM mode on a GPU machine: build, CUDA tests, the validation beds, the benchmark.
# Each PART fits one device call of <= 9 min; logs, JSON, CSV and snapshots go to $OUT/cfd (default ./out/cfd).
#
#   scripts/cfd_gpu.sh PART...
#     build     configure the `cuda` preset (build-gpu/, sm_90, Release) and build lbdem, lbdem_bench_cfd
#               and cfd_tests only
#     test      cfd_tests on both backends (host and CUDA instances; the CUDA ones have not run before),
#               the long fluidized-bed cases included
#     muller06  Mueller's bubbling bed at U = 0.6 m/s (cases/fluidized_bed_muller_u06.yaml), 15 s simulated,
#               averages from 5 s (the paper's last 10 s); stopped cleanly (SIGTERM, final output and
#               profiles written) at CFD_LIMIT seconds if not done: summary.json says how far it got and the
#               time per simulated s. The case files use the multigrid-preconditioned pressure solve
#               (gas.pressure_solver.type: multigrid; ~10x fewer launches per gas step than the Jacobi CG)
#     muller09  the same at U = 0.9 m/s
#     link      Link's spout-fluid bed (cases/fluidized_bed_link_spout.yaml), 20 s simulated, averages from
#               5 s (the paper's last 15 s); the same clean stop
#     speed     the pressure solvers compared on the GPU: 1000 gas steps of Mueller's bed (U = 0.6 m/s) and
#               of Link's spout with gas.pressure_solver.type cg and multigrid (~1 min in all): seconds per
#               gas step, mean iterations per solve, the ratio and the projected time of the planned runs
#               (MULLER_END, LINK_END), into speed.md: run it before muller06 / link
#     bench     lbdem_bench_cfd: the Sec. 5.2 system (1e6 particles, 300,000 cells, U = 0.9 m/s) on the GPU
#               and on all host cores: bench_cfd.{json,md}
#     plot      scripts/plot_cfd.py on what is there (needs python3-matplotlib; else it prints tables)
#   env  CFD_LIMIT (s of wall time per scene, default 510), MULLER_END / LINK_END (simulated s, default 15 / 20),
#        MULLER_START / LINK_START (s from which averages are taken, default 5 / 5), SOLVER (cg or multigrid:
#        overrides the case's gas.pressure_solver.type, e.g. to compare), GRAPHS (false: the multigrid's kernels
#        launched one by one, without CUDA graphs and the one-block coarse levels), GAS_DT (overrides the case's
#        gas.dt, e.g. after a watchdog stop: summary.json's "diverged" says why), BENCH_ARGS (extra arguments
#        of lbdem_bench_cfd), LBDEM_COMMIT (the commit named in the JSON when .git is stale), RESUME (1: a
#        scene goes on from the checkpoint its previous call wrote at the time limit, instead of starting over:
#        `RESUME=1 scripts/cfd_gpu.sh link` in successive calls runs Link's 20 s).
# Typical: call 1 `build test` (or `build` then `test`), call 2 `speed` (then choose the ends), call 3
# `muller06`, call 4 `muller09`, call 5 `link`, call 6 `bench plot`.
set -uo pipefail
if [ $# -eq 0 ]; then sed -n 2,34p "$0"; exit 2; fi
here="$(cd "$(dirname "$0")/.." && pwd)"
export OUT="${OUT:-$here/out}"
out="$OUT/cfd"
mkdir -p "$out"
build="$here/build-gpu"
lbdem="$build/cases/lbdem"
limit="${CFD_LIMIT:-510}"
export LBDEM_COMMIT="${LBDEM_COMMIT:-$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)}"
export OMP_WAIT_POLICY=passive
{ echo "commit $LBDEM_COMMIT"; nvidia-smi --query-gpu=name,memory.total --format=csv 2>&1; nproc; } > "$out/env.txt"

# scene NAME CASE END START: runs CASE with time.end END and statistics.start START (a copy of the
# case file with those values) into $out/NAME, under a SIGTERM at $limit s (the scene stops at the end
# of its current step and writes its final output, exit code 5).
scene() {
  local name="$1" case="$2" end="$3" start="$4" tmp rc graphs_expr="s/^//"
  [ -n "${GRAPHS:-}" ] && graphs_expr="s/^  pressure_solver: {\(.*\)}\$/  pressure_solver: {\1, graphs: $GRAPHS}/"
  tmp="$out/$name.yaml"
  sed -e "s/^time: {end: [0-9.e+-]*}/time: {end: $end}/" -e "s/^  start: [0-9.e+-]*$/  start: $start/" \
    -e "${GAS_DT:+s/^  dt: [0-9.e+-]*/  dt: $GAS_DT/}" \
    -e "${SOLVER:+s/^  pressure_solver: {type: [a-z]*/  pressure_solver: {type: $SOLVER/}" \
    -e "$graphs_expr" "$here/cases/$case" > "$tmp"
  local mode=(--overwrite)
  [ "${RESUME:-0}" = 1 ] || : > "$out/$name.log"
  # RESUME=1: go on from the checkpoint the last call's SIGTERM left (a chain of calls: Link's 20 s).
  [ "${RESUME:-0}" = 1 ] && [ -f "$out/$name/checkpoint.lbdem" ] && mode=(--restart "$out/$name")
  timeout -s TERM -k 60 "$limit" "$lbdem" run "$tmp" --backend cuda --output "$out/$name" "${mode[@]}" \
    >> "$out/$name.log" 2>&1
  rc=$?
  echo "scene $name exit $rc (0: done, 5: stopped at the time limit, with its output)"
  tail -2 "$out/$name.log"
  grep -m1 -o "pressure solver [a-z]*" "$out/$name.log"
  [ -f "$out/$name/summary.json" ] && grep -E '"(time_s|seconds_per_simulated_second|particle_steps_per_second|mean_pressure_drop_over_weight|max_courant|interrupted|diverged)"' "$out/$name/summary.json"
}

# speed_run NAME CASE SOLVER END: 1000 gas steps of CASE with that pressure solver, series every step; prints
# "NAME SOLVER seconds_per_gas_step mean_iterations projected_seconds_to_END".
speed_run() {
  local name="$1" case="$2" solver="$3" end="$4" d="$out/speed/$1_$3"
  mkdir -p "$d"
  sed -e "s/^time: {end: [0-9.e+-]*}/time: {steps: 1000}/" -e "s/series_interval: [0-9]*/series_interval: 1/" \
    -e "s/^  pressure_solver: {type: [a-z]*/  pressure_solver: {type: $solver/" "$here/cases/$case" > "$d/case.yaml"
  timeout -s TERM -k 30 240 "$lbdem" run "$d/case.yaml" --backend cuda --output "$d/run" --overwrite > "$d/log.txt" 2>&1
  local secs iters dt
  secs=$(grep -o '"seconds": [0-9.e+-]*' "$d/run/summary.json" 2>/dev/null | awk '{print $2 / 1000}')
  iters=$(awk -F, 'NR > 1 && $1 > 0 { n++; s += $NF } END { if (n) printf "%.1f", s / n }' "$d/run/series.csv" 2>/dev/null)
  dt=$(grep -m1 -o '^  dt: [0-9.e+-]*' "$here/cases/$case" | awk '{print $2}')
  echo "$name $solver ${secs:-nan} ${iters:-nan} $(awk -v s="${secs:-0}" -v e="$end" -v t="$dt" 'BEGIN { printf "%.0f", s * e / t }')"
}

for part in "$@"; do
  case "$part" in
    build)
      (cd "$here" && cmake --preset cuda && cmake --build --preset cuda -j"$(nproc)" --target lbdem lbdem_bench_cfd cfd_tests) \
        > "$out/build.log" 2>&1
      echo "build exit $?"; tail -3 "$out/build.log" ;;
    test)
      (cd "$build" && OMP_NUM_THREADS=4 timeout 520 ./tests/cfd/cfd_tests) > "$out/cfd_tests.log" 2>&1
      echo "cfd_tests exit $?"; grep -E '^\[  (PASSED|FAILED) ' "$out/cfd_tests.log"; grep -E 'FAILED|U_mf|relative error|weight' "$out/cfd_tests.log" | head -30 ;;
    muller06) scene muller_u06 fluidized_bed_muller_u06.yaml "${MULLER_END:-15.0}" "${MULLER_START:-5.0}" ;;
    muller09) scene muller_u09 fluidized_bed_muller_u09.yaml "${MULLER_END:-15.0}" "${MULLER_START:-5.0}" ;;
    link) scene link_spout fluidized_bed_link_spout.yaml "${LINK_END:-20.0}" "${LINK_START:-5.0}" ;;
    speed)
      {
        echo "| scene | solver | s per gas step | iterations per solve | projected s for the planned run |"
        echo "|---|---|---|---|---|"
        for sc in "muller fluidized_bed_muller_u06.yaml ${MULLER_END:-15.0}" "link fluidized_bed_link_spout.yaml ${LINK_END:-20.0}"; do
          read -r nm cf en <<< "$sc"
          for solver in cg multigrid; do speed_run "$nm" "$cf" "$solver" "$en"; done
        done | awk '{ printf "| %s | %s | %.3g | %s | %s |\n", $1, $2, $3, $4, $5; t[$1 " " $2] = $3 }
                    END { for (s in t) if (s ~ / cg$/) { m = s; sub(/ cg$/, " multigrid", m);
                          if (t[m] > 0) printf "\n%s: cg / multigrid = %.1fx per gas step\n", substr(s, 1, length(s) - 3), t[s] / t[m] } }'
        echo
        echo "A scene fits one call if its projected time (the whole run, DEM included) is below CFD_LIMIT ($limit s);"
        echo "otherwise lower MULLER_END / LINK_END to fit."
      } > "$out/speed.md"
      cat "$out/speed.md" ;;
    bench)
      timeout 520 "$build/bench/cfd/lbdem_bench_cfd" --out "$out" ${BENCH_ARGS:-} > "$out/bench_cfd.log" 2>&1
      echo "bench exit $?"; cat "$out/bench_cfd.md" 2>/dev/null || tail -5 "$out/bench_cfd.log" ;;
    plot)
      for d in muller_u06 muller_u09 link_spout; do
        [ -d "$out/$d" ] && python3 "$here/scripts/plot_cfd.py" run "$out/$d" --validation "$here/cfd/validation"
      done ;;
    *) echo "unknown part '$part'"; sed -n 2,34p "$0"; exit 2 ;;
  esac
done
