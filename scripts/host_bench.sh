#!/usr/bin/env bash
# The host backend's LBM speed against the host copy bandwidth of the same run, on all cores of the
# machine it runs on: host-only builds (the `host` preset, kernel sources compiled as C++, no MPI, no tests,
# LBDEM_NATIVE as given), then lbdem_bench_lbm --host-only. Used on the GPU machine, whose 16 cores are the
# reference.
#   scripts/host_bench.sh [-B PREFIX] OUTDIR [BASELINE_SRC]
#   PREFIX        the build folders PREFIX_native, PREFIX_generic, PREFIX_base (default /tmp/hb); an existing one
#                 is only rebuilt (scripts/lib.sh lbdem_build)
#   OUTDIR        receives lbm_host_native.json, lbm_host_generic.json (LBDEM_NATIVE=OFF),
#                 lbm_host_baseline.json (BASELINE_SRC built the same way, if given), *.log, lscpu.txt
#   HOST_SIZES3D  D3Q19 edge lengths (default 128,256); HOST_SIZES2D D2Q9 (default 2048)
#   LBDEM_COMMIT  the commit named in the JSON
set -uo pipefail
source "$(dirname "$0")/lib.sh"
prefix=/tmp/hb
[ "${1:-}" = -B ] && { prefix="${2:?-B needs a folder prefix}"; shift 2; }
out="${1:?OUTDIR}"
base="${2:-}"
mkdir -p "$out"
lscpu > "$out/lscpu.txt" 2>&1
build() {  # build SRC DIR NATIVE: lbdem_bench_lbm only; log $out/build_<DIR's name>.log
  LBDEM_SRC="$1" LBDEM_PRESET=host LBDEM_BUILD_LOG="$out/build_$(basename "$2").log" \
    LBDEM_CMAKE_ARGS="-DLBDEM_BUILD_TESTS=OFF -DLBDEM_ENABLE_MPI=OFF -DLBDEM_NATIVE=$3" \
    lbdem_build "$2" lbdem_bench_lbm
}
build "$LBDEM_ROOT" "${prefix}_native" ON & p1=$!
build "$LBDEM_ROOT" "${prefix}_generic" OFF & p2=$!
[ -n "$base" ] && { build "$base" "${prefix}_base" OFF & p3=$!; }
wait $p1; wait $p2
[ -n "$base" ] && wait $p3
export OMP_PROC_BIND=close OMP_PLACES=cores
sizes=(--host-sizes3d "${HOST_SIZES3D:-128,256}" --host-sizes2d "${HOST_SIZES2D:-2048}")
for v in native generic base; do
  exe="${prefix}_$v/bench/lbm/lbdem_bench_lbm"
  [ -x "$exe" ] || continue
  name="$v"; [ "$v" = base ] && name=baseline
  "$exe" --host-only "${sizes[@]}" --out "$out/lbm_host_$name.json" > "$out/lbm_host_$name.log" 2>&1
  echo "== $name"; grep -E "copy bandwidth|^cpu" "$out/lbm_host_$name.log"
done
