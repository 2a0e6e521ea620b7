#!/usr/bin/env bash
# The first paper's 3D suspension (cases/suspension/suspension_3d.yaml: 512 x 2016 x 512 cells, 129,024
# spheres, fp32) coupled on 1, 2 and 4 GPUs of one host (issue 27):
#   strong  the paper's box on 1, 2, 4 GPUs, STEPS steps, the shipped output settings (interval 5000, final
#           snapshot on): snapshots at step 0 and at the end, each rank writing its pieces;
#   weak    one paper box per GPU along the long axis (y: 2016 N cells, 129,024 N spheres, cut [1, N, 1]) on
#           2 and 4 GPUs (1 GPU: the strong run), no snapshots (each would be N x 10 GB);
#   fluid   lbdem_bench_scaling on the same grids (--grid 512 2016 512 on 1, 2, 4 ranks; --per-rank 512 2016 512
#           for weak, which it stacks along z), transport auto.
# Every coupled run's summary.json "timing" (phases max/mean over ranks, set-up phases, snapshot seconds) and
# "particles_per_rank" go to one JSON line each; a table is printed at the end.
#   scripts/suspension_scaling_gpu.sh BUILD_DIR
# BUILD_DIR: a build folder (configured from the `cuda` preset and built here if missing: lbdem_build).
# SKIP_FLUID=1: the coupled runs only (the fluid-only ones measured before, same machine kind).
# BUILD_ONLY=1: build and stop (a first call on a fresh machine; the runs then go in a second call).
# Environment: STEPS (200), BUDGET (seconds of runs before the remaining ones are skipped, 500), LIMIT (a run is
# cut by timeout so that the runs end within LIMIT s, default 570), WORK (run
# folders, removed after each run; default /tmp/lbdem_suspension_scaling), OUT (results; default ./out).
# Writes $OUT/suspension_scaling/{scaling.jsonl, table.txt, <run>.log, <run>.summary.json}; never field files.
# Time on 4 H200s, from the issue's numbers (1 GPU: set-up 40 s, 200 steps 7 s; a 10 GB fp32 snapshot per
# rank set in pieces at a few GB/s): strong 1/2/4 GPUs ~75/80/90 s, fluid-only ~60 s in all, weak 2/4 GPUs
# ~100/150 s: about 9 minutes after the build; BUDGET skips what would run past it (the weak 4-GPU run last).
set -uo pipefail
source "$(dirname "$0")/lib.sh"
lbdem_env
build="${1:?usage: scripts/suspension_scaling_gpu.sh BUILD_DIR}"
lbdem_build "$build" lbdem lbdem_bench_scaling || exit 1
[ -n "${BUILD_ONLY:-}" ] && exit 0
out="$OUT/suspension_scaling"
mkdir -p "$out"
jsonl="$out/scaling.jsonl"
work="${WORK:-/tmp/lbdem_suspension_scaling}"
mkdir -p "$work"
lbdem="$build/cases/lbdem"
bench="$build/bench/scaling/lbdem_bench_scaling"
steps="${STEPS:-200}"
budget="${BUDGET:-500}"
G=$(gpu_count)
[ "$G" -ge 1 ] || { echo "no GPU"; exit 1; }
case3d="$LBDEM_ROOT/cases/suspension/suspension_3d.yaml"
t0=$SECONDS

over_budget() { [ $((SECONDS - t0)) -gt "$budget" ]; }
# Seconds a run may take so that the whole script ends within LIMIT (570) s of the runs' start.
run_limit() {
  local left=$(( ${LIMIT:-570} - (SECONDS - t0) ))
  [ "$left" -gt 300 ] && left=300
  echo "$left"
}

# A weak-scaling case: N paper boxes along y, cut [1, N, 1], no snapshots.
weak_case() {
  local n="$1" f="$work/suspension_3d_weak$1.yaml"
  python3 - "$case3d" "$n" > "$f" <<'PY'
import re, sys
text, n = open(sys.argv[1]).read(), int(sys.argv[2])
text = re.sub(r"size: \[0.00384, 0.01512, 0.00384\]", "size: [0.00384, %.5f, 0.00384]" % (0.01512 * n), text)
text = re.sub(r"count: 129024", "count: %d" % (129024 * n), text)
text = re.sub(r"^output: \{", "output: {final: false, ", text, flags=re.M)
text = re.sub(r"interval: 5000", "interval: 0", text)
print(text + "parallel: {decomposition: [1, %d, 1]}" % n)
PY
  echo "$f"
}

