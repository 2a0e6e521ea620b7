#!/usr/bin/env bash
# The first paper's two suspensions at full size on one GPU (issue 16): memory (estimate by `lbdem check`
# and the peak nvidia-smi sees), coupled MLUPS against fluid-only MLUPS on the same grid, fp32 and fp64.
#   3D (512 x 2016 x 512, 129,024 spheres): lbdem_bench_psm suspension --dims 512,2016,512 with the case's
#      lattice parameters (tau 1.23856, density ratio 692.3, table fractions): fluid-only and coupled on the
#      same grid in one process, the phase split of the coupled step.
#   2D (15360 x 61440, 1,166,400 disks): `lbdem run cases/suspension/suspension_2d.yaml` for STEPS2D steps
#      (output.final false: its fields would be tens of GB), and lbdem_bench_lbm D2Q9 at 30720^2 (the same
#      number of cells) for the fluid-only speed.
#   scripts/suspension_fullsize_gpu.sh [-B DIR] [build]     results in $OUT/fullsize (fullsize.jsonl, logs, JSON)
#     -B DIR   the build folder (default $LBDEM_BUILD, else build-gpu/); lbdem, lbdem_bench_psm and
#              lbdem_bench_lbm are built there first (scripts/lib.sh lbdem_build; `build` is accepted, not needed)
#   PRECS (default "fp32 fp64"), STEPS3D (default 100), STEPS2D (default 100), LBDEM_COMMIT.
# One line of fullsize.jsonl per case and precision, with device, date and commit.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
[ "${1:-}" = -B ] && { LBDEM_BUILD="${2:?-B needs a build folder}"; shift 2; }
[ "${1:-}" = build ] && shift
export OUT="${OUT:-$LBDEM_ROOT/out}/fullsize"
lbdem_env
here="$LBDEM_ROOT"
out="$OUT"
build="$LBDEM_BUILD"
lbdem_build "$build" lbdem lbdem_bench_psm lbdem_bench_lbm || { echo "build failed: $out/build.log"; exit 1; }
lbdem="$build/cases/lbdem"
psm="$build/bench/imb/lbdem_bench_psm"
lbmb="$build/bench/lbm/lbdem_bench_lbm"

# row CASE PREC EXIT SAMPLES CHECK_LOG RESULT_JSON [LBM_JSON]: one line of fullsize.jsonl from the run's JSON
# (3d: the bench's; 2d: summary.json, with the fluid-only bench LBM_JSON beside it) and the estimate of its check.
row() {
  python3 - "$1" "$2" "$3" "$(sort -n "$4" | tail -1)" "$5" "$6" "${7:-}" "$LBDEM_DEVICE" "$LBDEM_COMMIT" \
    >> "$out/fullsize.jsonl" <<'PY'
import datetime, json, re, sys
case, prec, rc, peak, check, result, lbm, device, commit = sys.argv[1:]
row = {"case": case, "precision": prec, "exit": int(rc), "device": device, "commit": commit,
       "date": datetime.date.today().isoformat(), "peak_device_mib": float(peak or 0)}
m = re.search(r"total\s+([\d.]+) B/cell\s+([\d.]+) (MiB|GiB)", open(check).read())
if m:
    row["estimate_bytes_per_cell"] = float(m.group(1))
    row["estimate_mib"] = float(m.group(2)) * (1024 if m.group(3) == "GiB" else 1)
try:
    r = json.load(open(result))
    if case == "3d":
        for k in ("particles", "fluid_mlups", "coupled_mlups", "coupled_over_fluid", "substeps", "dem_seconds_per_step",
                  "map_seconds", "psm_step_seconds", "fluid_step_seconds", "fluid_fraction_of_copy", "fluid_finite"):
            row[k] = r.get(k)
        cells, dt_s = 512 * 2016 * 512, 6.0e-7  # the grid of --dims and the case's time.dt
        row["seconds_per_simulated_second"] = cells / (r["coupled_mlups"] * 1e6) / dt_s
    else:
        row.update({"particles": r["particles"], "steps": r["steps"], "seconds": r["seconds"],
                    "coupled_mlups": r["coupled_mlups"], "memory_bytes_per_cell": r.get("memory_bytes_per_cell"),
                    "seconds_per_simulated_second": r["seconds"] / (r["steps"] * r["conversion"]["dt_s"])})
except Exception as e:
    row["error"] = str(e)
if lbm:
    try:
        b = json.load(open(lbm))
        runs = [x for x in b.get("runs", b.get("results", [])) if isinstance(x, dict)]
        if runs:
            row["fluid_mlups_30720sq"] = max(x.get("mlups", 0) for x in runs)
            if row.get("coupled_mlups"):
                row["coupled_over_fluid"] = row["coupled_mlups"] / row["fluid_mlups_30720sq"]
    except Exception as e:
        row["lbm_error"] = str(e)
print(json.dumps(row))
PY
  tail -1 "$out/fullsize.jsonl"
}

for prec in ${PRECS:-fp32 fp64}; do
  # 3D: estimate of the SI case, then the bench on its grid.
  sed "s/precision: fp32/precision: $prec/" "$here/cases/suspension/suspension_3d.yaml" > "$out/suspension_3d_$prec.yaml"
  "$lbdem" check "$out/suspension_3d_$prec.yaml" > "$out/check_3d_$prec.log" 2>&1
  gpu_peak_mib "$out/mem_3d_$prec.txt" "$psm" suspension --dims 512,2016,512 --tau 1.23856 --fraction table \
    --substeps 10 --precision "$prec" --steps "${STEPS3D:-100}" --backend cuda --out "$out/bench_3d_$prec.json" \
    > "$out/bench_3d_$prec.log" 2>&1
  row 3d "$prec" $? "$out/mem_3d_$prec.txt" "$out/check_3d_$prec.log" "$out/bench_3d_$prec.json"
  # 2D: the SI case itself for STEPS2D steps, no final output; then the fluid-only bench on as many cells.
  sed -e "s/precision: fp32/precision: $prec/" -e "s/^output: {/output: {final: false, /" \
    "$here/cases/suspension/suspension_2d.yaml" > "$out/suspension_2d_$prec.yaml"
  "$lbdem" check "$out/suspension_2d_$prec.yaml" > "$out/check_2d_$prec.log" 2>&1
  gpu_peak_mib "$out/mem_2d_$prec.txt" "$lbdem" run "$out/suspension_2d_$prec.yaml" --backend cuda \
    --steps "${STEPS2D:-100}" --output "$out/run_2d_$prec" --overwrite > "$out/run_2d_$prec.log" 2>&1
  rc=$?
  "$lbmb" --sizes2d 30720 --host-sizes2d 256 --lattices D2Q9 --precisions "$prec" --streaming aa \
    --out "$out/lbm_2d_$prec.json" > "$out/lbm_2d_$prec.log" 2>&1
  row 2d "$prec" $rc "$out/mem_2d_$prec.txt" "$out/check_2d_$prec.log" "$out/run_2d_$prec/summary.json" \
    "$out/lbm_2d_$prec.json"
done
