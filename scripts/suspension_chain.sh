#!/usr/bin/env bash
# A suspension run as a chain of bounded jobs, each continuing the last by --restart (issue 16): what a
# user does on a cluster with a wall-time limit per job. Each job is `lbdem run` stopped by SIGTERM after
# JOB_SECONDS (it finishes the step, writes its output and a checkpoint, exits 5); the next job continues
# from that checkpoint, until the planned steps are done or MAX_JOBS have run.
#
#   scripts/suspension_chain.sh CASE STEPS JOB_SECONDS MAX_JOBS [RUN_DIR]
#     CASE         a case file (e.g. cases/suspension/suspension_3d_small.yaml)
#     STEPS        the planned steps of the whole chain (--steps)
#     JOB_SECONDS  wall-time limit of one job
#     MAX_JOBS     jobs at most
#     RUN_DIR      the run folder (default $OUT/chain/<case name>)
#   BACKEND (default cuda), LBDEM (default build-gpu/cases/lbdem), LBDEM_COMMIT (named in chain.jsonl).
# Writes RUN_DIR/../<name>_chain.jsonl (one line per job: exit code, first and last step, wall seconds,
# coupled MLUPS, mean slip against Wen-Yu, output share) and <name>_job<k>.log; then the pictures
# (scripts/plot_suspension.py) when matplotlib and h5py are there.
set -uo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
[ $# -ge 4 ] || { sed -n 2,17p "$0"; exit 2; }
case_file="$1" steps="$2" job_s="$3" max_jobs="$4"
name="$(basename "$case_file" .yaml)"
OUT="${OUT:-$here/out}"
run_dir="${5:-$OUT/chain/$name}"
log_dir="$(dirname "$run_dir")"
mkdir -p "$log_dir"
lbdem="${LBDEM:-$here/build-gpu/cases/lbdem}"
backend="${BACKEND:-cuda}"
commit="${LBDEM_COMMIT:-$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)}"
py=""
for p in python3 /opt/torch/.venv/bin/python3 /usr/bin/python3; do
  if "$p" -c 'import matplotlib, h5py, numpy' 2>/dev/null; then py="$p"; break; fi
done
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
  "${py:-python3}" - "$run_dir/summary.json" "$k" "$rc" "$t0" "$t1" "$commit" >> "$jsonl" <<'PY'
import json, sys
path, k, rc, t0, t1, commit = sys.argv[1:]
row = {"job": int(k), "exit": int(rc), "wall_s": round(float(t1) - float(t0), 1), "commit": commit}
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
