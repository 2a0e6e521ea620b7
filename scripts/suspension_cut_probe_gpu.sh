#!/usr/bin/env bash
# Where the coupled suspension loses time once the grid is cut (issue 27): the paper's 3D box
# (cases/suspension/suspension_3d.yaml, 512 x 2016 x 512 cells, 129,024 spheres, fp32) alone on one GPU
# against one such box per GPU on two GPUs (weak: every rank steps the same local grid), varying one
# thing at a time:
#   transport   parallel.transport nccl (NCCL kernels share the SMs with the PSM kernels) or host_mpi
#   pipeline    psm.pipeline fused (tiles) or mapped (cell slots)
#   axis        the cut along y (the long axis, as the shipped weak runs), z (slowest in memory) or x
#               (fastest: the rows gain ghost cells)
# and, with ROUND=ncu, Nsight Compute's duration of every PSM kernel of a few steps on rank 0 (single
# pass, no replay, clocks left alone), to tell a slower kernel from a concurrency loss.
#   scripts/suspension_cut_probe_gpu.sh BUILD_DIR [ROUND...]
# ROUND (4-GPU host): a (1 GPU fused, 1 GPU mapped, y-cut nccl fused), b (y-cut host_mpi fused, y-cut nccl mapped),
# c (z-cut, x-cut, nccl fused), ncu (kernel durations, 1 GPU and y-cut): default "a b". Runs of a round go
# side by side on disjoint GPUs of a 4-GPU host. STEPS (200). Writes $OUT/cut_probe/{probe.jsonl, *.log,
# table.txt}; every run folder is removed after its summary is read. About 70 s per round after the build.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
lbdem_env
build="${1:?usage: scripts/suspension_cut_probe_gpu.sh BUILD_DIR [ROUND...]}"; shift
rounds=("$@")
[ ${#rounds[@]} -gt 0 ] || rounds=(a b)
lbdem_build "$build" lbdem || exit 1
out="$OUT/cut_probe"
mkdir -p "$out"
jsonl="$out/probe.jsonl"
work="${WORK:-/tmp/lbdem_cut_probe}"
mkdir -p "$work"
lbdem="$build/cases/lbdem"
steps="${STEPS:-200}"
case3d="$LBDEM_ROOT/cases/suspension/suspension_3d.yaml"

# make_case NAME N AXIS TRANSPORT PIPELINE: N paper boxes stacked along AXIS, cut N ways along it.
make_case() {
  local f="$work/$1.yaml"
  python3 - "$case3d" "$2" "$3" "$4" "$5" > "$f" <<'PY'
import re, sys
text, n, axis, transport, pipeline = open(sys.argv[1]).read(), int(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5]
size = [0.00384, 0.01512, 0.00384]
a = "xyz".index(axis)
size[a] *= n
text = re.sub(r"size: \[0.00384, 0.01512, 0.00384\]", "size: [%.5f, %.5f, %.5f]" % tuple(size), text)
text = re.sub(r"count: 129024", "count: %d" % (129024 * n), text)
text = re.sub(r"^output: \{", "output: {final: false, ", text, flags=re.M)
text = re.sub(r"interval: 5000", "interval: 0", text)
text = re.sub(r"pipeline: auto", "pipeline: %s" % pipeline, text)
dec = [1, 1, 1]
dec[a] = n
text += "parallel: {decomposition: [%d, %d, %d], transport: %s}\n" % (dec[0], dec[1], dec[2], transport)
print(text)
PY
  echo "$f"
}

# one NAME GPUS N AXIS TRANSPORT PIPELINE [PREFIX...]: a run in the background on the GPUs listed.
one() {
  local name="$1" gpus="$2" n="$3" axis="$4" tr="$5" pl="$6"
  shift 6
  local yaml
  yaml=$(make_case "$name" "$n" "$axis" "$tr" "$pl")
  rm -rf "$work/$name"
  (
    t=$SECONDS
    CUDA_VISIBLE_DEVICES="$gpus" timeout 280 "${MPIRUN[@]}" -x CUDA_VISIBLE_DEVICES -np "$n" "$@" "$lbdem" run "$yaml" \
      --backend cuda --steps "$steps" --output "$work/$name" --quiet > "$out/$name.log" 2>&1
    rc=$?
    fields=$(python3 - "$work/$name/summary.json" <<'PY'
import json, sys
try:
    s = json.load(open(sys.argv[1]))
except Exception:
    print("error=no_summary"); sys.exit()
t = s.get("timing", {})
out = {"glups": s.get("coupled_mlups", 0) / 1e3, "loop_s": t.get("loop_seconds"), "setup_s": t.get("setup_seconds"),
       "phases": t.get("phases"), "psm": s.get("psm", {}).get("pipeline") if isinstance(s.get("psm"), dict) else None}
for k, v in out.items():
    print("%s=%s" % (k, json.dumps(v).replace(" ", "")))
PY
)
    # shellcheck disable=SC2086
    json_line "$jsonl" run="$name" gpus="$n" axis="$axis" transport="$tr" pipeline="$pl" exit="$rc" \
      wall_s="$((SECONDS - t))" $fields
    echo "$name: exit $rc in $((SECONDS - t)) s"
    [ "$rc" -eq 0 ] || tail -5 "$out/$name.log"
    rm -rf "$work/$name"
  ) &
}

# ncu_wrap: rank 0 under Nsight Compute (PSM kernels of steps ~50-53), the other ranks plain.
ncu_wrap() {
  cat > "$work/ncu_wrap.sh" <<EOF
#!/usr/bin/env bash
if [ "\${OMPI_COMM_WORLD_RANK:-0}" = 0 ]; then
  exec ncu --clock-control none --metrics gpu__time_duration.sum --kernel-name regex:psm_fused_kernel \\
    --launch-skip 150 --launch-count 12 --csv --log-file "$out/ncu_\$CUT_NAME.csv" "\$@"
fi
exec "\$@"
EOF
  chmod +x "$work/ncu_wrap.sh"
}

# Rounds on a 2-GPU host (every 2-GPU run alone): one (the two 1-GPU runs side by side), y_nccl_fused,
# y_mpi_fused, y_nccl_mapped, z, x, ncu1, ncu2.
for r in "${rounds[@]}"; do
  echo "== round $r"
  case "$r" in
    a) one one_fused 0 1 y nccl fused
       one one_mapped 1 1 y nccl mapped
       one y_nccl_fused 2,3 2 y nccl fused ;;
    b) one y_mpi_fused 0,1 2 y host_mpi fused
       one y_nccl_mapped 2,3 2 y nccl mapped ;;
    c) one z_nccl_fused 0,1 2 z nccl fused
       one x_nccl_fused 2,3 2 x nccl fused ;;
    ncu) ncu_wrap
       CUT_NAME=one one ncu_one 0 1 y nccl fused -x CUT_NAME "$work/ncu_wrap.sh"
       CUT_NAME=y2 one ncu_y2 2,3 2 y nccl fused -x CUT_NAME "$work/ncu_wrap.sh" ;;
    one) one one_fused 0 1 y nccl fused
       one one_mapped 1 1 y nccl mapped ;;
    y_nccl_fused) one y_nccl_fused 0,1 2 y nccl fused ;;
    y_mpi_fused) one y_mpi_fused 0,1 2 y host_mpi fused ;;
    y_nccl_mapped) one y_nccl_mapped 0,1 2 y nccl mapped ;;
    z) one z_nccl_fused 0,1 2 z nccl fused ;;
    x) one x_nccl_fused 0,1 2 x nccl fused ;;
    ncu1) ncu_wrap; CUT_NAME=one one ncu_one 0 1 y nccl fused -x CUT_NAME "$work/ncu_wrap.sh" ;;
    ncu2) ncu_wrap; CUT_NAME=y2 one ncu_y2 0,1 2 y nccl fused -x CUT_NAME "$work/ncu_wrap.sh" ;;
    *) echo "unknown round $r" ;;
  esac
  wait
done

python3 - "$jsonl" > "$out/table.txt" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
print("%-16s %4s %5s %8s %7s %6s %8s %9s %9s %9s" % ("run", "gpus", "axis", "transp", "pipe", "exit", "GLUPS", "loop_s", "fluid_psm", "exposed"))
for r in rows:
    ph = r.get("phases") or {}
    def mx(k):
        v = ph.get(k)
        return v.get("max") if isinstance(v, dict) else v
    print("%-16s %4s %5s %8s %7s %6s %8.2f %9s %9s %9s" % (r["run"], r["gpus"], r["axis"], r["transport"], r["pipeline"], r["exit"],
          r.get("glups") or 0, r.get("loop_s"), mx("fluid_psm"), mx("exposed_communication")))
PY
cat "$out/table.txt"
for f in "$out"/ncu_*.csv; do [ -f "$f" ] && { echo "== $f"; grep -i "psm_fused" "$f" | head -20; }; done
