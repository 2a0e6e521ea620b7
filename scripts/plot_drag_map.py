#!/usr/bin/env python3
"""Heat maps of the fixed-sphere drag error over d/l x tau, one PNG per weighting
(scripts/drag_map.sh merge writes the JSON).

usage: plot_drag_map.py drag_map.json OUTDIR

For each weighting (the "weight" of the rows: ntw = the wall rule, nt = classic
Noble-Torczynski) and array (the rows' "chi", d/L; 0.5 where a row has none) one
figure with a panel per (fraction method, precision): cell colour = relative drag
error (%), text = the error, a frame where |error| is above half the first paper's
Table 1 error (the bar; linear in d/l between its diameters). Needs
python3-matplotlib. Files: drag_map_<weight>.png (chi 0.5),
drag_map_<weight>_chi<chi>.png (any other chi).
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

PAPER = [(4, 15.99), (6, 6.953), (8, 4.352), (10, 2.868), (16, 2.101), (20, 1.367), (30, 0.6503), (50, 0.3335)]


def bar(d):
    """Half the first paper's Table 1 error (%) at d/l, linear in d/l between its diameters; None outside."""
    for (d0, e0), (d1, e1) in zip(PAPER, PAPER[1:]):
        if d0 <= d <= d1:
            return 0.5 * (e0 + (d - d0) / (d1 - d0) * (e1 - e0))
    return None


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = json.load(open(sys.argv[1]))["rows"]
    out = sys.argv[2]
    chi_of = lambda r: round(r.get("chi", 0.5), 4)  # noqa: E731
    for weight, chi in sorted({(r["weight"], chi_of(r)) for r in rows}):
        wr = [r for r in rows if r["weight"] == weight and chi_of(r) == chi and r.get("error") is not None]
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
                    b = bar(d)
                    bad = b is not None and abs(v) > b
                    ax.text(j, i, f"{v:+.2f}", ha="center", va="center", fontsize=7,
                            fontweight="bold" if bad else "normal")
                    if bad:
                        ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, ec="k", lw=1.5))
            ax.set_xticks(range(len(taus)), [f"{t:g}" for t in taus])
            ax.set_yticks(range(len(ds)), [f"{d:.3g}" for d in ds])
            ax.set_xlabel("tau")
            ax.set_ylabel("d / l")
            ax.set_title(f"{weight}, chi {chi:g}, {method}, {prec}: drag error % (framed: above the bar)", fontsize=9)
            fig.colorbar(im, ax=ax, label="(K - K_ref) / K_ref, %")
        fig.tight_layout()
        name = f"drag_map_{weight}.png" if chi == 0.5 else f"drag_map_{weight}_chi{chi:g}.png"
        path = os.path.join(out, name)
        fig.savefig(path, dpi=120)
        print("plot:", path)


if __name__ == "__main__":
    main()
