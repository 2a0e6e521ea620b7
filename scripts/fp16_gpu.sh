#!/usr/bin/env bash
# 16-bit population storage (precision fp16s / fp16c) on a GPU machine: speed beside error, against fp32 and
# fp64 in the same run. Everything goes to $OUT (default ./out/fp16): logs, JSON, and summary.md.
#
#   scripts/fp16_gpu.sh [-B DIR] [STEP...]    (default: build speed errors drag suspension summary)
#     -B DIR      the build folder (default $LBDEM_BUILD, else build-gpu/; scripts/lib.sh)
#     build       configure the `cuda` preset (sm_90, Release) into it if new and build the targets below; the
#                 compile time of the kernel objects per precision goes to build_times.txt (ninja's log)
#     speed       lbdem_bench_lbm: D3Q19 256^3 fp16s / fp16c / fp32 (A-A and two-lattice) with the device copy
#                 bandwidth measured in the same run; Taylor-Green error of each run beside its speed
#     errors      the 16-bit storage tests on both backends (tests/lbm/test_fp16_storage.cpp: Taylor-Green 2D/3D,
#                 Poiseuille against the rounding model, every boundary kind, mass drift over 1e5 steps; the halo
#                 exchange in 16 bits; tests/imb/test_psm_fp16.cpp: PSM forces against fp64, both pipelines)
#     drag        fixed-sphere drag (Sangani & Acrivos) at d/l 10 and 20, fp64 / fp32 / fp16s / fp16c, at tau 0.52
#                 (the accurate fp64 setting) and 0.8 (where 16-bit storage stalls less: lbm/storage_checks.hpp)
#     suspension  the coupled suspension (256^3, phi 0.128, d/l 10): coupled against fluid-only speed per precision
#                 (lbdem_bench_psm suspension), and the slip velocity (particles' mean v_y minus the fluid's) and
#                 the fluid's mass change from cases/suspension.yaml run to 4000 steps per precision
#     summary     summary.md from the JSON above
#   Env: LIMIT_DRAG (s, default 420) bounds the drag step; SUSP_STEPS (default 4000).
set -uo pipefail
source "$(dirname "$0")/lib.sh"
[ "${1:-}" = -B ] && { LBDEM_BUILD="${2:?-B needs a build folder}"; shift 2; }
export OUT="${OUT:-$LBDEM_ROOT/out}/fp16"
lbdem_env
here="$LBDEM_ROOT"
build="$(realpath -m "$LBDEM_BUILD")"

step_build() {
  lbdem_build "$build" lbdem lbdem_bench_lbm lbdem_bench_psm lbm_tests imb_tests core_tests
  local rc=$?
  # Compile time (ms) of each kernel translation unit, the last entry per object in ninja's log.
  awk -F'\t' '!/^#/ && $4 ~ /(solver_d|psm_).*\.cu\.o$/ {t[$4] = $2 - $1} END {for (o in t) printf "%8d ms  %s\n", t[o], o}' \
    "$build/.ninja_log" | sort -k3 > "$OUT/build_times.txt"
  awk '{ms = $1; if ($3 ~ /f16/) a += ms; else b += ms} END {printf "kernel TUs: 16-bit %.0f s, fp32/fp64 %.0f s (CPU time, one core each)\n", a / 1000, b / 1000}' \
    "$OUT/build_times.txt" | tee -a "$OUT/build_times.txt"
  return $rc
}

step_speed() {
  timeout 400 "$build/bench/lbm/lbdem_bench_lbm" --lattices D3Q19 --precisions fp16s,fp16c,fp32 \
    --streaming aa,two_lattice --sizes3d 256 --host-sizes3d 128 --out "$OUT/lbm_fp16.json" > "$OUT/lbm_fp16.log" 2>&1
  echo "speed exit $?"
  grep '^|' "$OUT/lbm_fp16.log"
}

