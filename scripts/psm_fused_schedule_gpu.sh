#!/usr/bin/env bash
# The fused PSM kernel's two schedules (imb/psm_coupling.hpp, PsmFusedSchedule: one block per tile, the default;
# persistent blocks that prefetch the next tile's candidates) on the first paper's 3D suspension at full size
# (cases/suspension/suspension_3d.yaml: 512 x 2016 x 512 cells, 129,024 spheres, fp32, table fractions) on ONE
# GPU, for issue 27's bar (coupled / fluid-only >= 70 %):
#   coupled  STEPS steps (200) with no snapshots (output.interval 0, output.final false), per schedule, two runs
#            each, alternating (block, persistent, block, persistent): coupled GLUPS and the fluid+PSM phase
#            (summary.json timing.phases.fluid_psm, max over ranks) per run;
#   fluid    lbdem_bench_scaling --grid 512 2016 512 fp32 once (the fluid-only GLUPS of the same grid).
#   scripts/psm_fused_schedule_gpu.sh BUILD_DIR
# BUILD_DIR: a build folder (configured from the `cuda` preset and built here if missing: lbdem_build).
# The schedule is chosen per run by LBDEM_PSM_FUSED_SCHEDULE (block | persistent), read once at set-up.
# Environment: STEPS (200), WORK (run folders, removed after each run; default /tmp/lbdem_fused_schedule),
# OUT (results; default ./out). Writes $OUT/psm_fused_schedule/{schedule.jsonl, table.txt, <run>.log,
# <run>.summary.json}; never field files. Time on one H200: ~40 s set-up + ~7 s of steps per coupled run, four
# runs, plus ~20 s fluid-only: about 4 minutes after the build (each run cut at 120 s).
set -uo pipefail
source "$(dirname "$0")/lib.sh"
lbdem_env
build="${1:?usage: scripts/psm_fused_schedule_gpu.sh BUILD_DIR}"
lbdem_build "$build" lbdem lbdem_bench_scaling || exit 1
out="$OUT/psm_fused_schedule"
mkdir -p "$out"
jsonl="$out/schedule.jsonl"
work="${WORK:-/tmp/lbdem_fused_schedule}"
mkdir -p "$work"
lbdem="$build/cases/lbdem"
bench="$build/bench/scaling/lbdem_bench_scaling"
steps="${STEPS:-200}"
export CUDA_VISIBLE_DEVICES="${CUDA_VISIBLE_DEVICES:-0}"
t0=$SECONDS

# The shipped case without snapshots (the same keys the weak-scaling script rewrites).
yaml="$work/suspension_3d_nosnap.yaml"
python3 - "$LBDEM_ROOT/cases/suspension/suspension_3d.yaml" > "$yaml" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
text, n1 = re.subn(r"^output: \{", "output: {final: false, ", text, flags=re.M)
text, n2 = re.subn(r"interval: 5000", "interval: 0", text)
assert n1 == 1 and n2 == 1, "suspension_3d.yaml: output line not as expected"
print(text)
PY

# coupled SCHEDULE RUN: one run on one GPU; its summary to a JSON line.
coupled() {
  local sched="$1" run="$2" name="coupled_${1}_${2}"
  rm -rf "${work:?}/$name"
  local t=$SECONDS
  LBDEM_PSM_FUSED_SCHEDULE="$sched" timeout 120 "$lbdem" run "$yaml" --backend cuda --steps "$steps" \
    --output "$work/$name" --quiet > "$out/$name.log" 2>&1
  local rc=$? wall=$((SECONDS - t))
  cp "$work/$name/summary.json" "$out/$name.summary.json" 2>/dev/null
  local fields
  fields=$(python3 "$LBDEM_ROOT/scripts/coupled_summary.py" "$work/$name/summary.json")
  # shellcheck disable=SC2086
  json_line "$jsonl" kind=coupled schedule="$sched" run="$run" exit="$rc" wall_s="$wall" $fields
  echo "$name: exit $rc in $wall s"
  [ "$rc" -eq 0 ] || tail -5 "$out/$name.log"
  rm -rf "${work:?}/$name"
}

for run in 1 2; do
  coupled block "$run"
  coupled persistent "$run"
done

line=$(timeout 90 "${MPIRUN[@]}" -np 1 "$bench" --transport auto --steps "$steps" --precision fp32 \
  --grid 512 2016 512 2>> "$out/fluid.log" | grep '^{' | tail -1)
python3 - "$line" >> "$jsonl" <<'PY'
import json, sys
try:
    b = json.loads(sys.argv[1])
except Exception:
    b = {"error": "no output"}
b.update({"kind": "fluid", "gpus": 1, "glups": b.get("mlups", 0) / 1e3})
print(json.dumps(b))
PY

python3 - "$jsonl" <<'PY' | tee "$out/table.txt"
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
fl = [r for r in rows if r.get("kind") == "fluid"]
fluid = fl[-1].get("glups") if fl else None
print("fluid-only GLUPS: %s" % ("%.2f" % fluid if fluid else "-"))
print("%-11s %3s %7s %10s %9s" % ("schedule", "run", "GLUPS", "fluid_psm s", "cpl/fluid"))
for r in rows:
    if r.get("kind") != "coupled" or r.get("exit") != 0:
        continue
    ph = (r.get("phases") or {}).get("fluid_psm", {})
    g = r.get("glups", 0)
    print("%-11s %3d %7.2f %10.3f %8.1f%%" % (r["schedule"], r["run"], g, ph.get("max", float("nan")),
                                            100 * g / fluid if fluid else float("nan")))
for s in ("block", "persistent"):
    g = [r["glups"] for r in rows if r.get("kind") == "coupled" and r.get("schedule") == s and r.get("exit") == 0]
    if g:
        m = sum(g) / len(g)
        print("%-11s mean %.2f GLUPS%s" % (s, m, ", %.1f %% of fluid-only" % (100 * m / fluid) if fluid else ""))
PY
echo "total $((SECONDS - t0)) s; results in $out"
