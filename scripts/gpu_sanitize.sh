#!/usr/bin/env bash
# compute-sanitizer over the CUDA tests and a short run of every shipped scene, on a GPU machine.
#   scripts/gpu_sanitize.sh [TOOL...]          (default: memcheck racecheck initcheck synccheck)
#   TESTS     test executables of build-gpu/tests to run (default: "lbm dem imb"; core_tests has no CUDA
#             instances, and a run that makes no CUDA call ends in a sanitizer error)
#   FILTER    gtest filter (default: the CUDA instances, '*/cuda*', without the 10^4-step hard cases
#             and the resolution sweeps, which take hours under the sanitizer)
#   SCENES    1 (default) also runs `lbdem run --backend cuda --steps $SCENE_STEPS` on every
#             cases/*.yaml (SCENE_STEPS default 20); 0 skips them; SCENE_GLOB picks some (default '*')
#   SANITIZER path of compute-sanitizer (default /usr/local/cuda/bin/compute-sanitizer)
#   OUT       where the logs and the summary go (default ./out/sanitize)
#   LBDEM_COMMIT  the commit named in the summary (default: git rev-parse here)
# Builds the `cuda` preset first when build-gpu/ is missing (scripts/gpu_run.sh build does the same).
# Each run's log is $OUT/<tool>_<what>.log; $OUT/summary.txt has one line per run with its
# "ERROR SUMMARY" and exit code. The script exits 1 when any run reported an error.
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
OUT="${OUT:-$here/out/sanitize}"
mkdir -p "$OUT"
build="$here/build-gpu"
cs="${SANITIZER:-/usr/local/cuda/bin/compute-sanitizer}"
tools=("$@")
[ ${#tools[@]} -eq 0 ] && tools=(memcheck racecheck initcheck synccheck)
filter="${FILTER:-*/cuda*:-*PsmHard*:*ResolutionSweep*:*Dl10WithinHalfPercent*}"
export OMP_WAIT_POLICY=passive OMP_NUM_THREADS="${OMP_NUM_THREADS:-2}"
[ -x "$cs" ] || { echo "compute-sanitizer not found at $cs (set SANITIZER)"; exit 2; }
if [ ! -d "$build" ]; then
  (cd "$here" && cmake --preset cuda && cmake --build --preset cuda -j"$(nproc)") > "$OUT/build.log" 2>&1 ||
    { echo "build failed: $OUT/build.log"; exit 2; }
fi
summary="$OUT/summary.txt"
{ echo "commit ${LBDEM_COMMIT:-$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)}"
  nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null; "$cs" --version | tail -1; } > "$summary"
fail=0

# sanitize TOOL NAME OK COMMAND...: one run; its "ERROR SUMMARY" line into the summary. OK lists
# the exit codes of a good run ("0"; "0 1" for the fixed-sphere scenes, which exit 1 when their
# drag has not converged in the few steps given).
sanitize() {
  local tool="$1" name="$2" ok="$3"; shift 3
  local extra=()
  case "$tool" in
    memcheck) extra=(--leak-check full) ;;
    racecheck) extra=(--racecheck-report hazard) ;;
  esac
  "$cs" --tool "$tool" "${extra[@]}" --error-exitcode 99 --print-limit 50 "$@" > "$OUT/${tool}_${name}.log" 2>&1
  local rc=$?
  local errs
  # racecheck ends with "RACECHECK SUMMARY: N hazards displayed (E errors, W warnings)", the others with
  # "ERROR SUMMARY: N errors".
  errs="$(grep -hE "(ERROR|RACECHECK) SUMMARY" "$OUT/${tool}_${name}.log" | tail -1)"
  printf '%-10s %-28s exit %-3s %s\n' "$tool" "$name" "$rc" "${errs:-no summary}" | tee -a "$summary"
  # 99: the sanitizer found errors; an exit code not in OK is a failing run, also a failure here.
  case " $ok " in *" $rc "*) ;; *) fail=1 ;; esac
  return 0
}

for tool in "${tools[@]}"; do
  for t in ${TESTS:-lbm dem imb}; do
    exe="$build/tests/$t/${t}_tests"
    [ -x "$exe" ] || { echo "skip $t: $exe not built" | tee -a "$summary"; continue; }
    sanitize "$tool" "${t}_tests" "0" "$exe" --gtest_filter="$filter"
  done
  if [ "${SCENES:-1}" = 1 ]; then
    for c in "$here"/cases/${SCENE_GLOB:-*}.yaml; do
      n="$(basename "$c" .yaml)"
      d="$(mktemp -d)"
      ok="0"
      grep -q '^scene: fixed_sphere' "$c" && ok="0 1"
      sanitize "$tool" "scene_$n" "$ok" "$build/cases/lbdem" run "$c" --backend cuda --steps "${SCENE_STEPS:-20}" \
        --output "$d/out" --quiet
      rm -rf "$d"
    done
  fi
done
echo "summary: $summary"
[ $fail -eq 0 ] && echo "compute-sanitizer: no errors" || echo "compute-sanitizer: errors or failing runs (see above)"
exit $fail
