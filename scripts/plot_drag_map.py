#!/usr/bin/env python3
"""Heat maps of the fixed-sphere drag error over d/l x tau, one PNG per weighting
(scripts/drag_map.sh merge writes the JSON).

usage: plot_drag_map.py drag_map.json OUTDIR

For each weighting (the "weight" of the rows: ntw = the wall rule, nt = classic
Noble-Torczynski) one figure with a panel per (fraction method, precision): cell
colour = relative drag error (%), text = the error, a frame where |error| is above
half the first paper's Table 1 error (the bar). Needs python3-matplotlib.
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

BAR = {4: 8.00, 6: 3.48, 8: 2.18, 10: 1.43, 16: 1.05, 20: 0.68, 30: 0.33, 50: 0.17}


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = json.load(open(sys.argv[1]))["rows"]
    out = sys.argv[2]
    for weight in sorted({r["weight"] for r in rows}):
        wr = [r for r in rows if r["weight"] == weight and r.get("error") is not None]
        panels = sorted({(r["method"], r["precision"]) for r in wr})
        if not panels:
            continue
        fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4.5), squeeze=False)
        for ax, (method, prec) in zip(axes[0], panels):
            pr = [r for r in wr if r["method"] == method and r["precision"] == prec]
            ds = sorted({r["d"] for r in pr})
            taus = sorted({r["tau"] for r in pr})
            grid = [[None] * len(taus) for _ in ds]
            for r in pr:
                grid[ds.index(r["d"])][taus.index(r["tau"])] = 100 * r["error"]
            vals = [abs(v) for row in grid for v in row if v is not None]
            vmax = max(vals + [1e-3])
            img = [[(v if v is not None else float("nan")) for v in row] for row in grid]
            im = ax.imshow(img, cmap="RdBu_r", vmin=-vmax, vmax=vmax, aspect="auto", origin="lower")
            for i, d in enumerate(ds):
                for j in range(len(taus)):
                    v = grid[i][j]
                    if v is None:
                        continue
                    bad = d in BAR and abs(v) > BAR[d]
                    ax.text(j, i, f"{v:+.2f}", ha="center", va="center", fontsize=7,
                            fontweight="bold" if bad else "normal")
                    if bad:
                        ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, ec="k", lw=1.5))
            ax.set_xticks(range(len(taus)), [f"{t:g}" for t in taus])
            ax.set_yticks(range(len(ds)), [f"{d:g}" for d in ds])
            ax.set_xlabel("tau")
            ax.set_ylabel("d / l")
            ax.set_title(f"{weight}, {method}, {prec}: drag error % (framed: above the bar)", fontsize=9)
            fig.colorbar(im, ax=ax, label="(K - K_ref) / K_ref, %")
        fig.tight_layout()
        path = os.path.join(out, f"drag_map_{weight}.png")
        fig.savefig(path, dpi=120)
        print("plot:", path)


if __name__ == "__main__":
    main()