step_errors() {
  timeout 500 "$build/tests/lbm/lbm_tests" --gtest_filter='*Fp16*:*fp16*' > "$OUT/errors.log" 2>&1
  echo "errors exit $?"
  grep -E '^(TG|Poiseuille|mass)|PASSED|FAILED' "$OUT/errors.log"
  timeout 300 "$build/tests/imb/imb_tests" --gtest_filter='*PsmFp16*' > "$OUT/errors_psm.log" 2>&1
  echo "PSM errors exit $?"
  grep -E '(cpu|cuda) (mapped|fused)|PASSED|FAILED' "$OUT/errors_psm.log"
  timeout 120 "$build/tests/core/core_tests" --gtest_filter='Half.*' > "$OUT/half.log" 2>&1
  echo "half-format tests exit $?"
}

step_drag() {
  local t0=$SECONDS lim=${LIMIT_DRAG:-420} tau left
  for tau in 0.8 0.52; do
    left=$((lim - (SECONDS - t0)))
    [ "$left" -lt 20 ] && { echo "drag tau $tau: skipped (time limit)"; continue; }
    timeout "$left" "$build/bench/imb/lbdem_bench_psm" sweep --backend cuda --d 10,20 --tau "$tau" --magic auto \
      --methods exact --precisions fp64,fp32,fp16s,fp16c --re 0.2 --tol 1e-5 --start estimate \
      --out "$OUT/drag_tau$tau.json" > "$OUT/drag_tau$tau.md" 2> "$OUT/drag_tau$tau.log"
    echo "drag tau $tau exit $?"
    grep '^| [0-9]' "$OUT/drag_tau$tau.md"
  done
}

step_suspension() {
  local p psm="$build/bench/imb/lbdem_bench_psm"
  mkdir -p "$OUT/suspension"
  for p in fp16s fp16c fp32 fp64; do
    timeout 90 "$psm" suspension --n 256 --steps 100 --precision $p --fraction table --pipeline fused \
      --out "$OUT/suspension/speed_$p.json" >> "$OUT/suspension_speed.log" 2>&1
    echo "suspension speed $p exit $?"
  done
  grep -A1 '^suspension' "$OUT/suspension_speed.log"
  # Settling: the shipped small suspension, one run per precision; series.csv holds the particles' mean velocity.
  for p in fp64 fp32 fp16s fp16c; do
    sed -e "s/^fluid: {\(.*\)}/fluid: {\1, precision: $p}/" -e "s/^time: .*/time: {steps: ${SUSP_STEPS:-4000}}/" \
      "$here/cases/suspension.yaml" > "$OUT/suspension/suspension_$p.yaml"
    timeout 150 "$build/cases/lbdem" run "$OUT/suspension/suspension_$p.yaml" --backend cuda --quiet --overwrite \
      --output "$OUT/suspension/run_$p" > "$OUT/suspension/run_$p.log" 2>&1
    echo "suspension run $p exit $?"
  done
}

