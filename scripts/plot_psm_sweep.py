#!/usr/bin/env python3
"""Plot the PSM fixed-sphere sweep (lbdem_bench_psm sweep --out ...).

usage: scripts/plot_psm_sweep.py OUT.png SWEEP.json [SWEEP.json ...]
Left: |drag error| against d/l for every configuration, with the first paper's
Table 1 errors and the issue's bar (half of them). Right: |error| against the
wall time to the detected steady state. Needs matplotlib (apt: python3-matplotlib).
"""
import json
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

PAPER = {4: 15.99, 6: 6.953, 8: 4.352, 10: 2.868, 16: 2.101, 20: 1.367, 30: 0.6503, 50: 0.3335}


def main():
    out, files = sys.argv[1], sys.argv[2:]
    rows = []
    for f in files:
        rows += json.load(open(f))["rows"]
    groups = {}
    for r in rows:
        key = f'{r["method"]} {r["precision"]} {r["collision"]}'
        groups.setdefault(key, []).append(r)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 5.2))
    ds = sorted(PAPER)
    a1.plot(ds, [PAPER[d] for d in ds], "k-o", lw=2, label="first paper, Table 1 (Re_p = 0.2)")
    a1.plot(ds, [PAPER[d] / 2 for d in ds], "k--", lw=1, label="issue bar: half the paper")
    for key, rs in sorted(groups.items()):
        rs = sorted(rs, key=lambda r: r["d"])
        a1.plot([r["d"] for r in rs], [max(abs(100 * r["error"]), 1e-3) for r in rs], "-s", ms=4, label=key)
        a2.plot([r["seconds"] for r in rs], [max(abs(100 * r["error"]), 1e-3) for r in rs], "-s", ms=4, label=key)
        for r in rs:
            a2.annotate(f'{r["d"]:g}', (r["seconds"], max(abs(100 * r["error"]), 1e-3)), fontsize=6)
    for a in (a1, a2):
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_ylabel("|K error| vs Sangani & Acrivos (%)")
        a.grid(True, which="both", alpha=0.3)
    a1.set_xlabel("d / l")
    a2.set_xlabel("wall time to steady state (s); labels: d/l")
    a1.set_title("Fixed sphere, simple cubic array, chi = 0.5")
    a2.set_title("Error against time to solution")
    a1.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


if __name__ == "__main__":
    main()
