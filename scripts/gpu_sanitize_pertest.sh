#!/usr/bin/env bash
# compute-sanitizer over the CUDA tests one test per process, in parallel, each checking the first
# LAUNCHES kernel launches of its test (compute-sanitizer --launch-count): the long simulation tests
# (10^4-10^5 steps) run their later steps uninstrumented, so every test executable is covered in one
# device call; a test's kernels are all launched within its first steps (set-up, the first time steps,
# the first diagnostics), which the log's launch count shows. Scenes: `lbdem run` of each cases/*.yaml
# for SCENE_STEPS steps under the same limit.
#   scripts/gpu_sanitize_pertest.sh SECONDS TOOL:TESTS[:FILTER] ...
#     TOOL   memcheck | initcheck | racecheck | synccheck
#     TESTS  lbm | dem | imb | cfd (build-gpu/tests/<t>/<t>_tests) or scenes (SCENE_GLOB, default '*')
#     FILTER gtest filter (default '*/cuda*')
#   LAUNCHES (default 400; 0: no limit), JOBS (parallel processes, default nproc), OUT (default ./out/sanitize_pertest),
#   SANITIZER, LBDEM_COMMIT. The build-gpu/ executables must exist.
# Writes $OUT/<tool>_<tests>/<test>.log per run and $OUT/summary.txt: per lane the runs, the runs whose
# sanitizer summary says 0 errors (0 hazards), the runs with errors (named), and the runs cut by the time
# limit or without a summary (named): those count as not covered.
# Caveat: the launches after the limit run uninstrumented, so initcheck does not record their writes; its
# host-API check (a cudaMemcpy reading device bytes) may then report bytes that such a kernel did write.
# Confirm an initcheck host-API report with LAUNCHES=0 on that test before taking it as a finding.
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
budget="${1:?seconds}"; shift
OUT="${OUT:-$here/out/sanitize_pertest}"
mkdir -p "$OUT"
t0=$(date +%s)
cs="${SANITIZER:-/usr/local/cuda/bin/compute-sanitizer}"
launches="${LAUNCHES:-400}"
jobs="${JOBS:-$(nproc)}"
build="${BUILD:-$here/build-gpu}"
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive
runlist="$OUT/runs.txt"
: > "$runlist"
for lane in "$@"; do
  IFS=: read -r tool what filter <<< "$lane"
  mkdir -p "$OUT/${tool}_$what"
  if [ "$what" = scenes ]; then
    for c in "$here"/cases/${SCENE_GLOB:-*}.yaml; do
      echo "$tool $what scene $(basename "$c" .yaml)" >> "$runlist"
    done
  else
    exe="$build/tests/$what/${what}_tests"
    [ -x "$exe" ] || { echo "$tool $what: $exe not built" >> "$OUT/missing.txt"; continue; }
    "$exe" --gtest_list_tests --gtest_filter="${filter:-*/cuda*}" 2>/dev/null |
      awk '/^[^ ]/{s=$1} /^  /{print s $1}' | while read -r t; do echo "$tool $what test $t" >> "$runlist"; done
  fi
done
one() {  # one() TOOL WHAT KIND NAME
  local tool="$1" what="$2" kind="$3" name="$4" left extra=()
  left=$(( t0 + budget - $(date +%s) ))
  [ "$left" -gt 5 ] || { echo "$tool $what $name: not started (no time left)" > "$OUT/${tool}_$what/${name//\//_}.log"; return; }
  case "$tool" in memcheck) extra=(--leak-check full) ;; racecheck) extra=(--racecheck-report hazard) ;; esac
  [ "$launches" -gt 0 ] && extra+=(--launch-count "$launches")
  local log="$OUT/${tool}_$what/${name//\//_}.log"
  if [ "$kind" = scene ]; then
    local d; d="$(mktemp -d)"
    timeout "$left" "$cs" --tool "$tool" "${extra[@]}" --error-exitcode 99 --print-limit 20 \
      "$build/cases/lbdem" run "$here/cases/$name.yaml" --backend cuda --steps "${SCENE_STEPS:-5}" --output "$d/o" --quiet \
      > "$log" 2>&1
    echo "exit $?" >> "$log"
    rm -rf "$d"
  else
    local td; td="$(mktemp -d)"
    (cd "$td" && TMPDIR="$td" timeout "$left" "$cs" --tool "$tool" "${extra[@]}" \
      --error-exitcode 99 --print-limit 20 "$build/tests/$what/${what}_tests" --gtest_filter="$name" > "$log" 2>&1
     echo "exit $?" >> "$log")
    rm -rf "$td"
  fi
}
export -f one
export t0 budget cs launches build here OUT
# Longest first is unknown; interleave the lanes so that each tool progresses.
awk '{print NR % 1000 " " $0}' "$runlist" | sort -n -s -k1,1 | cut -d' ' -f2- |
  xargs -P "$jobs" -L 1 bash -c 'one "$0" "$1" "$2" "$3"'
{
  echo "# compute-sanitizer, one test per process, first $launches launches each, $(( $(date +%s) - t0 )) s"
  echo "commit ${LBDEM_COMMIT:-$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)}"
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null; "$cs" --version | tail -1
  for d in "$OUT"/*/; do
    n=0; clean=0; bad=(); cut=()
    for f in "$d"*.log; do
      [ -e "$f" ] || continue
      n=$((n + 1))
      s="$(grep -hE "(ERROR|RACECHECK) SUMMARY" "$f" | tail -1)"
      rc="$(grep -E '^exit [0-9]+' "$f" | tail -1 | cut -d' ' -f2)"
      b="$(basename "$f" .log)"
      if [[ "$s" =~ "SUMMARY: 0 errors" || "$s" =~ "SUMMARY: 0 hazards" ]] && [ "${rc:-x}" != 124 ] && [ "${rc:-x}" != 99 ]; then
        clean=$((clean + 1))
      elif [ -n "$s" ] && ! [[ "$s" =~ "SUMMARY: 0 " ]]; then bad+=("$b")
      else cut+=("$b(exit ${rc:-none})"); fi
    done
    echo "$(basename "$d"): $n runs, $clean clean, errors: ${bad[*]:-none}; not covered: ${cut[*]:-none}"
  done
  [ -f "$OUT/missing.txt" ] && cat "$OUT/missing.txt"
} > "$OUT/summary.txt"
cat "$OUT/summary.txt"
