#!/usr/bin/env bash
# The host backend's LBM speed against the host copy bandwidth of the same run, on all cores of the
# machine it runs on: host-only builds (kernel sources compiled as C++, LBDEM_NATIVE as given), then
# lbdem_bench_lbm --host-only. Used on the GPU machine, whose 16 cores are the reference.
#   scripts/host_bench.sh OUTDIR [BASELINE_SRC]
#   OUTDIR        receives lbm_host_native.json, lbm_host_generic.json (LBDEM_NATIVE=OFF),
#                 lbm_host_baseline.json (BASELINE_SRC built the same way, if given), *.log, lscpu.txt
#   HOST_SIZES3D  D3Q19 edge lengths (default 128,256); HOST_SIZES2D D2Q9 (default 2048)
#   LBDEM_COMMIT  the commit named in the JSON
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:?OUTDIR}"
base="${2:-}"
mkdir -p "$out"
lscpu > "$out/lscpu.txt" 2>&1
build() {  # build SRC DIR NATIVE
  cmake -S "$1" -B "$2" -G Ninja -DCMAKE_BUILD_TYPE=Release -DLBDEM_ENABLE_CUDA=OFF -DLBDEM_BUILD_TESTS=OFF \
    -DLBDEM_ENABLE_MPI=OFF -DLBDEM_NATIVE="$3" > "$out/build_$(basename "$2").log" 2>&1 &&
    cmake --build "$2" -j16 --target lbdem_bench_lbm >> "$out/build_$(basename "$2").log" 2>&1
}
build "$here" /tmp/hb_native ON & p1=$!
build "$here" /tmp/hb_generic OFF & p2=$!
[ -n "$base" ] && { build "$base" /tmp/hb_base OFF & p3=$!; }
wait $p1; echo "build native: $?"; wait $p2; echo "build generic: $?"
[ -n "$base" ] && { wait $p3; echo "build baseline: $?"; }
export OMP_PROC_BIND=close OMP_PLACES=cores
sizes=(--host-sizes3d "${HOST_SIZES3D:-128,256}" --host-sizes2d "${HOST_SIZES2D:-2048}")
for v in native generic base; do
  exe="/tmp/hb_$v/bench/lbm/lbdem_bench_lbm"
  [ -x "$exe" ] || continue
  name="$v"; [ "$v" = base ] && name=baseline
  "$exe" --host-only "${sizes[@]}" --out "$out/lbm_host_$name.json" > "$out/lbm_host_$name.log" 2>&1
  echo "== $name"; grep -E "copy bandwidth|^cpu" "$out/lbm_host_$name.log"
done
