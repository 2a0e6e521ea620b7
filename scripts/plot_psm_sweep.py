#!/usr/bin/env python3
"""Plot the PSM fixed-sphere sweep (lbdem_bench_psm sweep --out ...).

usage: scripts/plot_psm_sweep.py OUT.png SWEEP.json[:SET] [SWEEP.json[:SET] ...]

SWEEP.json:SET plots the rows of the named set of a results file ("sets" in
bench/results/psm_fixed_sphere_sweep_h200.json) instead of its own rows.

Left: |drag error| against d/l for every configuration, with the first paper's
Table 1 errors (Re_p = 0.2, against Fluent) and the bar (half of them).
Right: |error| against the wall time to the detected steady state, with the
paper's error at each d/l drawn beside our points as a short horizontal mark at
the time of our accurate run at that d/l (the paper gives no times).
Filled markers: K above the reference; open: below. Rows not converged are
drawn with an 'x'. A configuration is labelled by the fields that vary across
the rows (method, precision, collision always). Needs matplotlib
(apt: python3-matplotlib).
"""
import json
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

PAPER = {4: 15.99, 6: 6.953, 8: 4.352, 10: 2.868, 16: 2.101, 20: 1.367, 30: 0.6503, 50: 0.3335}
# Fields that name a configuration besides method / precision / collision
# (a file written without one of them: its default).
EXTRA = [("weight", "nt"), ("variant", "nebb"), ("tau", None), ("magic", None), ("offset", 0), ("re_target", None)]


def label(r, varying):
    s = f'{r["method"]} {r["precision"]} {r["collision"]}'
    for k, _ in EXTRA:
        if k in varying:
            s += f' {k}={r.get(k)}'
    return s


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        sys.exit(2)
    out, files = sys.argv[1], sys.argv[2:]
    rows = []
    for f in files:
        path, _, name = f.partition(":")
        j = json.load(open(path))
        rows += (j["sets"][name] if name else j)["rows"]
    rows = [r for r in rows if r.get("error") is not None]
    for r in rows:
        for k, default in EXTRA:
            r.setdefault(k, default)
    varying = [k for k, _ in EXTRA if len({str(r.get(k)) for r in rows}) > 1]
    groups = {}
    for r in rows:
        groups.setdefault(label(r, varying), []).append(r)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(14, 5.6))
    ds = sorted(PAPER)
    a1.plot(ds, [PAPER[d] for d in ds], "k-o", lw=2, label="first paper, Table 1 (Re_p = 0.2, vs Fluent)")
    a1.plot(ds, [PAPER[d] / 2 for d in ds], "k--", lw=1, label="bar: half the paper")
    cycle = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    best_time = {}  # d -> wall time of the first group's run (for the paper marks)
    for gi, (key, rs) in enumerate(sorted(groups.items())):
        rs = sorted(rs, key=lambda r: r["d"])
        col = cycle[gi % len(cycle)]
        e = [max(abs(100 * r["error"]), 1e-3) for r in rs]
        a1.plot([r["d"] for r in rs], e, "-", color=col, lw=1, label=key)
        a2.plot([r["seconds"] for r in rs], e, "-", color=col, lw=1, label=key)
        for r, ei in zip(rs, e):
            conv = r.get("converged", True)
            mk = "s" if conv else "x"
            face = col if r["error"] > 0 else "none"
            for ax, x in ((a1, r["d"]), (a2, r["seconds"])):
                ax.plot([x], [ei], mk, ms=5, color=col, markerfacecolor=face if conv else col)
            a2.annotate(f'{r["d"]:g}', (r["seconds"], ei), fontsize=6, xytext=(2, 2), textcoords="offset points")
            if r["d"] in PAPER and r["d"] not in best_time:
                best_time[r["d"]] = r["seconds"]
    for d, t in sorted(best_time.items()):
        a2.plot([t / 1.3, t * 1.3], [PAPER[d], PAPER[d]], "k-", lw=2)
        a2.annotate(f"paper d/l={d:g}", (t * 1.3, PAPER[d]), fontsize=6, va="center")
    a2.plot([], [], "k-", lw=2, label="paper's error at that d/l (no time given)")
    for a in (a1, a2):
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_ylabel("|K error| vs Sangani & Acrivos (%)  (filled: K high, open: K low)")
        a.grid(True, which="both", alpha=0.3)
    a1.set_xlabel("d / l")
    a2.set_xlabel("wall time to steady state (s); labels: d/l")
    a1.set_title("Fixed sphere, simple cubic array, chi = 0.5")
    a2.set_title("Error against time to solution")
    a1.legend(fontsize=6)
    a2.legend(fontsize=6, loc="best")
    fig.tight_layout()
    fig.savefig(out, dpi=120)


if __name__ == "__main__":
    main()
