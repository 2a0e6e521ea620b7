#!/usr/bin/env python3
"""Plot the start-up of a sphere from rest (lbdem_bench_psm startup --out FILE.jsonl).

usage: scripts/plot_startup.py OUT.png STARTUP.jsonl

Top: the measured velocity (in the frame of the far fluid, over Stokes's
terminal velocity of the applied force) against T = t nu / a^2 for every run
(d/l, density ratio, box), with the periodic-cube model at the same density
ratio (dashed), at density ratio + 1 (dash-dot: the PSM sphere with its
interior fluid) and the unbounded reference (dotted, drawn up to the end of
the comparison window). Bottom: the error against the periodic-cube model at
the run's density ratio, in units of u_T. Needs matplotlib.
"""
import json
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    runs = {}
    for line in open(sys.argv[2]):
        line = line.strip()
        if not line:
            continue
        r = json.loads(line)
        if r.get("bench") != "startup_curve":
            continue
        key = (r["d"], r["ratio"], r["L"])
        runs.setdefault(key, []).append(r)
    if not runs:
        sys.exit("plot_startup: no startup_curve rows in " + sys.argv[2])
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(8, 9), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (key, rows) in enumerate(sorted(runs.items())):
        d, ratio, L = key
        c = colors[i % len(colors)]
        T = [r["T"] for r in rows]
        lab = f"d/l {d:g}, $\\rho_p/\\rho$ {ratio:g}, L {L}"
        ax.plot(T, [r["u"] for r in rows], "-", color=c, lw=1.6, label=lab + " LBM")
        ax.plot(T, [r["box"] for r in rows], "--", color=c, lw=1, label="periodic model" if i == 0 else None)
        ax.plot(T, [r["box_psm"] for r in rows], "-.", color=c, lw=0.8,
                label="periodic model, ratio + 1" if i == 0 else None)
        w = [r for r in rows if r["in_window"]]
        ax.plot([r["T"] for r in w], [r["ref"] for r in w], ":", color=c, lw=1.2,
                label="unbounded (Maxey-Riley + Basset)" if i == 0 else None)
        ax2.plot(T, [100 * r["error_box"] for r in rows], "-", color=c, lw=1.2, label=lab)
    ax.set_xscale("log")
    ax.set_ylabel("$(v - a_b t)/u_T$")
    ax.set_title("Start-up of a sphere from rest (PSM, periodic cube)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    ax2.axhline(0, color="k", lw=0.6)
    ax2.set_xlabel("$T = t\\nu/a^2$")
    ax2.set_ylabel("LBM - periodic model (% of $u_T$)")
    ax2.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(sys.argv[1], dpi=120)
    print("wrote " + sys.argv[1])


if __name__ == "__main__":
    main()
