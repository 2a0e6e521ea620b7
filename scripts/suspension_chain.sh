#!/usr/bin/env bash
# A suspension run as a chain of bounded jobs, each continuing the last by --restart (issue 16): what a
# user does on a cluster with a wall-time limit per job. Each job is `lbdem run` stopped by SIGTERM after
# JOB_SECONDS (it finishes the step, writes its output and a checkpoint, exits 5); the next job continues
# from that checkpoint, until the planned steps are done or MAX_JOBS have run.
#
#   scripts/suspension_chain.sh [-B DIR] CASE STEPS JOB_SECONDS MAX_JOBS [RUN_DIR]
#     -B DIR       the build folder (default $LBDEM_BUILD, else build-gpu/); lbdem is built there first
#                  (scripts/lib.sh lbdem_build: the `cuda` preset if new)
#     CASE         a case file (e.g. cases/suspension/suspension_3d_small.yaml)
#     STEPS        the planned steps of the whole chain (--steps)
#     JOB_SECONDS  wall-time limit of one job
#     MAX_JOBS     jobs at most
#     RUN_DIR      the run folder (default $OUT/chain/<case name>)
#   BACKEND (default cuda), LBDEM (an lbdem to use as it is, instead of building one), LBDEM_COMMIT (named in
#   chain.jsonl).
# Writes RUN_DIR/../<name>_chain.jsonl (one line per job: exit code, first and last step, wall seconds,
# coupled MLUPS, mean slip against Wen-Yu, output share, device, date, commit) and <name>_job<k>.log; then the pictures
# (scripts/plot_suspension.py) when matplotlib and h5py are there.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
[ "${1:-}" = -B ] && { LBDEM_BUILD="${2:?-B needs a build folder}"; shift 2; }
[ $# -ge 4 ] || { sed -n "2,/^set -uo/p" "$0" | grep "^#"; exit 2; }
case_file="$1" steps="$2" job_s="$3" max_jobs="$4"
name="$(basename "$case_file" .yaml)"
lbdem_env
here="$LBDEM_ROOT"
run_dir="${5:-$OUT/chain/$name}"
log_dir="$(dirname "$run_dir")"
mkdir -p "$log_dir"
if [ -n "${LBDEM:-}" ]; then
  lbdem="$LBDEM"
else
  LBDEM_BUILD_LOG="$log_dir/build.log" lbdem_build "$LBDEM_BUILD" lbdem || exit 1
  lbdem="$LBDEM_BUILD/cases/lbdem"
fi
backend="${BACKEND:-cuda}"
py="$(plot_python)"
jsonl="$log_dir/${name}_chain.jsonl"
for ((k = 1; k <= max_jobs; ++k)); do
  if [ $k -eq 1 ]; then
    args=(run "$case_file" --backend "$backend" --steps "$steps" --output "$run_dir" --overwrite)
  else
    args=(run "$case_file" --backend "$backend" --steps "$steps" --restart "$run_dir")
  fi
  t0=$(date +%s.%N)
  timeout --preserve-status -s TERM -k 120 "$job_s" "$lbdem" "${args[@]}" > "$log_dir/${name}_job$k.log" 2>&1
  rc=$?
  t1=$(date +%s.%N)
  "${py:-python3}" - "$run_dir/summary.json" "$k" "$rc" "$t0" "$t1" "$LBDEM_DEVICE" "$LBDEM_COMMIT" >> "$jsonl" <<'PY'
import datetime, json, sys
path, k, rc, t0, t1, device, commit = sys.argv[1:]
row = {"job": int(k), "exit": int(rc), "wall_s": round(float(t1) - float(t0), 1), "device": device,
       "date": datetime.date.today().isoformat(), "commit": commit}
try:
    s = json.load(open(path))
    st, o = s.get("statistics", {}), s.get("output", {})
    row.update({"from_step": s["restarted_from_step"], "to_step": s["steps"], "steps_planned": s["steps_planned"],
                "simulated_s": s["steps"] * s["conversion"]["dt_s"], "coupled_mlups": s["coupled_mlups"],
                "interrupted": s["interrupted"], "mean_slip_m_per_s": st.get("mean_slip_m_per_s"),
                "wen_yu_slip_m_per_s": st.get("wen_yu_slip_m_per_s"), "slip_over_wen_yu": st.get("slip_over_wen_yu"),
                "mean_drag_over_weight": st.get("mean_drag_over_weight"),
                "statistics_fraction": st.get("fraction_of_run"), "output_fraction": o.get("fraction_of_stepping"),
                "checkpoint_seconds": o.get("checkpoint_seconds")})
except Exception as e:  # no summary: the job failed before writing one
    row["error"] = str(e)
print(json.dumps(row))
PY
  tail -1 "$jsonl"
  # 5: stopped by the signal with a checkpoint: go on; 0: the planned steps are done; else: stop the chain.
  [ $rc -eq 5 ] || break
done
if [ -n "$py" ] && [ -f "$run_dir/series.csv" ]; then
  "$py" "$here/scripts/plot_suspension.py" "$run_dir" > "$log_dir/${name}_plot.log" 2>&1 || true
fi
