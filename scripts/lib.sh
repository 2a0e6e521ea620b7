# shellcheck shell=bash
# Shared helpers of the GPU-run scripts: source it, do not run it.
#   source "$(dirname "$0")/lib.sh"
# Build folder: every script that builds takes it as `-B DIR` (first argument; else $LBDEM_BUILD, else build-gpu/,
# the `cuda` preset's own folder), so one device build serves every script on a warm machine.
# What it gives:
#   lbdem_env                  the environment every GPU run needs (NCCL without NVLink multicast, passive
#                              OpenMP waits), $OUT created, $LBDEM_COMMIT and $LBDEM_DEVICE set, $OUT/env.txt
#                              (commit, date, GPUs, cores)
#   lbdem_build DIR [TARGET...] configure the `cuda` preset (or $LBDEM_PRESET) into DIR and build it (all targets,
#                              or the ones named); an existing DIR is only rebuilt, so one build serves every later
#                              call. $LBDEM_SRC: another source tree (default this checkout); $LBDEM_CMAKE_ARGS:
#                              extra configure arguments; log: $LBDEM_BUILD_LOG (default $OUT/build.log)
#   gpu_count                  the GPUs of this machine
#   MPIRUN                     an array: mpirun with the flags a one-host GPU run needs (root, no binding, NCCL env)
#   json_line FILE KEY=VALUE...  appends one JSON object to FILE with device, date and commit added; a VALUE that
#                              is a number, true/false/null, or starts with [ or { is written as it is, else quoted
#   gpu_peak_mib FILE CMD...   runs CMD while sampling the device memory in use (GPU 0, every 20 ms) into FILE;
#                              returns CMD's exit code; `sort -n FILE | tail -1` is then the peak in MiB
#   plot_python                prints the first python3 that has matplotlib, h5py and numpy (nothing if none)
#   tail_log FILE [N]          the last N lines (default 15) of FILE, under a header naming it
# Nothing here changes the GPU's settings.

LBDEM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
LBDEM_BUILD="${LBDEM_BUILD:-$LBDEM_ROOT/build-gpu}"  # a script's `-B DIR` replaces it

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
  dir="$(realpath -m "$dir")"  # configure runs in the source tree: a relative DIR means the caller's folder
  local src="${LBDEM_SRC:-$LBDEM_ROOT}" log="${LBDEM_BUILD_LOG:-$OUT/build.log}" targets=() extra=()
  [ $# -gt 0 ] && targets=(--target "$@")
  read -r -a extra <<< "${LBDEM_CMAKE_ARGS:-}"
  local t0=$SECONDS
  { [ -f "$dir/build.ninja" ] || (cd "$src" && cmake --preset "${LBDEM_PRESET:-cuda}" -B "$dir" "${extra[@]}"); } \
    >> "$log" 2>&1 &&
    cmake --build "$dir" -j"$(nproc)" "${targets[@]}" >> "$log" 2>&1
  local rc=$?
  echo "build $dir exit $rc in $((SECONDS - t0)) s"
  [ $rc -eq 0 ] || tail -20 "$log"
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

gpu_peak_mib() {
  local file="${1:?gpu_peak_mib needs a file}"; shift
  (while :; do nvidia-smi --query-gpu=memory.used --format=csv,noheader,nounits -i 0; sleep 0.02; done) \
    > "$file" 2>/dev/null &
  local sampler=$!
  "$@"
  local rc=$?
  kill "$sampler" 2>/dev/null
  wait "$sampler" 2>/dev/null
  return $rc
}

plot_python() {
  local p
  for p in python3 /usr/bin/python3; do
    "$p" -c 'import matplotlib, h5py, numpy' 2>/dev/null && { echo "$p"; return 0; }
  done
  return 0
}

tail_log() { echo "--- ${1}"; tail -n "${2:-15}" "$1" 2>/dev/null; }