step_summary() {
  python3 - "$OUT" "$LBDEM_COMMIT" <<'EOF'
import json, csv, glob, os, sys
out, commit = sys.argv[1], sys.argv[2]
L = [f"# 16-bit population storage: speed and error (commit {commit})", ""]
env = open(os.path.join(out, "env.txt")).read().strip().splitlines()  # commit, date, nvidia-smi CSV, cores
L += ["Device: " + " / ".join(env[2:4]) + f"; lbdem_bench_lbm device: {json.load(open(os.path.join(out, 'lbm_fp16.json'))).get('device', '?') if os.path.exists(os.path.join(out, 'lbm_fp16.json')) else '?'}", ""]
try:
    j = json.load(open(os.path.join(out, "lbm_fp16.json")))
    cb = ", ".join(f"{k} {v:.0f} GB/s" for k, v in j.get("copy_bandwidth_GBs", {}).items())
    L += ["## D3Q19 fluid step (lbdem_bench_lbm, same run as the copy bandwidth)", "", f"Copy bandwidth: {cb}.", "",
          "| backend | precision | streaming | cells | GLUPS | GB/s | % of copy | Taylor-Green rel. L2 |", "|---|---|---|---|---|---|---|---|"]
    for r in j["runs"]:
        L.append(f"| {r['backend']} | {r['precision']} | {r['streaming']} | {'x'.join(map(str, r['cells']))} | "
                 f"{r['mlups'] / 1e3:.3g} | {r['GBs']:.4g} | {100 * r['fraction_of_copy']:.1f} | {r['taylor_green_rel_l2']:.2e} |")
    L.append("")
except Exception as e:
    L += [f"(speed: {e})", ""]
for tau in ("0.8", "0.52"):
    f = os.path.join(out, f"drag_tau{tau}.json")
    if not os.path.exists(f):
        continue
    try:
        j = json.load(open(f))
        L += [f"## Fixed-sphere drag, tau {tau} (Sangani & Acrivos; lbdem_bench_psm sweep)", "",
              "| d/l | precision | K | error % | steps | converged |", "|---|---|---|---|---|---|"]
        for r in j["rows"]:
            e = r.get("error")
            L.append(f"| {r.get('d')} | {r.get('precision')} | {r.get('K')} | {100 * e if isinstance(e, (int, float)) else e} | "
                     f"{r.get('steps')} | {r.get('converged')} |")
        L.append("")
    except Exception as e:
        L += [f"(drag tau {tau}: {e})", ""]
import re
rows = []
for p in ("fp64", "fp32", "fp16s", "fp16c"):
    f = os.path.join(out, "suspension", f"run_{p}", "series.csv")
    y = os.path.join(out, "suspension", f"suspension_{p}.yaml")
    sp = os.path.join(out, "suspension", f"speed_{p}.json")
    slip, drift = "", ""
    if os.path.exists(f) and os.path.exists(y):
        m = re.search(r"cells:\s*\[([^\]]*)\]", open(y).read())
        cells = 1
        for v in m.group(1).split(","):
            cells *= int(v)
        data = list(csv.DictReader(open(f)))
        half = data[len(data) // 2:]
        if half:
            # slip: particles' mean velocity minus the fluid's mean velocity (momentum per cell, rho ~ 1)
            slip = sum(float(r["mean_vy"]) - float(r["fluid_momentum_y"]) / cells for r in half) / len(half)
            drift = float(data[-1]["fluid_mass_rel_change"])
    speed = ""
    if os.path.exists(sp):
        s = json.load(open(sp))
        speed = f"{s['fluid_mlups']:.0f} | {s['coupled_mlups']:.0f} | {100 * s['coupled_over_fluid']:.1f}"
    rows.append((p, slip, drift, speed))
L += ["## Coupled suspension", "",
      "Slip velocity: the particles' mean v_y minus the fluid's mean v_y (lattice units), averaged over the second "
      "half of cases/suspension.yaml run per precision; mass change of the fluid at the end. Speed: lbdem_bench_psm "
      "suspension, 256^3, phi 0.128, d/l 10, table fractions, fused pipeline.", "",
      "| precision | slip v_y | rel. to fp64 | fluid mass change | fluid-only MLUPS | coupled MLUPS | coupled / fluid % |",
      "|---|---|---|---|---|---|---|"]
ref = rows[0][1] if rows and rows[0][1] != "" else None
for p, slip, drift, speed in rows:
    rel = f"{(slip - ref) / ref:+.2e}" if ref not in (None, 0) and slip != "" else ""
    ss = f"{slip:.5e}" if slip != "" else ""
    ds = f"{drift:.2e}" if drift != "" else ""
    L.append(f"| {p} | {ss} | {rel} | {ds} | {speed if speed else ' | '} |")
L.append("")
for f in ("build_times.txt",):
    p = os.path.join(out, f)
    if os.path.exists(p):
        L += ["## Kernel build times", "", "```", open(p).read().rstrip(), "```", ""]
open(os.path.join(out, "summary.md"), "w").write("\n".join(L) + "\n")
print("\n".join(L))
EOF
}

steps=("$@")
[ ${#steps[@]} -eq 0 ] && steps=(build speed errors drag suspension summary)
for s in "${steps[@]}"; do
  case "$s" in
    build) step_build ;;
    speed) step_speed ;;
    errors) step_errors ;;
    drag) step_drag ;;
    suspension) step_suspension ;;
    summary) step_summary ;;
    *) echo "unknown step $s (valid: build speed errors drag suspension summary)"; exit 2 ;;
  esac
done
