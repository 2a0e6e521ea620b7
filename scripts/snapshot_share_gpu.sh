#!/usr/bin/env bash
# The snapshot's share of the run for the first paper's 3D suspension (cases/suspension/suspension_3d.yaml:
# 512 x 2016 x 512 cells, 129,024 spheres, fp32 fields, output.interval 5000; issue 27, bar 5 %) on 1 and 4
# GPUs of one host, with output.background off (each rank writes its pieces in the foreground, slab by slab)
# and on (the owned box packed on the device, one copy to page-locked host memory, a writer thread):
#   scripts/snapshot_share_gpu.sh BUILD_DIR
# Each run steps STEPS (200) steps with snapshots at step 0 and at the end (the shipped output settings); its
# summary.json gives a JSON line in $OUT/snapshot_share/share.jsonl with:
#   snapshot_s            one snapshot's wall time in the run's loop (max over ranks; background: the device
#                         pack and copy plus any wait for the previous write);
#   interval_s            the stepping time of the shipped interval (5000 steps at this run's speed);
#   share_measured        snapshot_s / interval_s (background: the first snapshot's write may still run when
#                         the last one comes after only STEPS steps, so its wait is counted: pessimistic);
#   background_copy_s, background_write_s   per snapshot: what holds the run, and the writer thread's time;
#   share_shipped         background: (copy + max(0, write - interval_s)) / interval_s, the share at the
#                         shipped interval, where the write overlaps 5000 steps; foreground: share_measured.
# Needs: 4 GPUs for the 4-GPU runs (fewer: those are skipped). Time on 4 H200s: 4 runs of ~25-45 s (set-up ~5 s,
# 200 steps 2-7 s, two snapshots of 10.6 GB in all: fp32 fields, 20 B per cell), about 3 minutes after the build.
# Environment: STEPS (200), WORK (run folders, removed after each run; default /tmp/lbdem_snapshot_share),
# OUT (results; default ./out). Writes $OUT/snapshot_share/{share.jsonl, table.txt, <run>.log,
# <run>.summary.json}; never field files.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
lbdem_env
build="${1:?usage: scripts/snapshot_share_gpu.sh BUILD_DIR}"
lbdem_build "$build" lbdem || exit 1
out="$OUT/snapshot_share"
mkdir -p "$out"
jsonl="$out/share.jsonl"
work="${WORK:-/tmp/lbdem_snapshot_share}"
mkdir -p "$work"
lbdem="$build/cases/lbdem"
steps="${STEPS:-200}"
G=$(gpu_count)
[ "$G" -ge 1 ] || { echo "no GPU"; exit 1; }
t0=$SECONDS

# The paper's case with output.background set to $1.
case_with() {
  local f="$work/suspension_3d_bg_$1.yaml"
  sed -E "s/^output: \{/output: {background: $1, /" "$LBDEM_ROOT/cases/suspension/suspension_3d.yaml" > "$f"
  echo "$f"
}

# run N BACKGROUND: one run on N GPUs; its figures to a JSON line.
run() {
  local n="$1" bg="$2" name="snap_${1}gpu_bg_${2}"
  local yaml
  yaml=$(case_with "$bg")
  rm -rf "${work:?}/$name"
  local t=$SECONDS
  timeout 240 "${MPIRUN[@]}" -np "$n" "$lbdem" run "$yaml" --backend cuda --steps "$steps" --output "$work/$name" \
    --quiet > "$out/$name.log" 2>&1
  local rc=$? wall=$((SECONDS - t))
  cp "$work/$name/summary.json" "$out/$name.summary.json" 2>/dev/null
  python3 - "$work/$name/summary.json" "$n" "$bg" "$rc" "$wall" >> "$jsonl" <<'PY'
import json, sys
path, n, bg, rc, wall = sys.argv[1:]
row = {"kind": "snapshot_share", "gpus": int(n), "background": bg == "true", "exit": int(rc), "wall_s": int(wall)}
try:
    s = json.load(open(path))
except Exception:
    row["error"] = "no summary"
    print(json.dumps(row))
    sys.exit()
t, o = s.get("timing", {}), s.get("output", {})
steps = s.get("steps", 0) - s.get("restarted_from_step", 0)
loop = t.get("loop_seconds", s.get("seconds", 0))
nsnap = max(o.get("snapshots", 0), 1)
if row["background"]:
    # In the loop a snapshot holds the run for its pack and copy and any wait for the previous write;
    # the final drain (after the loop) is the writer's time, not the loop's.
    held = o.get("background_copy_seconds", 0) + o.get("background_wait_seconds", 0)
else:
    held = t.get("output_seconds", {}).get("max", o.get("seconds", 0))
stepping = max(loop - held, 1e-9)
interval = 5000 * stepping / steps if steps else float("nan")
snap = held / nsnap
row.update({"steps": steps, "snapshots": o.get("snapshots"), "loop_s": loop, "stepping_s": stepping,
            "snapshot_s": snap, "interval_s": interval, "share_measured": snap / interval,
            "glups": s.get("coupled_mlups", 0) / 1e3})
if row["background"]:
    copy = o.get("background_copy_seconds", 0) / nsnap
    write = o.get("background_write_seconds", 0) / nsnap
    row.update({"background_copy_s": copy, "background_wait_s": o.get("background_wait_seconds", 0) / nsnap,
                "background_write_s": write, "share_shipped": (copy + max(0.0, write - interval)) / interval})
else:
    row["share_shipped"] = row["share_measured"]
mem = s.get("memory_bytes", {})
row["snapshot_pack_bytes"] = mem.get("snapshot pack (output.background)", 0)
print(json.dumps(row))
PY
  echo "$name: exit $rc in $wall s: $(tail -1 "$jsonl")"
  [ "$rc" -eq 0 ] || tail -5 "$out/$name.log"
  rm -rf "${work:?}/$name"
}

for n in 1 4; do
  [ "$n" -le "$G" ] || { echo "skipped $n GPUs: $G here"; continue; }
  run "$n" false
  run "$n" true
done

python3 - "$jsonl" <<'PY' | tee "$out/table.txt"
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
print("%4s %10s %8s %9s %10s %9s %9s %9s %9s" % ("GPUs", "background", "GLUPS", "snap s", "interval s", "copy s",
                                                "write s", "measured", "shipped"))
for r in rows:
    if r.get("exit", 1) != 0 or "share_measured" not in r:
        print("%4d %10s failed" % (r["gpus"], r["background"]))
        continue
    print("%4d %10s %8.2f %9.2f %10.1f %9s %9s %8.2f%% %8.2f%%" % (
        r["gpus"], r["background"], r["glups"], r["snapshot_s"], r["interval_s"],
        "%.2f" % r["background_copy_s"] if "background_copy_s" in r else "-",
        "%.2f" % r["background_write_s"] if "background_write_s" in r else "-",
        100 * r["share_measured"], 100 * r["share_shipped"]))
print("one snapshot's hold on the run over 5000 steps of stepping (the shipped interval); bar 5 %")
PY
echo "total $((SECONDS - t0)) s; results in $out"
