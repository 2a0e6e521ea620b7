#!/usr/bin/env bash
# Where a bed's step spends its GPU time, kernel by kernel, and what the pressure solve's tolerance costs (issue 28),
# on one GPU, without nsys (Nsight Compute's duration metric only):
#
#   scripts/bed_profile_gpu.sh BUILD_DIR [PART...]     PART: profile | tolerance | variants (default: the first two)
#
#   profile    each bed (Mueller 0.9 m/s, Link) for SKIP_STEPS + PROFILE_STEPS gas steps under
#              `ncu --metrics gpu__time_duration.sum` (no cache flush, no clock lock: the kernels as they run), the
#              kernels of about the last PROFILE_STEPS gas steps profiled one by one (ncu serialises them, so the
#              sum is the GPU's busy time without the gaps between launches). The pressure solve runs polled
#              (LBDEM_PRESSURE_DEVICE_LOOP=0: the same kernels, outside a WHILE node, which ncu may not enter).
#              Per kernel: launches per gas step, mean and total microseconds per gas step (gas steps counted by
#              the gas step's first kernel, GasFraction). The same bed without ncu and with LBDEM_STEP_PHASES=1
#              gives the wall time of the gas step and of the DEM sub-steps per gas step: wall minus busy is
#              what launches and waits cost.
#   tolerance  each bed for TOL_STEPS gas steps at gas.pressure_solver.tolerance 1e-10 (the default), 1e-8, 1e-6:
#              seconds per simulated second and the mean multigrid-CG iterations (series.csv cg_iterations).
#   variants   each bed as shipped for TOL_STEPS gas steps under each environment of VARIANTS (default: as
#              shipped; the pressure V-cycle's one-block tail from 2048, 512, 128 cells or none
#              (LBDEM_PRESSURE_TAIL_CELLS: the same bits); the DEM force kernel with 1 and 8 lanes
#              (LBDEM_DEM_FORCE_LANES: rounding only)): seconds per simulated second, into variants.jsonl.
#
# env GPU (default 0), SKIP_STEPS (default 300), PROFILE_STEPS (default 4), TOL_STEPS (default 1500),
#     LAUNCHES_PER_STEP (ncu's skip and count per gas step, default 420 Mueller / 250 Link; an estimate: the bed runs
#     3 x SKIP_STEPS gas steps, and the gas steps profiled are counted, not assumed).
# Output under $OUT/bed_profile: kernels_<bed>.jsonl (one line per kernel name, sorted by time), profile.jsonl (one
# line per bed: busy and wall ms per gas step), tolerance.jsonl, variants.jsonl, logs. About 3-4 min after the
# build for profile + tolerance, ~2 min for the default variants.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?usage: scripts/bed_profile_gpu.sh BUILD_DIR [profile|tolerance|variants ...]}"
shift
parts="${*:-profile tolerance}"
g="${GPU:-0}"
lbdem_env
out="$OUT/bed_profile"
mkdir -p "$out"
lbdem_build "$build" lbdem || exit 1
build="$(realpath "$build")"
exe="$build/cases/lbdem"
ncu_bin="$(command -v ncu || echo /usr/local/cuda/bin/ncu)"

# yaml CASE NAME STEPS [TOL]: CASE for STEPS gas steps, no snapshots but the first, statistics from 0.3 s / 0.1 s.
yaml() {
  local f="$out/$2.yaml"
  sed -e "s/^time: {end\(_time\)\?: [0-9.e+-]*}/time: {steps: $3}/" \
    -e "s/^output: {directory: \([^,]*\), interval: [0-9]*/output: {directory: \1, interval: 0/" \
    "$LBDEM_ROOT/cases/$1" > "$f"
  if [ -n "${4:-}" ]; then
    if grep -q "pressure_solver: {type: multigrid, tolerance:" "$f"; then
      sed -i "s/pressure_solver: {type: multigrid, tolerance: [0-9.e+-]*/pressure_solver: {type: multigrid, tolerance: $4/" "$f"
    else
      sed -i "s/pressure_solver: {type: multigrid/pressure_solver: {type: multigrid, tolerance: $4/" "$f"
    fi
    grep -q "tolerance: $4" "$f" || { echo "could not set the tolerance in $f" >&2; return 1; }
  fi
  echo "$f"
}
get() { grep -o "\"$1\": [^,}]*" "$2" | head -1 | sed 's/^[^:]*: //; s/"//g'; }

