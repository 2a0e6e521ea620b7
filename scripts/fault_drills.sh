#!/usr/bin/env bash
# Fault drills of a run on several ranks: what happens when one rank dies, a checkpoint write is cut off, one rank
# lacks memory, the disk fills. Each drill starts real `mpirun -np N lbdem run` processes, does the harm, and checks
# the outcome the README promises.
#   scripts/fault_drills.sh BUILD_DIR [--backend cpu|cuda] [--ranks N] [DRILL...]
#     BUILD_DIR  a build holding cases/lbdem (built first with scripts/lib.sh's lbdem_build when it has none)
#     --backend  cpu (default; CPU ranks, any machine) or cuda (GPU ranks: one GPU per rank, the local rank's)
#     --ranks    ranks of every run (default 4; at least 2)
#     DRILL      any of kill_rank ckpt_interrupt ckpt_cadence ckpt_counts oom_rank disk_full (default: all six)
#   DRILL_CELLS    cells per axis of the drills' 3D Taylor-Green case (default 24 on cpu, 128 on cuda)
#   DRILL_DISK     tmpfs | fsize | auto (default auto: tmpfs where this process may mount one, else fsize)
#   DRILL_KILL_S   the most seconds the surviving ranks may take to end after one rank is killed (default 30)
#   DRILL_KEEP=1   keep the drills' folders (cases, logs, runs) under $TMPDIR
# The drills (each one JSON line in $OUT/fault_drills.jsonl: name, expected, observed, pass, seconds):
#   kill_rank       SIGKILL to the last rank after the run's second checkpoint: mpirun ends non-zero within
#                   DRILL_KILL_S s, its message names the lost rank, the checkpoint under the final name is
#                   whole, and a restart from it on the same ranks to one interval further ends bit for bit in the
#                   checkpoint of a straight run to that step
#   ckpt_interrupt  a checkpoint after every step (rank 0 writes one file, the others send their parts); SIGKILL of
#                   every rank at random moments, five rounds, each restarted: after each kill the checkpoint under
#                   the final name is whole (trailer and length) and no older than the last one seen; the last
#                   restart ends bit for bit in the straight run's checkpoint. Reports how many kills caught a
#                   temporary in the folder (a write in progress)
#   ckpt_cadence    checkpoint.interval 100 with the default diagnostics interval (1000): the checkpoints seen while
#                   the run goes (four polled, within 40 s) include a step that is not a multiple of 1000: the fluid
#                   scenes end a step chunk at every multiple of checkpoint.interval
#   oom_rank        the last rank short of memory: cpu: that rank alone runs with `--memory 16MiB` (the cap a
#                   scheduler's per-process limit sets) below what its piece needs; cuda: a helper process holds
#                   all but 1 GiB of that rank's GPU. Exit code 4 within 30 s, the refusal names the memory and the rank
#   disk_full       the first half of a run writes normally (snapshots, the checkpoint of step 20); its restart
#                   then meets a full disk when the ranks write their first snapshot pieces:
#                   tmpfs: a small tmpfs mounted for the drill (needs root and mount rights), filled by a file
#                   of the user's up to a quarter of one piece;
#                   fsize: every rank but rank 0 under a file-size limit of a quarter of a piece (RLIMIT_FSIZE,
#                   SIGXFSZ ignored, so a write past it fails with EFBIG as a full disk's fails with ENOSPC);
#                   rank 0 (which writes the checkpoint) without one.
#                   Exit 4 within 120 s, one line naming the file, the user's files and the earlier snapshots
#                   unchanged, the checkpoint of step 20 whole, every snapshot under a final name readable (h5py,
#                   where python3 has it)
# Prints one line per drill; exit status 0 when every drill passed. Time: ~2 min on 2 shared CPU cores
# (cpu, 24^3); ~3 min on 4 GPUs (cuda, 128^3).
set -uo pipefail
source "$(dirname "$0")/lib.sh"
lbdem_env
build="${1:?usage: scripts/fault_drills.sh BUILD_DIR [--backend cpu|cuda] [--ranks N] [DRILL...]}"
shift
backend=cpu ranks=4 drills=()
while [ $# -gt 0 ]; do
  case "$1" in
    --backend) backend="$2"; shift 2 ;;
    --ranks) ranks="$2"; shift 2 ;;
    kill_rank|ckpt_interrupt|ckpt_cadence|ckpt_counts|oom_rank|disk_full) drills+=("$1"); shift ;;
    *) echo "fault_drills: unknown argument '$1'"; exit 2 ;;
  esac
