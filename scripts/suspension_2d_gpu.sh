#!/usr/bin/env bash
# The first paper's 2D suspension at full size (cases/suspension/suspension_2d.yaml: 15360 x 61440 cells,
# 1,166,400 disks of d/l 10, block packing) coupled on 1, 2 and (where the host has them) 4 GPUs, in fp32 and
# fp64 (issue 27): STEPS steps each, no snapshots (output.interval 0, no final snapshot: one would be 15-30 GB),
# the grid cut as halo::decompose chooses. Every run's summary.json "timing" (phases max/mean over ranks, set-up
# phases), "particles_per_rank", the series rows' own time (statistics.seconds, rank 0) and the loop's stepping
# time go to one JSON line each (dim 2d, precision, gpus, dims, series_s, series_interval: what
# scripts/scaling_model_coupled.py reads from bench/results/suspension_2d_h200.jsonl); a table is printed at the
# end.
#   scripts/suspension_2d_gpu.sh BUILD_DIR [all|pair]
# BUILD_DIR: a build folder (configured from the `cuda` preset and built here if missing: lbdem_build).
# all (default): every precision on every GPU count of GPUS.
# pair: the strong-scaling ratios of one lease, on a 4-GPU host: fp32 on 1 GPU (GPU 0, nothing else running),
#   fp32 on 4 GPUs, fp32 on 4 GPUs again with series_interval 10 (21 series rows instead of 3: the rows' cost
#   and the rest of the loop apart), then fp64 on 1 and on 4 GPUs. About 3 minutes after the build (one GPU
#   ~30-35 s a run, set-up included; four GPUs ~15 s); the fp64 pair is skipped if BUDGET is spent.
# BUILD_ONLY=1: build and stop (a first call on a fresh machine; the runs then go in a second call).
# Environment: STEPS (200), GPUS (the GPU counts to run, default "1 2 4" less those the host lacks; pair: 1 4),
# PRECISIONS ("fp32 fp64"), SERIES (series_interval of the runs, default the case's 100), BUDGET (seconds of runs
# after which the remaining ones are skipped, 420), WORK (run folders, removed after each run; default
# /tmp/lbdem_suspension_2d), OUT (results; default ./out); CASE2D and BACKEND (a smaller 2D case and the cpu
# backend: a try of the script on a host without GPUs). NSYS=1: rank 0 of every run on several GPUs runs under
# `nsys profile` (CUDA API, OS runtime, MPI): the per-call host time of the CUDA API and the runtime, the GPU
# time per kernel, top lines printed and kept as <run>.nsys_*.txt (where time goes that the phase clocks do not
# see: host waits, copies, MPI).
# Writes $OUT/suspension_2d/{suspension_2d.jsonl, table.txt, <run>.log, <run>.summary.json}; never field files.
# Time on a 4-GPU H200 host (measured at 48bb40e / a1d284a: one GPU 37.5 ms per step in fp32, 70 in fp64, set-up
# ~20 s; four GPUs 14-23 ms per step, set-up ~8-11 s): six runs of 15-35 s each. Device memory: ~46 GB (fp32)
# and ~80 GB (fp64) on one GPU.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
lbdem_env
build="${1:?usage: scripts/suspension_2d_gpu.sh BUILD_DIR [all|pair]}"
mode="${2:-all}"
case "$mode" in all|pair) ;; *) echo "scripts/suspension_2d_gpu.sh: mode '$mode': use all or pair"; exit 2 ;; esac
lbdem_build "$build" lbdem || exit 1
[ -n "${BUILD_ONLY:-}" ] && exit 0
out="$OUT/suspension_2d"
mkdir -p "$out"
jsonl="$out/suspension_2d.jsonl"
work="${WORK:-/tmp/lbdem_suspension_2d}"
mkdir -p "$work"
lbdem="$build/cases/lbdem"
steps="${STEPS:-200}"
budget="${BUDGET:-420}"
G=$(gpu_count)
[ "$G" -ge 1 ] || { echo "no GPU"; exit 1; }
case2d="${CASE2D:-$LBDEM_ROOT/cases/suspension/suspension_2d.yaml}"
backend="${BACKEND:-cuda}"
t0=$SECONDS

# The shipped case in precision P, no snapshots, series rows every S steps (default: as shipped).
case_in() {
  local p="$1" ser="${2:-}" f="$work/suspension_2d_$1_${2:-case}.yaml"
  python3 - "$case2d" "$p" "$ser" > "$f" <<'PY'
import re, sys
text, p, ser = open(sys.argv[1]).read(), sys.argv[2], sys.argv[3]
text = re.sub(r"precision: fp32", "precision: " + p, text)
text = re.sub(r"^output: \{", "output: {final: false, ", text, flags=re.M)
text = re.sub(r"(?<!_)interval: 5000", "interval: 0", text)
if ser:
    text = re.sub(r"series_interval: \d+", "series_interval: " + ser, text)
print(text)
PY
  echo "$f"
}

# series_interval of a case file (the runs' series rows: steps / interval + 1, the row at step 0 included).
series_of() {
  python3 -c 'import re,sys; m=re.search(r"series_interval: (\d+)", open(sys.argv[1]).read()); print(m.group(1) if m else 100)' "$1"
}

