#!/usr/bin/env bash
# Fluid-only scaling sweep with lbdem_bench_scaling on the GPUs of this machine.
#   scripts/scaling_gpu.sh BUILD OUT_JSONL [quick]
#     BUILD  a build folder: lbdem_bench_scaling is built there first (scripts/lib.sh lbdem_build; the `cuda`
#            preset if new), so the folder of scripts/gpu_run.sh -B serves
# For 1 .. G ranks (G = the GPUs here, one rank per GPU) and, on a one-GPU
# machine, 2 ranks sharing it (communication measured, not scaling): D3Q19
# fp32 and fp64, strong scaling of 256^3 and 512^3 total and weak scaling of
# 512^3 per rank (256^3 in quick mode), every transport that can run.
# One JSON object per line; a transport that cannot run here logs why (OUT_JSONL.log).
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?build dir}"
out="${2:?output .jsonl}"
quick="${3:-}"
lbdem_env
g=$(gpu_count)
[ "$g" -ge 1 ] || { echo "no GPU"; exit 1; }
mkdir -p "$(dirname "$out")"
LBDEM_BUILD_LOG="$(dirname "$out")/build.log" lbdem_build "$build" lbdem_bench_scaling || exit 1
b="$build/bench/scaling/lbdem_bench_scaling"
counts="$(seq 1 "$g")"
[ "$g" -eq 1 ] && counts="1 2"
sizes="256 512"; weak=512; steps=200
[ "$quick" = quick ] && { sizes="256"; weak=256; steps=100; }
run() {  # ranks transport args...
  local n="$1" t="$2"; shift 2
  timeout 120 "${MPIRUN[@]}" -x OMP_NUM_THREADS=2 -np "$n" "$b" --transport "$t" --steps "$steps" "$@" \
    >> "$out" 2>> "$out.log"
  echo "ranks $n transport $t $* exit $?" >> "$out.log"
}
for prec in fp32 fp64; do
  for n in $counts; do
    for t in host_mpi device_mpi nccl; do
      [ "$n" -eq 1 ] && [ "$t" != host_mpi ] && continue  # one rank: no exchange
      for s in $sizes; do run "$n" "$t" --grid "$s" "$s" "$s" --precision "$prec"; done
      run "$n" "$t" --per-rank "$weak" "$weak" "$weak" --precision "$prec"
    done
  done
done
grep -c . "$out" | sed 's/^/runs: /'