done
[ ${#drills[@]} -gt 0 ] || drills=(kill_rank ckpt_interrupt ckpt_cadence ckpt_counts oom_rank disk_full)
[ "$ranks" -ge 2 ] || { echo "fault_drills: --ranks must be at least 2"; exit 2; }
build="$(realpath -m "$build")"
exe="$build/cases/lbdem"
[ -x "$exe" ] || lbdem_build "$build" lbdem || exit 1
cells="${DRILL_CELLS:-$([ "$backend" = cuda ] && echo 128 || echo 24)}"
kill_limit="${DRILL_KILL_S:-30}"
jsonl="$OUT/fault_drills.jsonl"
work="$(mktemp -d "${TMPDIR:-/tmp}/lbdem_drills.XXXXXX")"
mounted=""
cleanup() {
  [ -n "$mounted" ] && umount "$mounted" 2>/dev/null
  if [ "${DRILL_KEEP:-0}" = 1 ]; then echo "fault_drills: kept $work"; else rm -rf "$work"; fi
}
trap cleanup EXIT
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"
all_ok=1

# The case: 3D Taylor-Green in fp64 (a flow that changes every population every step, so a wrong restart shows).
# case_file NAME STEPS CKPT_INTERVAL OUTPUT_INTERVAL [DIAG_INTERVAL]: DIAG_INTERVAL (default: the checkpoint
# interval, else the scene's 1000) is given because the fluid scenes check a checkpoint's cadence only where
# their step chunks end (diagnostics and output; see ckpt_cadence).
case_file() {
  local f="$work/$1.yaml"
  cat > "$f" <<EOF
scene: taylor_green
lattice: D3Q19
precision: fp64
streaming: aa
collision: {model: trt, tau: 0.8}
fluid: {density: 1.0, kinematic_viscosity: 1.0e-6}
domain: {cells: [$cells, $cells, $cells], spacing: 1.5625e-5}
taylor_green: {velocity: 1.0e-3}
time: {steps: $2}
output: {interval: $4}
diagnostics: {interval: ${5:-$([ "$3" -gt 0 ] && echo "$3" || echo 1000)}}
checkpoint: {interval: $3}
parallel: {decomposition: [1, 1, $ranks]}
EOF
  echo "$f"
}

# launch LOG PIDDIR [PREFIX...] -- LBDEM_ARGS...: mpirun -np $ranks in the background, each rank through a shell that
# writes its pid to PIDDIR/<rank> and then becomes lbdem (PREFIX: a command every rank runs under); sets $mpi_pid.
launch() {
  local log="$1" piddir="$2"; shift 2
  mkdir -p "$piddir"
  "${MPIRUN[@]}" -np "$ranks" bash -c 'echo $$ > "$0/${OMPI_COMM_WORLD_RANK:-${PMIX_RANK:-0}}"; shift; exec "$@"' \
    "$piddir" _ "$exe" "$@" --backend "$backend" --quiet > "$log" 2>&1 &
  mpi_pid=$!
}

# ckpt_step FILE: the step in a checkpoint's header when the file is whole (magic, trailer, the trailer's length
# = the bytes before it), else -1. The checksum is the restart's to check.
ckpt_step() {
  python3 - "$1" <<'PY' 2>/dev/null || echo -1
import os, struct, sys
p = sys.argv[1]
try:
    size = os.path.getsize(p)
    with open(p, "rb") as f:
        head = f.read(20)
        if head[:8] != b"LBDEMCKP": raise ValueError
        n = struct.unpack("<Q", head[12:20])[0]
        text = f.read(n).decode()
        f.seek(size - 24)
        tail = f.read(24)
    if tail[:8] != b"LBDEMEND" or struct.unpack("<Q", tail[8:16])[0] != size - 24: raise ValueError
    step = [l.split("=", 1)[1] for l in text.splitlines() if l.startswith("step=")]
    print(int(step[0]))
except Exception:
    print(-1)
PY
}

# wait_ckpt FILE STEP SECONDS PID: waits until FILE holds a whole checkpoint of at least STEP (0) or PID ended or
# the time is up (1).
wait_ckpt() {
  local t_end=$((SECONDS + $3))
  while [ $SECONDS -lt $t_end ]; do
    kill -0 "$4" 2>/dev/null || return 1
    [ -f "$1" ] && [ "$(ckpt_step "$1")" -ge "$2" ] && return 0
    sleep 0.05
  done
  return 1
}

# wait_exit PID LIMIT_S: waits for PID (a child) at most LIMIT_S s; sets $rc (its exit code, or 124 and the process
# group killed when it had not ended) and $took (seconds, two decimals).
wait_exit() {
  local t0 t1
  t0=$(date +%s.%N)
  local t_end=$((SECONDS + $2))
  while kill -0 "$1" 2>/dev/null && [ $SECONDS -lt "$t_end" ]; do sleep 0.02; done
  t1=$(date +%s.%N)
  took=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }')
  if kill -0 "$1" 2>/dev/null; then
    kill -9 "$1" 2>/dev/null
    wait "$1" 2>/dev/null
    rc=124
  else
    wait "$1"
    rc=$?
  fi
}

# report NAME PASS EXPECTED OBSERVED SECONDS LOG
report() {
  json_line "$jsonl" name="fault_drill_$1" backend="$backend" ranks="$ranks" cells="$cells" expected="$3" \
    observed="$4" pass="$2" seconds="$5"
  echo "drill $1: $([ "$2" = true ] && echo PASS || echo FAIL): $4 ($5 s)"
  if [ "$2" != true ]; then
    all_ok=0
    [ -n "${6:-}" ] && tail_log "$6" 12
  fi
}

# straight STEPS: the straight run of the drills' case on $ranks ranks (checkpoint at the end only); its checkpoint.
straight() {
  local d="$work/straight_$1"
  if [ ! -f "$d/checkpoint.lbdem" ]; then
    "${MPIRUN[@]}" -np "$ranks" "$exe" run "$(case_file "straight_$1" "$1" "$1" 0)" --backend "$backend" --quiet \
      --output "$d" > "$work/straight_$1.log" 2>&1 || { tail_log "$work/straight_$1.log"; return 1; }
  fi
  echo "$d/checkpoint.lbdem"
}

drill_kill_rank() {
  local every=$((cells >= 128 ? 200 : 100)) d="$work/kill" t0=$SECONDS
  # Planned far beyond the kill; the restart goes one checkpoint interval past the checkpoint it starts from.
  launch "$work/kill.log" "$work/kill_pids" run "$(case_file kill 100000000 "$every" 0)" --output "$d"
  if ! wait_ckpt "$d/checkpoint.lbdem" $((2 * every)) 300 "$mpi_pid"; then
    wait_exit "$mpi_pid" 1
    report kill_rank false "the run reaches its second checkpoint" "it ended first (exit $rc)" $((SECONDS - t0)) \
      "$work/kill.log"
    return
  fi
  local victim=$((ranks - 1))
  kill -9 "$(cat "$work/kill_pids/$victim")"
  wait_exit "$mpi_pid" "$kill_limit"
  local ended_in="$took" kill_rc="$rc" named=false whole ref end
  grep -Eiq "rank $victim\b" "$work/kill.log" && named=true
  whole=$(ckpt_step "$d/checkpoint.lbdem")
  end=$((whole + every))
  "${MPIRUN[@]}" -np "$ranks" "$exe" run "$work/kill.yaml" --backend "$backend" --quiet --restart "$d" --steps "$end" \
    > "$work/kill_restart.log" 2>&1
  local rrc=$? same=false
  ref=$(straight "$end") && cmp -s "$ref" "$d/checkpoint.lbdem" && same=true
  local ok=false
  [ "$kill_rc" -ne 0 ] && [ "$kill_rc" -ne 124 ] && [ "$named" = true ] && [ "$whole" -ge $((2 * every)) ] &&
    [ "$rrc" -eq 0 ] && [ "$same" = true ] && ok=true
  report kill_rank "$ok" "SIGKILL of rank $victim: mpirun exits non-zero within ${kill_limit} s naming rank $victim; checkpoint whole; restart bitwise" \
    "mpirun exit $kill_rc ${ended_in} s after the kill, rank named: $named; checkpoint of step $whole whole; restart to $end exit $rrc, final checkpoint bitwise to a straight run: $same" \
    $((SECONDS - t0)) "$work/kill.log"
  json_line "$jsonl" name=fault_drill_kill_rank_seconds_to_end value="$ended_in" backend="$backend" ranks="$ranks"
}

drill_ckpt_interrupt() {
  local steps=400 d="$work/interrupt" t0=$SECONDS
  local ref; ref=$(straight "$steps") || { report ckpt_interrupt false "a straight run" "the straight run failed" 0; return; }
  local c; c=$(case_file interrupt "$steps" 1 0)
  local before=0 round kills=0 mid=0 bad="" s seen=""
  for round in 1 2 3 4 5; do
    if [ "$round" -eq 1 ]; then
      launch "$work/interrupt_$round.log" "$work/int_pids_$round" run "$c" --output "$d"
    else
      launch "$work/interrupt_$round.log" "$work/int_pids_$round" run "$c" --restart "$d"
    fi
    # Wait for a checkpoint beyond the last one seen, then kill every rank at a random moment within 50 ms.
    if ! wait_ckpt "$d/checkpoint.lbdem" $((before + 1)) 300 "$mpi_pid"; then
      wait_exit "$mpi_pid" 5
      [ "$rc" -eq 0 ] && break  # the run reached its end before a kill
      bad+="round $round: the run ended with exit $rc before a new checkpoint; "
      break
    fi
    sleep "$(awk -v r=$RANDOM 'BEGIN { printf "%.3f", r / 32768 * 0.05 }')"
    local p pids=()
    for p in "$work/int_pids_$round"/*; do pids+=("$(cat "$p")"); done
    kill -9 "${pids[@]}" 2>/dev/null && kills=$((kills + 1))
    wait_exit "$mpi_pid" 30
    compgen -G "$d/checkpoint.lbdem.tmp*" > /dev/null && mid=$((mid + 1))
    s=$(ckpt_step "$d/checkpoint.lbdem")
    if [ "$s" -lt "$before" ]; then bad+="round $round: checkpoint step $s (before: $before); "; break; fi
    before=$s
    seen+="${seen:+ }$s"
    [ "$s" -ge "$steps" ] && break
  done
  # The rest of the run with one checkpoint at its end (the policy is not part of a checkpoint's identity).
  "${MPIRUN[@]}" -np "$ranks" "$exe" run "$(case_file interrupt_end "$steps" "$steps" 0)" --backend "$backend" \
    --quiet --restart "$d" > "$work/interrupt_end.log" 2>&1
  local rrc=$? same=false ok=false
  cmp -s "$ref" "$d/checkpoint.lbdem" && same=true
  [ -z "$bad" ] && [ "$kills" -ge 1 ] && [ "$rrc" -eq 0 ] && [ "$same" = true ] && ok=true
  report ckpt_interrupt "$ok" "SIGKILL of all ranks during checkpoint writes: the checkpoint under the final name always whole; restart bitwise" \
    "$kills kills ($mid with a write in progress), checkpoint whole after each (steps $seen)${bad:+; $bad}; last restart exit $rrc, bitwise: $same" \
    $((SECONDS - t0)) "$work/interrupt_end.log"
}

# The default diagnostics interval (1000) and a checkpoint every 100 steps: the checkpoints the run writes while it
# goes (polled: a random sample of them) must include steps that are not multiples of 1000.
drill_ckpt_cadence() {
  local d="$work/cadence" t0=$SECONDS seen="" s n=0 p pids=()
  launch "$work/cadence.log" "$work/cadence_pids" run "$(case_file cadence 100000000 100 0 1000)" --output "$d"
  local t_end=$((SECONDS + 40))
  while [ $n -lt 4 ] && [ $SECONDS -lt $t_end ] && kill -0 "$mpi_pid" 2>/dev/null; do
    s=$([ -f "$d/checkpoint.lbdem" ] && ckpt_step "$d/checkpoint.lbdem" || echo -1)
    if [ "$s" -gt 0 ] && [[ " $seen " != *" $s "* ]]; then seen+="${seen:+ }$s"; n=$((n + 1)); fi
    sleep 0.2
  done
  for p in "$work/cadence_pids"/*; do pids+=("$(cat "$p")"); done
  kill -9 "${pids[@]}" 2>/dev/null
  wait_exit "$mpi_pid" 30
  local off=false
  for s in $seen; do [ $((s % 1000)) -ne 0 ] && off=true; done
  report ckpt_cadence "$off" "checkpoint.interval 100 with diagnostics every 1000: checkpoints at multiples of 100" \
    "checkpoints seen at steps: ${seen:-none}" $((SECONDS - t0)) "$work/cadence.log"
}

# ckpt_counts: a checkpoint of the run on $ranks ranks of this backend at step 200, restarted to step 400 on 2
# ranks and on 1 of this backend and on $ranks CPU ranks (the grid cut as the scene chooses). Each final snapshot
# (joined) against the straight run's on $ranks ranks, with `lbdem compare`: the same backend bit for bit (the
# fluid's arithmetic does not depend on the cut); the CPU's density and velocity within 1e-12 of each field's
# largest value (another compiler and FMA contraction: round-off only). The pressure field, p - p0, is a small
# difference of densities: its round-off is that of the density (reported, not judged against its own size).
drill_ckpt_counts() {
  local steps=400 first=200 d="$work/counts" t0=$SECONDS ref
  ref=$(straight "$steps") || { report ckpt_counts false "a straight run" "the straight run failed" 0; return; }
  ref="$(dirname "$ref")"
  local yaml="$work/counts.yaml"
  grep -v '^parallel:' "$(case_file counts "$steps" "$first" 0)" > "$yaml.cut" && mv "$yaml.cut" "$yaml"
  "${MPIRUN[@]}" -np "$ranks" "$exe" run "$(case_file counts_first "$steps" "$first" 0)" --backend "$backend" \
    --quiet --steps "$first" --output "$d" > "$work/counts.log" 2>&1
  local rc=$? observed="" ok=true target np be tol out r
  [ "$rc" -eq 0 ] && [ "$(ckpt_step "$d/checkpoint.lbdem")" -eq "$first" ] || ok=false
  observed="checkpoint of step $first on $ranks $backend ranks (exit $rc)"
  "${MPIRUN[@]}" -np 1 "$exe" join "$ref" --step "$steps" > /dev/null 2>&1
  for target in "2:$backend" "1:$backend" "$ranks:cpu"; do
    np=${target%%:*} be=${target#*:}
    tol=$([ "$be" = "$backend" ] && echo 0 || echo 1e-12)
    out="$work/counts_${np}_$be"
    rm -rf "$out" && cp -a "$d" "$out"
    OMP_NUM_THREADS=$([ "$be" = cpu ] && echo 2 || echo 1) "${MPIRUN[@]}" -np "$np" "$exe" run "$yaml" \
      --backend "$be" --quiet --restart "$out" --output "$out" > "$out.log" 2>&1
    rc=$?
    [ "$np" -gt 1 ] && "${MPIRUN[@]}" -np 1 "$exe" join "$out" --step "$steps" > /dev/null 2>&1
    "$exe" compare "$ref/$(printf 'fields_%08d.h5' "$steps")" "$out/$(printf 'fields_%08d.h5' "$steps")" \
      --tolerance "$tol" > "$out.cmp" 2>&1
    r=$?
    observed+="; restart on $np $be ranks exit $rc, compare (tolerance $tol) exit $r: $(grep -c 'not bitwise' "$out.cmp") of $(grep -c ' values, ' "$out.cmp") fields not bitwise, largest relative $(sed -E -n 's/.*relative to max \|a\| ([^ ]+)$/\1/p' "$out.cmp" | sort -g | tail -1)"
    if [ "$be" != "$backend" ]; then  # the state's fields within the tolerance; the pressure reported only
      r=$(awk -v tol="$tol" '/ values, / && $1 != "pressure:" { if ($NF + 0 > tol) bad = 1 } END { print bad + 0 }' "$out.cmp")
      observed+=" (density and velocity judged: exit $r)"
    fi
    { [ "$rc" -eq 0 ] && [ "$r" -eq 0 ] && grep -q ' values, ' "$out.cmp"; } || { ok=false; tail_log "$out.log" 6; cat "$out.cmp"; }
  done
  report ckpt_counts "$ok" "a checkpoint on $ranks $backend ranks restarted on 2 and 1 $backend ranks (fields bitwise to the straight run) and on $ranks cpu ranks (within 1e-12)" \
    "$observed" $((SECONDS - t0)) "$work/counts.log"
}

drill_oom_rank() {
  local d="$work/oom" t0=$SECONDS c victim=$((ranks - 1)) hog_pid=""
  if [ "$backend" = cuda ]; then
    # A case whose pieces need ~1/3 of a GPU each; the helper leaves the last rank's GPU 1 GiB.
    local free_mib n
    free_mib=$(nvidia-smi --query-gpu=memory.free --format=csv,noheader,nounits -i "$victim" | head -1)
    n=$(python3 -c "print(int(round(($free_mib * 2**20 / 3 * $ranks / 160) ** (1/3) / 8) * 8))")
    c=$(cells=$n case_file oom 10 0 0)
    cat > "$work/hog.cu" <<'EOF'
#include <cuda_runtime.h>
#include <cstdio>
#include <unistd.h>
// Holds all but 1 GiB of the GPU's free memory until killed.
int main() {
  size_t free_b = 0, total = 0;
  if (cudaMemGetInfo(&free_b, &total) != cudaSuccess) return 1;
  void* p = nullptr;
  if (cudaMalloc(&p, free_b - (size_t(1) << 30)) != cudaSuccess) return 1;
  std::printf("held\n");
  std::fflush(stdout);
  pause();
}
EOF
    local nvcc="${CUDACXX:-/usr/local/cuda/bin/nvcc}"
    "$nvcc" -o "$work/hog" "$work/hog.cu" > "$work/hog_build.log" 2>&1 ||
      { report oom_rank false "a memory holder" "nvcc failed" 0 "$work/hog_build.log"; return; }
    CUDA_VISIBLE_DEVICES="$victim" "$work/hog" > "$work/hog.log" 2>&1 &
    hog_pid=$!
    local t_end=$((SECONDS + 30))
    until grep -q held "$work/hog.log" || [ $SECONDS -gt $t_end ]; do sleep 0.2; done
    "${MPIRUN[@]}" -np "$ranks" "$exe" run "$c" --backend cuda --quiet --output "$d" > "$work/oom.log" 2>&1 &
  else
    # Each piece needs ~19 * 8 bytes a cell (fp64, A-A): ~34 MiB per rank at 96^3 on 4 ranks; the last rank alone
    # may use 16 MiB (--memory: the cap a scheduler's per-process limit would set).
    c=$(cells=96 case_file oom 10 0 0)
    "${MPIRUN[@]}" -np $((ranks - 1)) "$exe" run "$c" --backend cpu --quiet --output "$d" : \
      -np 1 "$exe" run "$c" --backend cpu --quiet --output "$d" --memory 16MiB > "$work/oom.log" 2>&1 &
  fi
  local pid=$!
  wait_exit "$pid" 60
  [ -n "$hog_pid" ] && { kill "$hog_pid" 2>/dev/null; wait "$hog_pid" 2>/dev/null; }
  local named=false memory=false ok=false
  grep -Eiq "rank $victim\b" "$work/oom.log" && named=true
  grep -Eiq "memory" "$work/oom.log" && memory=true
  [ "$rc" -eq 4 ] && [ "$named" = true ] && [ "$memory" = true ] && ok=true
  report oom_rank "$ok" "rank $victim short of memory: exit 4, the refusal names memory and rank $victim, no hang" \
    "exit $rc after ${took} s, memory named: $memory, rank named: $named; $(grep -m1 -i 'error' "$work/oom.log" | cut -c1-200)" \
    $((SECONDS - t0)) "$work/oom.log"
}

drill_disk_full() {
  local mode="${DRILL_DISK:-auto}" t0=$SECONDS root="$work/disk"
  mkdir -p "$root"
  if [ "$mode" != fsize ]; then
    if mount -t tmpfs -o size=$(( cells * cells * cells * 19 * 8 * 3 / 1048576 + 8 ))m lbdem_drill "$root" 2> /dev/null; then
      mounted="$root"; mode=tmpfs
    elif [ "$mode" = tmpfs ]; then
      report disk_full false "a tmpfs" "mount failed (DRILL_DISK=fsize needs no mount)" 0; return
    else
      mode=fsize
    fi
  fi
  # The first half of the run writes normally (snapshots at 0, 10, 20, the checkpoint of step 20); the restart
  # then meets the full disk at its first snapshot piece (step 30).
  echo "my notes" > "$root/notes.txt"
  local d="$root/run" c
  c=$(case_file disk 40 20 10)
  "${MPIRUN[@]}" -np "$ranks" "$exe" run "$c" --backend "$backend" --quiet --output "$d" --steps 20 \
    > "$work/disk_first.log" 2>&1 || { report disk_full false "the first half runs" "it failed" 0 "$work/disk_first.log"; return; }
  local before; before=$(cd "$d" && md5sum ./*.h5 2>/dev/null)
  if [ "$mode" = fsize ]; then
    # Every rank but 0: no file may grow past a quarter of a snapshot piece (4 values of 8 bytes a cell).
    local kib=$(( cells * cells * cells * 32 / ranks / 4 / 1024 + 1 ))
    # NCCL_SHM_DISABLE: NCCL's shared-memory segments are files too (under /dev/shm), which the limit would refuse.
    "${MPIRUN[@]}" -x NCCL_SHM_DISABLE=1 -np 1 "$exe" run "$c" --backend "$backend" --quiet --restart "$d" : \
      -np $((ranks - 1)) bash -c 'trap "" XFSZ; ulimit -f '"$kib"'; exec "$@"' _ "$exe" run "$c" \
      --backend "$backend" --quiet --restart "$d" > "$work/disk.log" 2>&1 &
  else
    # A file of the user's takes all but a quarter of one snapshot piece.
    local avail keep=$(( cells * cells * cells * 32 / ranks / 4 ))
    avail=$(df --output=avail -B1 "$root" | tail -1)
    fallocate -l $(( avail - keep )) "$root/big_user_file" 2>/dev/null ||
      head -c $(( avail - keep )) /dev/zero > "$root/big_user_file" 2>/dev/null
    "${MPIRUN[@]}" -np "$ranks" "$exe" run "$c" --backend "$backend" --quiet --restart "$d" > "$work/disk.log" 2>&1 &
  fi
  local pid=$!
  wait_exit "$pid" 120
  local notes=false kept=false line s unreadable=0 f
  [ "$(cat "$root/notes.txt" 2>/dev/null)" = "my notes" ] && [ "$mode" = fsize -o -f "$root/big_user_file" ] && notes=true
  [ -n "$before" ] && [ "$(cd "$d" && md5sum ./*.h5 2>/dev/null | grep -c -F -x -f <(echo "$before"))" -eq \
    "$(echo "$before" | wc -l)" ] && kept=true
  line=$(grep -m1 -Ei "^error:.*(disk|space|too large)" "$work/disk.log" | cut -c1-240)
  s=$([ -f "$d/checkpoint.lbdem" ] && ckpt_step "$d/checkpoint.lbdem" || echo -1)
  if python3 -c 'import h5py' 2>/dev/null; then
    for f in "$d"/*.h5; do
      [ -e "$f" ] || continue
      python3 -c 'import h5py, sys; h5py.File(sys.argv[1], "r").close()' "$f" 2>/dev/null || unreadable=$((unreadable + 1))
    done
  fi
  local ok=false
  [ "$rc" -eq 4 ] && [ -n "$line" ] && [ "$notes" = true ] && [ "$kept" = true ] && [ "$s" -eq 20 ] &&
    [ "$unreadable" -eq 0 ] && ok=true
  report disk_full "$ok" "disk full ($mode) while the ranks write snapshot pieces: exit 4, one line naming the file, the user's files and the earlier snapshots kept, the checkpoint of step 20 whole, no unreadable snapshot" \
    "exit $rc after ${took} s; user's files kept: $notes; earlier snapshots unchanged: $kept; checkpoint step $s; $unreadable unreadable snapshots; message: ${line:-none}" \
    $((SECONDS - t0)) "$work/disk.log"
  if [ -n "$mounted" ]; then umount "$mounted" && mounted=""; fi
}

echo "fault_drills: $backend backend, $ranks ranks, ${cells}^3 cells, drills: ${drills[*]}"
for dr in "${drills[@]}"; do "drill_$dr"; done
[ "$all_ok" -eq 1 ]