# run_one N PRECISION [SERIES_INTERVAL]
run_one() {
  local n="$1" prec="$2" ser="${3:-${SERIES:-}}" name="coupled_2d_${2}_${1}${3:+_series$3}"
  local label="strong${ser:+_series$ser}"
  if [ $((SECONDS - t0)) -gt "$budget" ]; then
    echo "skipped $name: past the ${budget} s budget"
    json_line "$jsonl" kind=coupled dim=2d mode="$label" precision="$prec" gpus="$n" skipped=true
    return
  fi
  local yaml
  yaml=$(case_in "$prec" "$ser")
  rm -rf "${work:?}/$name"
  local t=$SECONDS
  local pre=()
  if [ -n "${NSYS:-}" ] && [ "$n" -gt 1 ] && command -v nsys > /dev/null 2>&1; then
    # Rank 0 under the profiler, the others as they are.
    cat > "$work/nsys_rank0.sh" <<SH
#!/bin/bash
if [ "\${OMPI_COMM_WORLD_RANK:-0}" = 0 ]; then exec nsys profile -t cuda,osrt,mpi --force-overwrite true -o "$work/$name.r0" "\$@"; fi
exec "\$@"
SH
    chmod +x "$work/nsys_rank0.sh"
    pre=("$work/nsys_rank0.sh")
  fi
  timeout 240 "${MPIRUN[@]}" -np "$n" "${pre[@]}" "$lbdem" run "$yaml" --backend "$backend" --steps "$steps" --output "$work/$name" \
    --quiet > "$out/$name.log" 2>&1
  local rc=$? wall=$((SECONDS - t))
  if [ -f "$work/$name.r0.nsys-rep" ]; then
    for r in cuda_api_sum osrt_sum cuda_gpu_kern_sum mpi_event_sum; do
      timeout 120 nsys stats -r "$r" "$work/$name.r0.nsys-rep" > "$out/$name.nsys_$r.txt" 2>&1
      echo "== $name rank 0: $r"; grep -a -v '^\s*$' "$out/$name.nsys_$r.txt" | head -16 | cut -c1-200
    done
    rm -f "$work/$name.r0.nsys-rep" "$work/$name.r0.sqlite"
  fi
  cp "$work/$name/summary.json" "$out/$name.summary.json" 2>/dev/null
  local fields extra
  fields=$(python3 "$LBDEM_ROOT/scripts/coupled_summary.py" "$work/$name/summary.json")
  # The series rows' own wall time (statistics.seconds: rank 0's time in the rows) and the loop's time inside the
  # step function (phases_s.coupled): loop_s minus these is what neither the rows nor the steps hold.
  extra=$(python3 - "$work/$name/summary.json" <<'PY'
import json, sys
try:
    s = json.load(open(sys.argv[1]))
except Exception:
    sys.exit()
st, ph = s.get("statistics", {}), s.get("phases_s", {})
if "seconds" in st:
    print("series_s=%r" % st["seconds"])
if "coupled" in ph:
    print("step_fn_s=%r" % ph["coupled"])
PY
)
  # shellcheck disable=SC2086
  json_line "$jsonl" kind=coupled dim=2d mode="$label" precision="$prec" gpus="$n" exit="$rc" wall_s="$wall" \
    series_interval="$(series_of "$yaml")" $fields $extra
  echo "$name: exit $rc in $wall s"
  [ "$rc" -eq 0 ] || tail -5 "$out/$name.log"
  rm -rf "${work:?}/$name"
}

if [ "$mode" = pair ]; then
  # One lease, both ratios: each precision on 1 GPU (GPU 0, alone) then on 4; fp32 on 4 once more with 21 series
  # rows. Runs one after another, so nothing shares a GPU.
  [ "$G" -ge 4 ] || echo "pair: this host has $G GPU(s); the 4-GPU runs are left out"
  for prec in ${PRECISIONS:-fp32 fp64}; do
    for n in ${GPUS:-1 4}; do
      [ "$n" -le "$G" ] && run_one "$n" "$prec"
    done
    [ "$prec" = fp32 ] && [ "$G" -ge 4 ] && run_one 4 fp32 10
  done
else
  for prec in ${PRECISIONS:-fp32 fp64}; do
    for n in ${GPUS:-1 2 4}; do
      [ "$n" -le "$G" ] && run_one "$n" "$prec"
    done
  done
fi

python3 - "$jsonl" <<'PY' | tee "$out/table.txt"
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
print("%-5s %4s %-7s %-16s %8s %8s %7s %6s %s" % ("prec", "GPUs", "cut", "run", "setup s", "steps/s", "GLUPS", "eff %",
                                                  "phases max/mean s (fluid_psm dem map force_red ghost exposed)"))
for prec in ("fp32", "fp64"):
    mine = [r for r in rows if r.get("precision") == prec and not r.get("skipped") and r.get("exit", 1) == 0
            and r.get("loop_s")]
    base = next((r for r in mine if r["gpus"] == 1 and r.get("mode") == "strong"), None)
    for r in sorted(mine, key=lambda r: r["gpus"]):
        eff = r["glups"] / (r["gpus"] * base["glups"]) if base and base.get("glups") else float("nan")
        ph = r.get("phases") or {}
        split = " ".join("%.2f/%.2f" % (ph[k]["max"], ph[k]["mean"]) for k in
                         ("fluid_psm", "dem", "map", "force_reduction", "ghost_sync", "exposed_communication") if k in ph)
        ppr = r.get("particles_per_rank") or {}
        outside = r["loop_s"] - sum(ph[k]["max"] for k in ph if k != "exposed_communication")
        print("%-5s %4d %-7s %-16s %8.1f %8.2f %7.2f %6.1f %s  imbalance %.4f  outside phases %.3f s, series rows %s s" % (
            prec, r["gpus"], "x".join(map(str, r.get("dims", []))), r.get("mode", ""), r.get("setup_s") or 0,
            r.get("steps_per_s", 0), r.get("glups", 0), 100 * eff, split, ppr.get("imbalance", 0), outside,
            "%.3f" % r["series_s"] if "series_s" in r else "-"))
PY
echo "total $((SECONDS - t0)) s; results in $out (append $jsonl to bench/results/suspension_2d_h200.jsonl)"