profile_bed() {
  local name="$1" case="$2" per="$3"
  # Three times the skipped steps: an estimate of launches per step that is off by up to 2x still lands inside.
  local steps=$((3 * ${SKIP_STEPS:-300} + ${PROFILE_STEPS:-4}))
  local y; y="$(yaml "$case" "$name" "$steps")" || return
  local skip=$((${SKIP_STEPS:-300} * per)) count=$((${PROFILE_STEPS:-4} * per))
  CUDA_VISIBLE_DEVICES="$g" LBDEM_PRESSURE_DEVICE_LOOP=0 timeout -s TERM -k 20 240 "$ncu_bin" \
    --metrics gpu__time_duration.sum --cache-control none --clock-control none --csv --print-units base \
    --launch-skip "$skip" --launch-count "$count" --log-file "$out/ncu_$name.csv" \
    "$exe" run "$y" --backend cuda --output "$out/run_$name" --overwrite --quiet > "$out/ncu_$name.log" 2>&1
  echo "$name under ncu: exit $?"
  # Wall time of the gas step and of the DEM sub-steps, the same configuration without the tool.
  CUDA_VISIBLE_DEVICES="$g" LBDEM_PRESSURE_DEVICE_LOOP=0 LBDEM_STEP_PHASES=1 timeout -s TERM -k 20 120 "$exe" run "$y" \
    --backend cuda --output "$out/ph_$name" --overwrite --quiet > "$out/ph_$name.log" 2>&1
  local l; l="$(grep -a '^step phases:' "$out/ph_$name.log" | tail -1)"
  python3 - "$out/ncu_$name.csv" "$out/kernels_$name.jsonl" "$out/profile.jsonl" "$name" "$l" <<'EOF'
import csv, json, re, sys
src, kout, pout, name, phases = sys.argv[1:6]
rows = []
with open(src, newline="") as f:
    lines = [l for l in f if l.startswith('"')]
for r in csv.DictReader(lines):
    if r.get("Metric Name") != "gpu__time_duration.sum":
        continue
    k = r["Kernel Name"].replace("(anonymous namespace)::", "").replace("<unnamed>::", "")
    m = re.search(r"for_each_kernel<([^>(]*)", k) or re.search(r"<(?:lbdem::)?([^,<>()]+)", k)
    short = (m.group(1) if m else k.split("(")[0]).split("::")[-1].strip()
    base = k.split("(")[0].split("<")[0].split("::")[-1]
    rows.append((f"{base}:{short}" if m else base, float(r["Metric Value"].replace(",", "")) * 1e-3))  # ns -> us
steps = sum(1 for n, _ in rows if n.endswith(":GasFraction")) or 1
agg = {}
for n, t in rows:
    a = agg.setdefault(n, [0, 0.0])
    a[0] += 1; a[1] += t
busy = sum(a[1] for a in agg.values()) / steps
with open(kout, "w") as o:
    for n, (c, t) in sorted(agg.items(), key=lambda kv: -kv[1][1]):
        o.write(json.dumps({"bed": name, "kernel": n, "launches_per_gas_step": round(c / steps, 2),
                            "us_mean": round(t / c, 2), "us_per_gas_step": round(t / steps, 1),
                            "share": round(t / steps / busy, 4) if busy else None}) + "\n")
m = re.search(r"\(([0-9.e+-]+) and ([0-9.e+-]+) ms per step", phases)
gas, dem = (float(m.group(1)), float(m.group(2))) if m else (None, None)
line = {"bed": name, "gas_steps_profiled": steps, "kernels_profiled": len(rows), "busy_ms_per_gas_step": round(busy / 1e3, 4),
        "wall_gas_ms_per_step": gas, "wall_dem_ms_per_step": dem,
        "busy_over_wall": round(busy / 1e3 / (gas + dem), 3) if gas else None}
open(pout, "a").write(json.dumps(line) + "\n")
print(json.dumps(line))
with open(kout) as f:
    for i, l in enumerate(f):
        if i < 14: print("  " + l.strip())
EOF
  find "$out/run_$name" "$out/ph_$name" -type f \( -name 'checkpoint*' -o -name '*.h5' -o -name '*.xdmf' \) -delete 2> /dev/null
}

