#!/usr/bin/env bash
# Fixed-sphere drag error map over d/l x tau for the PSM weightings (bench/imb/NOTES.md, "Where the PSM
# wall sits", "One rule for every tau"): the rule (noble_torczynski_wall, "ntw") and the classic NT
# weighting ("nt"), both with Lambda auto (imb::psm_magic_auto: by d/l and tau; 1e-4 below d/l 16 and
# 3e-2 from 16 as tau -> 1/2), NEBB, sphere centre on a cell centre, chi = 0.5, Re_p 0.2, against
# Sangani & Acrivos (1982); and the dense array, chi 0.8685 (phi 0.343, spheres nearly touching), against
# Zick & Homsy (1982). One JSON, one heat-map PNG per weighting.
#
#   scripts/drag_map.sh BIN OUTDIR PART...     PART: host | host-hi | host-2d | gpu-a | gpu-b | gpu-c | gpu-d | gpu-e | gpu-lam | merge | plot
#
#   BIN     lbdem_bench_psm (host build for `host`, the CUDA build for the gpu parts)
#   OUTDIR  receives drag_map_<part>_<k>.{json,md,log}; each JSON is rewritten after every run, so a
#           part cut off by its time limit keeps the rows it finished; merge writes OUTDIR/drag_map.json,
#           plot OUTDIR/drag_map_<weight>.png
#   env     DRAG_MAP_LIMIT (s per part, default 520: one device call of at most 9 minutes)
#
# host    d/l 4, 6, 8, 10 x tau {0.505 ... 1.0}: ntw and nt exact fp64, ntw table fp64; the plane-wall
#         runs (lbdem_bench_psm wall); the dense array, chi = (6 phi / pi)^(1/3) at Zick & Homsy's
#         phi 0.343, L = 5, 7, 9, 12 (d = chi L: d/l 4.34, 6.08, 7.82, 10.42) x tau {0.505 ... 1.0}, ntw
#         exact fp64. About 20 min of one CPU core (the dense array: 1 min).
# host-hi d/l 4, 6, 8, 10 x tau {1.25, 1.5} (the shipped suspensions run at tau 1.24): ntw exact fp64,
#         chi 0.5. About 10 min of one CPU core.
# host-2d fixed disks in square arrays (D2Q9; the 2D map, bench/results/drag_map_2d_host.md): d/l 8, 10, 16,
#         20 x tau {0.52, 0.6, 0.8, 1.0, 1.25, 1.5} at chi 0.3 and d/l 8 ... 30 at chi 0.5, the disk centre on a
#         cell corner and on a cell centre: ntw exact fp64, against Sangani & Acrivos's square arrays of
#         cylinders; and the shipped 2D suspensions' point (d/l 10, tau 0.86928) exact and table, fp64 and
#         fp32. Two sweeps side by side, one thread each (OMP_NUM_THREADS=1): about 25 min on 2 CPU cores.
# gpu-a   d/l 16, 20, 30 x every tau: ntw exact fp64, nt exact fp64; ntw table fp64 and exact fp32 at
#         d/l 16 and 20 (fp32 is not a validation precision past d/l 20). About 7 min on an H200.
# gpu-b   d/l 50 x tau 0.52 ... 1.0: ntw exact fp64. About 4 min on an H200.
# gpu-c   d/l 50 at tau 0.505: ntw exact fp64 (5.2e6 steps). About 8 min on an H200.
# gpu-d   the rule above tau 1 and where d/l >= 16 has no row yet: d/l 16, 20, 30 x tau {1.5, 1.25, 1.0,
#         0.8, 0.6} and d/l 50 x tau {1.5, 1.25, 1.0, 0.8}: ntw exact fp64. About 6 min on an H100/H200.
# gpu-e   the rule (issue 29's Lambda table to d/l 50 and tau 1.5) where d/l >= 16: d/l 16, 20, 30, 50 x tau
#         {1.5, 1.25, 1.0, 0.8, 0.6}: ntw exact fp64. About 1.5 min on an H200.
# gpu-lam the gpu-e points at 0.6 and 1.6 times the rule's Lambda (the slope that re-centres the table).
#         About 2.5 min on an H200.
# merge   every OUTDIR/drag_map_*.json (sweep rows) into OUTDIR/drag_map.json.
# plot    scripts/plot_drag_map.py OUTDIR/drag_map.json OUTDIR (needs python3-matplotlib).
#
# GPU (the lead's device calls, one part each):
#   scripts/drag_map.sh build-cuda/bench/imb/lbdem_bench_psm $OUT gpu-a
#   scripts/drag_map.sh build-cuda/bench/imb/lbdem_bench_psm $OUT gpu-b
#   scripts/drag_map.sh build-cuda/bench/imb/lbdem_bench_psm $OUT gpu-c
#   scripts/drag_map.sh build-cuda/bench/imb/lbdem_bench_psm $OUT gpu-d
# then, here: copy the JSONs beside the host ones and run `merge plot`.
set -uo pipefail
if [ $# -lt 3 ]; then sed -n 2,46p "$0"; exit 2; fi
bin="$1"
out="$2"
shift 2
parts=("$@")
here="$(cd "$(dirname "$0")/.." && pwd)"
mkdir -p "$out"

TAUS=0.505,0.52,0.55,0.6,0.7,0.8,0.9,1.0
t0=$SECONDS
limit=${DRAG_MAP_LIMIT:-520}

# run NAME BACKEND SECONDS_CAP ARGS...: one sweep, stopped at the part's deadline or its own cap.
run() {
  local name="$1" backend="$2" cap="$3"
  shift 3
  local left=$((limit - (SECONDS - t0)))
  [ "$left" -gt "$cap" ] && left=$cap
  if [ "$left" -lt 10 ]; then echo "$name: skipped (part time limit)"; return; fi
  timeout "$left" "$bin" sweep --backend "$backend" --re 0.2 --tol 1e-5 --start estimate --offset 0.5 \
    --chi 0.5 --collisions trt --variants nebb --magic auto "$@" --out "$out/$name.json" > "$out/$name.md" 2> "$out/$name.log"
  local rc=$?
  echo "$name: exit $rc ($((SECONDS - t0)) s into the part)"
  grep '^| [0-9]' "$out/$name.md" | cut -d'|' -f2-13 | sed 's/^/  /'
}

for p in "${parts[@]}"; do
  t0=$SECONDS
  [ "$p" = merge ] || [ "$p" = plot ] || [ -x "$bin" ] || { echo "drag_map: $bin is not an executable"; exit 2; }
  case "$p" in
    host)
      limit=${DRAG_MAP_LIMIT:-3300}
      "$bin" wall --out "$out/plane_wall.json" --magic 1e-4 > "$out/plane_wall.md" 2>&1
      echo "plane walls: $out/plane_wall.md"
      # Fast (large tau) first: a cut-off run keeps the rows it finished.
      run drag_map_host_1 host 900 --d 4,6,8 --tau 1.0,0.9,0.8,0.7,0.6,0.55,0.52,0.505 --weights ntw,nt \
        --methods exact --precisions fp64
      run drag_map_host_2 host 900 --d 10 --tau 1.0,0.9,0.8,0.7,0.6,0.55,0.52,0.505 --weights ntw,nt \
        --methods exact --precisions fp64
      run drag_map_host_3 host 600 --d 4,6,8,10 --tau 1.0,0.9,0.8,0.6,0.52 --weights ntw --methods table \
        --precisions fp64
      # The dense array: d = chi L for an integer period L (the reference holds at that chi only).
      run drag_map_host_dense host 900 --chi 0.8684907 --d 4.342453,6.079435,7.816416,10.421888 --offset centre \
        --tau 1.0,0.9,0.8,0.7,0.6,0.55,0.52,0.505 --weights ntw --methods exact --precisions fp64
      ;;
    host-hi)
      limit=${DRAG_MAP_LIMIT:-3300}
      run drag_map_host_hi host 3300 --d 4,6,8,10 --tau 1.5,1.25 --weights ntw --methods exact --precisions fp64
      ;;
    host-2d)
      limit=${DRAG_MAP_LIMIT:-3300}
      export OMP_NUM_THREADS=1
      two=(--dim 2 --offset 0,0.5 --tau 0.52,0.6,0.8,1.0,1.25,1.5 --weights ntw --methods exact --precisions fp64)
      run drag_map_2d_chi05 host 3300 "${two[@]}" --chi 0.5 --d 8,10,16,20,30 &
      run drag_map_2d_chi03 host 3300 "${two[@]}" --chi 0.3 --d 8,10,16,20
      wait
      run drag_map_2d_suspension host 300 --dim 2 --chi 0.3 --offset 0,0.5 --d 10 --tau 0.86928 --weights ntw \
        --methods exact,table --precisions fp64,fp32
      ;;
    gpu-d)
      run drag_map_gpu_d1 cuda 200 --d 16,20,30 --tau 1.5,1.25,1.0,0.8,0.6 --weights ntw --methods exact --precisions fp64
      run drag_map_gpu_d2 cuda 300 --d 50 --tau 1.5,1.25,1.0,0.8 --weights ntw --methods exact --precisions fp64
      ;;
    gpu-e)
      run drag_map_gpu_e1 cuda 60 --d 16,20,30 --tau 1.5,1.25,1.0,0.8,0.6 --weights ntw --methods exact --precisions fp64
      run drag_map_gpu_e2 cuda 90 --d 50 --tau 1.5,1.25,1.0,0.8,0.6 --weights ntw --methods exact --precisions fp64
      ;;
    gpu-lam)
      run drag_map_gpu_lam1 cuda 80 --d 16,20,30 --tau 1.5,1.25,1.0,0.8,0.6 --weights ntw --methods exact \
        --precisions fp64 --magic "auto*0.6,auto*1.6"
      run drag_map_gpu_lam2 cuda 120 --d 50 --tau 1.5,1.25,1.0,0.8 --weights ntw --methods exact --precisions fp64 \
        --magic "auto*0.6,auto*1.6"
      ;;
    gpu-a)
      run drag_map_gpu_a1 cuda 240 --d 16,20,30 --tau "$TAUS" --weights ntw --methods exact --precisions fp64
      run drag_map_gpu_a2 cuda 120 --d 16,20 --tau "$TAUS" --weights ntw --methods table --precisions fp64
      run drag_map_gpu_a3 cuda 80 --d 16,20 --tau "$TAUS" --weights ntw --methods exact --precisions fp32
      run drag_map_gpu_a4 cuda 240 --d 16,20,30 --tau 1.0,0.8,0.6,0.52 --weights nt --methods exact --precisions fp64
      ;;
    gpu-b)
      run drag_map_gpu_b1 cuda 520 --d 50 --tau 1.0,0.8,0.7,0.6,0.55,0.52 --weights ntw --methods exact \
        --precisions fp64
      ;;
    gpu-c)
      run drag_map_gpu_c1 cuda 520 --d 50 --tau 0.505 --weights ntw --methods exact --precisions fp64
      ;;
    merge)
      /usr/bin/python3 - "$out" <<'PY' && echo "merge: $out/drag_map.json" || echo "merge: failed"
import glob, json, os, sys
out = sys.argv[1]
head, rows = None, []
for f in sorted(glob.glob(os.path.join(out, "drag_map_*.json"))):
    j = json.load(open(f))
    head = head or {k: v for k, v in j.items() if k not in ("rows", "device", "backend")}
    rows += [dict(r, source=os.path.basename(f), device=j.get("device")) for r in j.get("rows", [])]
json.dump(dict(head or {}, rows=rows), open(os.path.join(out, "drag_map.json"), "w"), indent=1)
PY
      ;;
    plot)
      /usr/bin/python3 "$here/scripts/plot_drag_map.py" "$out/drag_map.json" "$out" || echo "plot: failed (python3-matplotlib missing?)"
      ;;
    *) echo "drag_map: unknown part $p (host, host-hi, host-2d, gpu-a, gpu-b, gpu-c, gpu-d, gpu-e, gpu-lam, merge, plot)"; exit 2 ;;
  esac
done
