#!/usr/bin/env bash
# The first paper's two suspensions at full size on one GPU (issue 16): memory (estimate by `lbdem check`
# and the peak nvidia-smi sees), coupled MLUPS against fluid-only MLUPS on the same grid, fp32 and fp64.
#   3D (512 x 2016 x 512, 129,024 spheres): lbdem_bench_psm suspension --dims 512,2016,512 with the case's
#      lattice parameters (tau 1.23856, density ratio 692.3, table fractions): fluid-only and coupled on the
#      same grid in one process, the phase split of the coupled step.
#   2D (15360 x 61440, 1,166,400 disks): `lbdem run cases/suspension/suspension_2d.yaml` for STEPS2D steps
#      (output.final false: its fields would be tens of GB), and lbdem_bench_lbm D2Q9 at 30720^2 (the same
#      number of cells) for the fluid-only speed.
#   scripts/suspension_fullsize_gpu.sh [build]     results in $OUT/fullsize (fullsize.jsonl, logs, JSON)
#   PRECS (default "fp32 fp64"), STEPS3D (default 100), STEPS2D (default 100), LBDEM_COMMIT.
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out="${OUT:-$here/out}/fullsize"
mkdir -p "$out"
build="$here/build-gpu"
commit="${LBDEM_COMMIT:-$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)}"
if [ "${1:-}" = build ]; then
  (cd "$here" && cmake --preset cuda && cmake --build build-gpu -j16 --target lbdem lbdem_bench_psm lbdem_bench_lbm) \
    > "$out/build.log" 2>&1 || { echo "build failed: $out/build.log"; exit 1; }
fi
lbdem="$build/cases/lbdem"
psm="$build/bench/imb/lbdem_bench_psm"
lbmb="$build/bench/lbm/lbdem_bench_lbm"
peak_pid=""
start_peak() {  # samples the device memory in use every 50 ms into $1
  (while :; do nvidia-smi --query-gpu=memory.used --format=csv,noheader,nounits -i 0; sleep 0.05; done) > "$1" 2>/dev/null &
  peak_pid=$!
}
stop_peak() { kill "$peak_pid" 2>/dev/null; wait "$peak_pid" 2>/dev/null; sort -n "$1" | tail -1; }
device="$(nvidia-smi --query-gpu=name --format=csv,noheader | head -1)"
for prec in ${PRECS:-fp32 fp64}; do
  # 3D: estimate of the SI case, then the bench on its grid.
  sed "s/precision: fp32/precision: $prec/" "$here/cases/suspension/suspension_3d.yaml" > "$out/suspension_3d_$prec.yaml"
  "$lbdem" check "$out/suspension_3d_$prec.yaml" > "$out/check_3d_$prec.log" 2>&1
  start_peak "$out/mem_3d_$prec.txt"
  "$psm" suspension --dims 512,2016,512 --tau 1.23856 --fraction table --substeps 10 --precision "$prec" --steps "${STEPS3D:-100}" \
    --backend cuda --out "$out/bench_3d_$prec.json" > "$out/bench_3d_$prec.log" 2>&1
  rc=$?
  peak=$(stop_peak "$out/mem_3d_$prec.txt")
  python3 - "$out/bench_3d_$prec.json" "$out/check_3d_$prec.log" "$prec" "$rc" "$peak" "$device" "$commit" >> "$out/fullsize.jsonl" <<'PY'
import json, re, sys
path, check, prec, rc, peak, device, commit = sys.argv[1:]
row = {"case": "3d", "precision": prec, "exit": int(rc), "device": device, "commit": commit, "peak_device_mib": float(peak or 0)}
m = re.search(r"total\s+([\d.]+) B/cell\s+([\d.]+) (MiB|GiB)", open(check).read())
if m:
    row["estimate_bytes_per_cell"] = float(m.group(1))
    row["estimate_mib"] = float(m.group(2)) * (1024 if m.group(3) == "GiB" else 1)
try:
    b = json.load(open(path))
    for k in ("particles", "fluid_mlups", "coupled_mlups", "coupled_over_fluid", "substeps", "dem_seconds_per_step",
              "map_seconds", "psm_step_seconds", "fluid_step_seconds", "fluid_fraction_of_copy", "fluid_finite"):
        row[k] = b.get(k)
    cells = 512 * 2016 * 512
    row["seconds_per_simulated_second"] = cells / (b["coupled_mlups"] * 1e6) / 6.0e-7
except Exception as e:
    row["error"] = str(e)
print(json.dumps(row))
PY
  tail -1 "$out/fullsize.jsonl"
  # 2D: the SI case itself for STEPS2D steps, no final output.
  sed -e "s/precision: fp32/precision: $prec/" -e "s/^output: {/output: {final: false, /" \
    "$here/cases/suspension/suspension_2d.yaml" > "$out/suspension_2d_$prec.yaml"
  "$lbdem" check "$out/suspension_2d_$prec.yaml" > "$out/check_2d_$prec.log" 2>&1
  start_peak "$out/mem_2d_$prec.txt"
  "$lbdem" run "$out/suspension_2d_$prec.yaml" --backend cuda --steps "${STEPS2D:-100}" --output "$out/run_2d_$prec" \
    --overwrite > "$out/run_2d_$prec.log" 2>&1
  rc=$?
  peak=$(stop_peak "$out/mem_2d_$prec.txt")
  "$lbmb" --sizes2d 30720 --host-sizes2d 256 --lattices D2Q9 --precisions "$prec" --streaming aa --out "$out/lbm_2d_$prec.json" \
    > "$out/lbm_2d_$prec.log" 2>&1
  python3 - "$out/run_2d_$prec/summary.json" "$out/check_2d_$prec.log" "$out/lbm_2d_$prec.json" "$prec" "$rc" "$peak" \
    "$device" "$commit" >> "$out/fullsize.jsonl" <<'PY'
import json, re, sys
path, check, lbm, prec, rc, peak, device, commit = sys.argv[1:]
row = {"case": "2d", "precision": prec, "exit": int(rc), "device": device, "commit": commit, "peak_device_mib": float(peak or 0)}
m = re.search(r"total\s+([\d.]+) B/cell\s+([\d.]+) (MiB|GiB)", open(check).read())
if m:
    row["estimate_bytes_per_cell"] = float(m.group(1))
    row["estimate_mib"] = float(m.group(2)) * (1024 if m.group(3) == "GiB" else 1)
try:
    s = json.load(open(path))
    row.update({"particles": s["particles"], "steps": s["steps"], "seconds": s["seconds"],
                "coupled_mlups": s["coupled_mlups"], "memory_bytes_per_cell": s.get("memory_bytes_per_cell"),
                "seconds_per_simulated_second": s["seconds"] / (s["steps"] * s["conversion"]["dt_s"])})
except Exception as e:
    row["error"] = str(e)
try:
    text = open(lbm).read()
    b = json.loads(text)
    runs = [r for r in b.get("runs", b.get("results", [])) if isinstance(r, dict)]
    if runs:
        row["fluid_mlups_30720sq"] = max(r.get("mlups", 0) for r in runs)
        if row.get("coupled_mlups"):
            row["coupled_over_fluid"] = row["coupled_mlups"] / row["fluid_mlups_30720sq"]
except Exception as e:
    row["lbm_error"] = str(e)
print(json.dumps(row))
PY
  tail -1 "$out/fullsize.jsonl"
done