tolerance_bed() {
  local name="$1" case="$2" tol="$3"
  local y; y="$(yaml "$case" "${name}_tol$tol" "${TOL_STEPS:-1500}" "$tol")" || return
  CUDA_VISIBLE_DEVICES="$g" timeout -s TERM -k 20 200 "$exe" run "$y" --backend cuda --output "$out/t_${name}_$tol" \
    --overwrite --quiet > "$out/t_${name}_$tol.log" 2>&1
  local rc=$? s="$out/t_${name}_$tol/summary.json" c="$out/t_${name}_$tol/series.csv"
  [ -f "$s" ] || { echo "$name tol $tol: exit $rc, no summary"; tail -5 "$out/t_${name}_$tol.log"; return; }
  local it; it="$(awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == "cg_iterations") c = i; next }
                     NR > 2 && c { s += $c; n++ } END { if (n) printf "%.2f", s / n }' "$c")"
  json_line "$out/tolerance.jsonl" bed="$name" tolerance="$tol" exit="$rc" gas_steps="$(get gas_steps "$s")" \
    s_per_simulated_s="$(get seconds_per_simulated_second "$s")" mean_cg_iterations="$it" \
    dp_over_weight="$(get mean_pressure_drop_over_weight "$s")"
  tail -1 "$out/tolerance.jsonl"
  find "$out/t_${name}_$tol" -type f \( -name 'checkpoint*' -o -name '*.h5' -o -name '*.xdmf' \) -delete 2> /dev/null
}

variant_bed() {
  local name="$1" case="$2" v="$3" tag
  tag="$(echo "$v" | sed 's/LBDEM_//; s/[^A-Za-z0-9=]/_/g')"
  local y; y="$(yaml "$case" "${name}_v" "${TOL_STEPS:-1500}")" || return
  CUDA_VISIBLE_DEVICES="$g" env $v timeout -s TERM -k 20 200 "$exe" run "$y" --backend cuda \
    --output "$out/v_${name}_$tag" --overwrite --quiet > "$out/v_${name}_$tag.log" 2>&1
  local rc=$? s="$out/v_${name}_$tag/summary.json"
  [ -f "$s" ] || { echo "$name $v: exit $rc, no summary"; tail -5 "$out/v_${name}_$tag.log"; return; }
  json_line "$out/variants.jsonl" bed="$name" variant="$v" exit="$rc" gas_steps="$(get gas_steps "$s")" \
    s_per_simulated_s="$(get seconds_per_simulated_second "$s")" dem_force_lanes="$(get dem_force_lanes "$s")" \
    pressure_tolerance="$(get pressure_tolerance "$s")"
  tail -1 "$out/variants.jsonl"
  find "$out/v_${name}_$tag" -type f \( -name 'checkpoint*' -o -name '*.h5' -o -name '*.xdmf' \) -delete 2> /dev/null
}

for p in $parts; do
  case "$p" in
    profile)
      profile_bed muller fluidized_bed_muller_u09.yaml "${LAUNCHES_PER_STEP:-420}"
      profile_bed link fluidized_bed_link_spout.yaml "${LAUNCHES_PER_STEP:-250}" ;;
    tolerance)
      for t in 1e-10 1e-8 1e-6; do tolerance_bed muller fluidized_bed_muller_u09.yaml "$t"; done
      for t in 1e-10 1e-8 1e-6; do tolerance_bed link fluidized_bed_link_spout.yaml "$t"; done ;;
    variants)
      vs="${VARIANTS:-LBDEM_NONE=0 LBDEM_PRESSURE_TAIL_CELLS=512 LBDEM_PRESSURE_TAIL_CELLS=128 LBDEM_PRESSURE_TAIL_CELLS=0 LBDEM_DEM_FORCE_LANES=1 LBDEM_DEM_FORCE_LANES=8}"
      for v in $vs; do variant_bed muller fluidized_bed_muller_u09.yaml "$v"; done
      for v in $vs; do variant_bed link fluidized_bed_link_spout.yaml "$v"; done ;;
    *) echo "unknown part $p (profile | tolerance | variants)"; exit 2 ;;
  esac
done