# coupled MODE N CASE: one run on N GPUs; its summary to a JSON line.
coupled() {
  local mode="$1" n="$2" yaml="$3" name="coupled_${1}_${2}"
  if over_budget; then
    echo "skipped $name: past the ${budget} s budget"
    json_line "$jsonl" kind=coupled mode="$mode" gpus="$n" skipped=true
    return
  fi
  rm -rf "$work/$name"
  local t=$SECONDS
  local lim
  lim=$(run_limit)
  [ "$lim" -lt 30 ] && lim=30
  timeout "$lim" "${MPIRUN[@]}" -np "$n" "$lbdem" run "$yaml" --backend cuda --steps "$steps" --output "$work/$name" \
    --quiet > "$out/$name.log" 2>&1
  local rc=$? wall=$((SECONDS - t))
  cp "$work/$name/summary.json" "$out/$name.summary.json" 2>/dev/null
  local du
  du=$(du -sm "$work/$name" 2>/dev/null | cut -f1)
  local fields
  fields=$(python3 "$LBDEM_ROOT/scripts/coupled_summary.py" "$work/$name/summary.json")
  # shellcheck disable=SC2086
  json_line "$jsonl" kind=coupled mode="$mode" gpus="$n" exit="$rc" wall_s="$wall" disk_mib="${du:-0}" $fields
  echo "$name: exit $rc in $wall s"
  [ "$rc" -eq 0 ] || tail -5 "$out/$name.log"
  rm -rf "$work/$name"
}

# fluid MODE N ARGS...: lbdem_bench_scaling on N ranks.
fluid() {
  local mode="$1" n="$2"; shift 2
  if over_budget; then
    json_line "$jsonl" kind=fluid mode="$mode" gpus="$n" skipped=true
    return
  fi
  local tr=auto
  local line
  line=$(timeout 90 "${MPIRUN[@]}" -np "$n" "$bench" --transport "$tr" --steps "$steps" --precision fp32 "$@" \
    2>> "$out/fluid.log" | grep '^{' | tail -1)
  python3 - "$line" "$mode" "$n" >> "$jsonl" <<'PY'
import json, sys
line, mode, n = sys.argv[1:]
try:
    b = json.loads(line)
except Exception:
    b = {"error": "no output"}
b.update({"kind": "fluid", "mode": mode, "gpus": int(n), "glups": b.get("mlups", 0) / 1e3})
print(json.dumps(b))
PY
  echo "fluid $mode $n: $(tail -1 "$jsonl" | python3 -c 'import json,sys; print(json.load(sys.stdin).get("glups"))') GLUPS"
}

for n in 1 2 4; do [ "$n" -le "$G" ] && coupled strong "$n" "$case3d"; done
if [ -z "${SKIP_FLUID:-}" ]; then
  for n in 1 2 4; do [ "$n" -le "$G" ] && fluid strong "$n" --grid 512 2016 512; done
fi
for n in 2 4; do
  [ "$n" -le "$G" ] || continue
  [ -n "${SKIP_FLUID:-}" ] || fluid weak "$n" --per-rank 512 2016 512
  coupled weak "$n" "$(weak_case "$n")"
done

python3 - "$jsonl" <<'PY' | tee "$out/table.txt"
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
def pick(kind, mode, n):
    r = [x for x in rows if x.get("kind") == kind and x.get("mode") == mode and x.get("gpus") == n and not x.get("skipped")]
    return r[-1] if r else None
base = pick("coupled", "strong", 1)
fl1 = pick("fluid", "strong", 1)
print("%-7s %4s %8s %8s %7s %9s %6s %8s %s" % ("mode", "GPUs", "setup s", "steps/s", "GLUPS", "cpl/fluid", "eff %",
                                             "snap %", "phases max/mean s (fluid_psm dem map force_red ghost exposed)"))
for mode in ("strong", "weak"):
    for n in (1, 2, 4):
        c = pick("coupled", mode, n) or (base if mode == "weak" and n == 1 else None)
        if not c or c.get("exit", 1) != 0:
            continue
        f = pick("fluid", mode, n) or (fl1 if n == 1 else None)
        ratio = c["glups"] / f["glups"] if f and f.get("glups") else float("nan")
        if base and base.get("glups"):
            eff = c["glups"] / (n * base["glups"]) if mode == "strong" else c["steps_per_s"] / base["steps_per_s"]
        else:
            eff = float("nan")
        ph = c.get("phases") or {}
        split = " ".join("%.2f/%.2f" % (ph[k]["max"], ph[k]["mean"]) for k in
                         ("fluid_psm", "dem", "map", "force_reduction", "ghost_sync", "exposed_communication") if k in ph)
        snap = c.get("snapshot_fraction_shipped")
        ppr = c.get("particles_per_rank") or {}
        print("%-7s %4d %8.1f %8.2f %7.2f %9.2f %6.1f %8s %s  imbalance %.3f" % (
            mode, n, c.get("setup_s") or 0, c.get("steps_per_s", 0), c.get("glups", 0), ratio, 100 * eff,
            "%.2f" % (100 * snap) if snap is not None else "-", split, ppr.get("imbalance", 0)))
print("snap %: one snapshot's wall time (max over ranks) over the stepping time of the shipped interval (5000 steps)")
PY
echo "total $((SECONDS - t0)) s; results in $out"
