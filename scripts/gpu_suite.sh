#!/usr/bin/env bash
# The GPU test suite spread over this host's GPUs, repeated under full load, then a stress run and two
# compute-sanitizer tools on the fluid halo test that once failed under load.
#   scripts/gpu_suite.sh BUILD_DIR [REPEATS]
#     BUILD_DIR  a build of the `cuda` preset (built here first if it has no build.ninja yet; an existing one is
#                reused as it is, so build it with the commit you mean to test)
#     REPEATS    passes of the suite (default 3); a pass that would end after LBDEM_SUITE_BUDGET_S seconds
#                (default 330) from the start is not begun, and the JSON says how many ran
#   LBDEM_SUITE_ARGS  more ctest arguments (e.g. "-LE long" to leave out the long-labelled tests)
#   STRESS_PROCS (8), STRESS_REPEATS (50): processes on one GPU, and repeats of the test in each
# How: every test of a CUDA build takes one GPU slot (tests/CMakeLists.txt: RESOURCE_GROUPS "gpus:1"; an N-rank
# mpiexec test N slots), and each test process turns the GPU CTest gives it into CUDA_VISIBLE_DEVICES
# (tests/common/ctest_gpu.cpp). The resource spec written here gives each GPU 4 slots; ctest runs -j(4 x GPUs).
# The suite is `ctest -L gpu`: the tests on the CUDA backend and the mpiexec tests on GPU ranks.
# Writes under $OUT:
#   gpu_suite.jsonl        one line per pass: pass, passed, failed, total, seconds, failed_tests;
#                          then one line for the stress run and one per sanitizer tool
#   gpu_suite_failures.txt the names of the failed tests of every pass (empty: none)
#   gpu_suite_pass<i>.log  ctest's output of each pass; stress_<k>.log, racecheck.log, synccheck.log
# Prints one summary line per pass and per check. Exit status: 0 when every pass, the stress run and both
# sanitizers are clean.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
lbdem_env
build="${1:?usage: scripts/gpu_suite.sh BUILD_DIR [REPEATS]}"
repeats="${2:-3}"
budget="${LBDEM_SUITE_BUDGET_S:-330}"
t_start=$SECONDS
[ -f "$build/build.ninja" ] || lbdem_build "$build" || exit 1
ngpu=$(gpu_count)
[ "$ngpu" -gt 0 ] || { echo "gpu_suite: no GPU (nvidia-smi -L lists none)"; exit 1; }
# LBDEM_SUITE_GPUS="0 1 2": the GPUs the suite may use (default all), leaving the others to a job beside it.
read -r -a gpu_ids <<< "${LBDEM_SUITE_GPUS:-$(seq -s ' ' 0 $((ngpu - 1)))}"
ngpu=${#gpu_ids[@]}
jsonl="$OUT/gpu_suite.jsonl"
fails="$OUT/gpu_suite_failures.txt"
: > "$fails"

# The resource spec: every GPU with 4 slots.
spec="$OUT/gpu_resources.json"
{
  echo '{"version": {"major": 1, "minor": 0}, "local": [{"gpus": ['
  for ((g = 0; g < ngpu; ++g)); do
    echo "  {\"id\": \"${gpu_ids[g]}\", \"slots\": 4}$([ $g -lt $((ngpu - 1)) ] && echo ,)"
  done
  echo ']}]}'
} > "$spec"
jobs=$((4 * ngpu))
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-2}"  # the host-side parts of up to $jobs tests share the cores
# shellcheck disable=SC2086
total_tests=$(ctest --test-dir "$build" -N -L gpu ${LBDEM_SUITE_ARGS:-} 2>/dev/null | awk '/Total Tests:/{print $3}')
echo "gpu_suite: $ngpu GPUs, $jobs jobs, ${total_tests:-?} tests per pass, up to $repeats passes within ${budget} s"

