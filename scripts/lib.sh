# Shared helpers of the GPU-run scripts: source it, do not run it.
#   source "$(dirname "$0")/lib.sh"
# What it gives:
#   lbdem_env                  the environment every GPU run needs (NCCL without NVLink multicast, passive
#                              OpenMP waits), $OUT created, $LBDEM_COMMIT set, $OUT/env.txt (GPUs, cores, commit)
#   lbdem_build DIR [TARGET...] configure the `cuda` preset (or $LBDEM_PRESET) into DIR, outside the checkout if
#                              you like, and build it (all targets, or the ones named); an existing DIR is reused,
#                              so one build serves every later call on a warm machine. Log: $OUT/build.log
#   gpu_count                  the GPUs of this machine
#   MPIRUN                     an array: mpirun with the flags a one-host GPU run needs (root, no binding, NCCL env)
#   json_line FILE KEY=VALUE...  appends one JSON object to FILE with device, date and commit added; a VALUE that
#                              is a number, true/false/null, or starts with [ or { is written as it is, else quoted
#   tail_log FILE [N]          the last N lines (default 15) of FILE, under a header naming it
# Nothing here changes the GPU's settings.

LBDEM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

lbdem_env() {
  export OUT="${OUT:-$LBDEM_ROOT/out}"
  mkdir -p "$OUT"
  export NCCL_NVLS_ENABLE=0 TORCH_SYMM_MEM_DISABLE_MULTICAST=1 NVSHMEM_DISABLE_NVLS=1
  export OMP_WAIT_POLICY=passive
  export LBDEM_COMMIT="${LBDEM_COMMIT:-$(git -C "$LBDEM_ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)}"
  LBDEM_DEVICE="$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1)"
  export LBDEM_DEVICE="${LBDEM_DEVICE:-host $(nproc) cores}"
  { echo "commit $LBDEM_COMMIT"; date -u +%FT%TZ; nvidia-smi --query-gpu=name,memory.total,clocks.sm,clocks.mem \
      --format=csv 2>/dev/null || echo "no GPU"; echo "cores $(nproc)"; } > "$OUT/env.txt"
}

lbdem_build() {
  local dir="${1:?lbdem_build needs a build folder}"; shift
  local targets=()
  [ $# -gt 0 ] && targets=(--target "$@")
  local t0=$SECONDS
  { [ -f "$dir/build.ninja" ] || (cd "$LBDEM_ROOT" && cmake --preset "${LBDEM_PRESET:-cuda}" -B "$dir"); } \
    >> "$OUT/build.log" 2>&1 &&
    cmake --build "$dir" -j"$(nproc)" "${targets[@]}" >> "$OUT/build.log" 2>&1
  local rc=$?
  echo "build $dir exit $rc in $((SECONDS - t0)) s"
  [ $rc -eq 0 ] || tail -20 "$OUT/build.log"
  return $rc
}

gpu_count() { nvidia-smi -L 2>/dev/null | grep -c '^GPU' || true; }

MPIRUN=(mpirun --allow-run-as-root --oversubscribe --bind-to none -x NCCL_NVLS_ENABLE=0 -x OMP_WAIT_POLICY=passive)

json_line() {
  local file="${1:?json_line needs a file}"; shift
  local out="{" kv k v
  for kv in "$@"; do
    k="${kv%%=*}"; v="${kv#*=}"
    if [[ "$v" =~ ^-?[0-9]+(\.[0-9]+)?([eE][-+]?[0-9]+)?$ || "$v" =~ ^(true|false|null)$ || "$v" == [\[{]* ]]; then
      out+="\"$k\": $v, "
    else
      v="${v//\\/\\\\}"; v="${v//\"/\\\"}"
      out+="\"$k\": \"$v\", "
    fi
  done
  out+="\"device\": \"${LBDEM_DEVICE:-unknown}\", \"date\": \"$(date -u +%F)\", \"commit\": \"${LBDEM_COMMIT:-unknown}\"}"
  echo "$out" >> "$file"
}

tail_log() { echo "--- ${1}"; tail -n "${2:-15}" "$1" 2>/dev/null; }
