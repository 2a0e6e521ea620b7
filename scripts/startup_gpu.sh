#!/usr/bin/env bash
# The start-up of a sphere from rest (issue 29) on ONE GPU (lbdem_bench_psm startup, bench/imb/startup_case.hpp):
#
#   scripts/startup_gpu.sh BUILD_DIR
#
# A free sphere (PSM, the default weighting noble_torczynski_wall with Lambda auto, exact fractions, fp64, tau 0.8)
# pulled from rest by a constant force (Re_p 0.2 at Stokes's terminal velocity) in a periodic cube of 6 d, density
# ratios 2 and 8, d/l 10 (60^3 cells, 7,300 steps) and 16 (96^3, 18,700 steps); then d/l 10 at ratio 2 in a cube of
# 10 d (100^3, 20,300 steps: the images' share is 5x smaller) if time is left. Each run: the curve against the
# periodic-cube model (RMS, max, in units of u_T), against the unbounded Maxey-Riley + Basset reference over
# sqrt(nu t) <= L/4, the terminal slip against Hasimoto (1959) and Sangani & Acrivos (1982).
# Expected about 1 min on one H200 after the build (56 G cell updates in all); the timeouts cap it at 3.5 min.
# Output: $OUT/startup.jsonl (per run one "startup" line and one "startup_curve" line per sample),
# $OUT/startup.md (the table), $OUT/startup.png (measured against the models), logs $OUT/startup*.log.
# Prints the table.
set -uo pipefail
source "$(dirname "$0")/lib.sh"
build="${1:?usage: scripts/startup_gpu.sh BUILD_DIR}"
lbdem_env
lbdem_build "$build" lbdem_bench_psm || exit 1
bin="$(realpath "$build")/bench/imb/lbdem_bench_psm"
common=(--backend cuda --tau 0.8 --magic auto --weights ntw --re 0.2 --precision fp64 --out "$OUT/startup.jsonl")
{
  timeout 60 "$bin" startup "${common[@]}" --diameter 10 --ratio 2,8 --box 6
  echo "startup d/l 10: exit $?" >&2
  timeout 90 "$bin" startup "${common[@]}" --diameter 16 --ratio 2,8 --box 6 | tail -n +3
  echo "startup d/l 16: exit $?" >&2
  timeout 45 "$bin" startup "${common[@]}" --diameter 10 --ratio 2 --box 10 | tail -n +3
  echo "startup d/l 10 box 10: exit $?" >&2
} > "$OUT/startup.md" 2> "$OUT/startup.log"
cat "$OUT/startup.md"
tail_log "$OUT/startup.log" 4
py="$(plot_python)"
[ -z "$py" ] && py=python3
"$py" "$(dirname "$0")/plot_startup.py" "$OUT/startup.png" "$OUT/startup.jsonl" > "$OUT/startup_plot.log" 2>&1 ||
  tail_log "$OUT/startup_plot.log" 5