all_ok=1
last=0
for ((i = 1; i <= repeats; ++i)); do
  elapsed=$((SECONDS - t_start))
  if [ $i -gt 1 ] && [ $((elapsed + last)) -gt "$budget" ]; then
    echo "pass $i: not begun (${elapsed} s used, the last pass took ${last} s, budget ${budget} s)"
    break
  fi
  log="$OUT/gpu_suite_pass$i.log"
  t0=$SECONDS
  # shellcheck disable=SC2086
  ctest --test-dir "$build" -L gpu --resource-spec-file "$spec" -j"$jobs" --timeout 600 \
    ${LBDEM_SUITE_ARGS:-} > "$log" 2>&1
  rc=$?
  last=$((SECONDS - t0))
  # -a: a test that prints a NUL byte makes the log "binary", and grep would print no line of it
  # ctest ends with "N% tests passed, F tests failed out of T", or "100% tests passed out of T" when none failed
  line=$(grep -aE 'tests passed(, [0-9]+ tests? failed)? out of [0-9]+' "$log" | tail -1)
  failed=$(sed -E -n 's/.* ([0-9]+) tests? failed out of ([0-9]+).*/\1/p' <<< "$line")
  total=$(sed -E -n 's/.* out of ([0-9]+).*/\1/p' <<< "$line")
  failed=${failed:-0}; total=${total:-0}
  names=$(sed -n '/The following tests FAILED:/,$p' "$log" | tr -d '\000' | sed -E -n 's/^[[:space:]]+[0-9]+ - ([^ ]+) .*/\1/p')
  arr="["
  while read -r n; do [ -n "$n" ] && arr+="\"$n\", " && echo "pass $i: $n" >> "$fails"; done <<< "$names"
  arr="${arr%, }]"
  json_line "$jsonl" what=suite pass="$i" passed=$((total - failed)) failed="$failed" total="$total" \
    seconds="$last" jobs="$jobs" gpus="$ngpu" ctest_exit="$rc" failed_tests="$arr"
  echo "pass $i: $((total - failed))/$total passed in ${last} s (ctest exit $rc)${names:+; failed: $(tr '\n' ' ' <<< "$names")}"
  { [ "$rc" -eq 0 ] && [ "$total" -gt 0 ]; } || all_ok=0
done

# The test that failed once under `ctest -R cuda -j6` on one GPU: STRESS_PROCS processes at once on GPU 0,
# each repeating it STRESS_REPEATS times; meanwhile racecheck and synccheck run it on other GPUs (or after, on one).
lbm="$build/tests/lbm/lbm_tests"
t="Lbm/FluidHaloExchange.PiecesEqualWholeGridBitwise/cuda_D2Q9_fp32_aa_1x2x1_walls"
procs="${STRESS_PROCS:-8}"
reps="${STRESS_REPEATS:-50}"
cs="${SANITIZER:-/usr/local/cuda/bin/compute-sanitizer}"
sanitize() {  # sanitize TOOL GPU
  local tool="$1" gpu="$2" t0=$SECONDS rc
  CUDA_VISIBLE_DEVICES="$gpu" timeout 240 "$cs" --tool "$tool" --error-exitcode 99 --print-limit 20 \
    "$lbm" --gtest_filter="$t" > "$OUT/$tool.log" 2>&1
  rc=$?
  local summary errors
  summary=$(grep -E 'ERROR SUMMARY|RACECHECK SUMMARY' "$OUT/$tool.log" | tail -1 | sed -E 's/^=+ *//')
  errors=$(sed -E -n 's/.*SUMMARY: ([0-9]+) .*/\1/p' <<< "$summary")
  json_line "$jsonl" what="$tool" test="$t" exit="$rc" errors="${errors:-null}" seconds=$((SECONDS - t0)) \
    summary="${summary:-none}"
  echo "$tool: exit $rc, ${summary:-no summary (see $OUT/$tool.log)}"
}
g1=${gpu_ids[$((ngpu > 1 ? 1 : 0))]}; g2=${gpu_ids[$((ngpu > 2 ? 2 : 0))]}
if [ "$ngpu" -gt 1 ]; then
  sanitize racecheck "$g1" &
  p_race=$!
  sanitize synccheck "$g2" &
  p_sync=$!
fi
t0=$SECONDS
pids=()
for ((k = 1; k <= procs; ++k)); do
  CUDA_VISIBLE_DEVICES="${gpu_ids[0]}" "$lbm" --gtest_filter="$t" --gtest_repeat="$reps" > "$OUT/stress_$k.log" 2>&1 &
  pids+=($!)
done
bad_procs=0
for p in "${pids[@]}"; do wait "$p" || bad_procs=$((bad_procs + 1)); done
runs_ok=$(cat "$OUT"/stress_*.log | grep -c '^\[       OK \] ')
runs_failed=$(cat "$OUT"/stress_*.log | grep -cE '^\[  FAILED  \] .* \([0-9]+ ms\)$')
json_line "$jsonl" what=stress test="$t" processes="$procs" repeats="$reps" runs_ok="$runs_ok" \
  runs_failed="$runs_failed" failed_processes="$bad_procs" seconds=$((SECONDS - t0))
echo "stress: $procs processes x $reps repeats on GPU ${gpu_ids[0]}: $runs_ok passed, $runs_failed failed in $((SECONDS - t0)) s"
[ "$runs_failed" -eq 0 ] && [ "$bad_procs" -eq 0 ] && [ "$runs_ok" -eq $((procs * reps)) ] || all_ok=0
if [ "$ngpu" -gt 1 ]; then
  wait "$p_race"; wait "$p_sync"
else
  sanitize racecheck 0
  sanitize synccheck 0
fi
for tool in racecheck synccheck; do
  grep -qE '(ERROR|RACECHECK) SUMMARY: 0 ' "$OUT/$tool.log" || all_ok=0
done
echo "gpu_suite: $((SECONDS - t_start)) s in all; $([ $all_ok -eq 1 ] && echo clean || echo 'NOT clean')"
[ $all_ok -eq 1 ]
