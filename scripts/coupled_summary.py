#!/usr/bin/env python3
"""The figures of a coupled (particles scene) run's summary.json as KEY=VALUE lines (values JSON without spaces),
for the GPU scripts' json_line (scripts/lib.sh): steps, cells, particles, grid, dims, GLUPS, loop and stepping
seconds (the loop less the snapshots taken inside it), set-up, snapshots and their share at the shipped interval
(5000 steps), phases and set-up phases (max/mean over ranks), particles per rank.
  python3 scripts/coupled_summary.py RUN_DIR/summary.json"""
import json
import re
import sys

try:
    s = json.load(open(sys.argv[1]))
except Exception:
    print("error=no_summary")
    sys.exit()
t = s.get("timing", {})
cells = 1
for c in s["lattice"]["cells"]:
    cells *= c
loop = t.get("loop_seconds", s.get("seconds", 0))
steps = s.get("steps", 0) - s.get("restarted_from_step", 0)
snap = t.get("output_seconds", {}).get("max", 0)
nsnap = max(t.get("snapshots", 0), 1)
# loop_seconds counts the snapshots taken inside the loop: the stepping alone is the rest.
stepping = loop - snap if loop > snap else loop
out = {"steps": steps, "cells": cells, "particles": s.get("particles"), "grid": s["lattice"]["cells"],
       "dims": [int(v) for v in re.findall(r"\d+", s.get("decomposition", "1 x 1 x 1"))][:3],
       "glups": s.get("coupled_mlups", 0) / 1e3, "steps_per_s": steps / stepping if stepping else 0,
       "loop_s": loop, "stepping_s": stepping, "setup_s": t.get("setup_seconds"), "snapshot_s": snap,
       "snapshots": t.get("snapshots", 0),
       # One snapshot over 5000 steps of stepping (the shipped cases' interval).
       "snapshot_fraction_shipped": (snap / nsnap) / (5000 * stepping / steps) if steps and stepping else None,
       "snapshot_fraction_run": snap / loop if loop else None,
       "phases": t.get("phases"), "setup": t.get("setup"),
       "particles_per_rank": {k: v for k, v in s.get("particles_per_rank", {}).items() if k != "note"}}
for k, v in out.items():
    print("%s=%s" % (k, json.dumps(v).replace(" ", "")))
