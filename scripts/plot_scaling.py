#!/usr/bin/env python3
"""Plot the many-GPU model (bench/results/scaling_model.json, written by
lbdem_scaling_model): model against every measured point (left) and the
predicted parallel efficiency of strong and weak scaling (right).

    scripts/plot_scaling.py [bench/results/scaling_model.json] [bench/results/scaling_model.png]
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else "bench/results/scaling_model.json"
    dst = sys.argv[2] if len(sys.argv) > 2 else "bench/results/scaling_model.png"
    with open(src) as f:
        d = json.load(f)

    fig, axes = plt.subplots(1, 4, figsize=(22, 5.4))
    ax = axes[0]
    pts = d["points"]
    labels, meas, mod = [], [], []
    for p in pts:
        shared = " 1GPU" if p.get("ranks_per_gpu", 1) > 1 else ""
        labels.append(f'{p["ranks"]}{shared} {p["mode"]} {p["precision"]}\n{p["grid"][0]}x{p["grid"][1]}x{p["grid"][2]}')
        meas.append(p["measured"]["t_step_s"] * 1e3)
        mod.append(p["model"]["t_step_s"] * 1e3)
    x = range(len(pts))
    ax.bar([i - 0.2 for i in x], meas, 0.4, label="measured")
    ax.bar([i + 0.2 for i in x], mod, 0.4, label="model")
    for i, p in enumerate(pts):
        ax.text(i, max(meas[i], mod[i]) * 1.02, f'{p["rel_error"] * 100:+.1f}%', ha="center", fontsize=7)
    ax.set_xticks(list(x))
    ax.set_xticklabels(labels, fontsize=6, rotation=60, ha="right")
    ax.set_ylabel("ms per step")
    dev = sorted({p["device"] for p in pts})
    ax.set_title("model vs measured (" + ", ".join(dev) + ")", fontsize=9)
    ax.legend(fontsize=8)

    styles = {"host_mpi": "o-", "device_mpi": "s--", "nccl": "^:"}
    panels = (("strong", False), ("weak", False), (None, True))
    for ax, (scaling, one_host) in zip(axes[1:], panels):
        series = {}
        for r in d["predictions"]:
            if r["scene"].startswith("one host") != one_host:
                continue
            if scaling is not None and r["scaling"] != scaling:
                continue
            name = r["scene"].split(",")[0].replace("one host: ", "")
            key = (name + (" " + r["scaling"] if one_host else ""), r["precision"], r["transport"])
            series.setdefault(key, []).append(r)
        for (scene, prec, tp), rows in sorted(series.items()):
            g = [r["gpus"] for r in rows]
            e = [r["efficiency"] * 100 for r in rows]
            ax.plot(g, e, styles[tp], label=f"{scene} {prec} {tp}", ms=4, lw=1)
            for r in rows:
                if not r["fits_h200"]:
                    ax.plot(r["gpus"], r["efficiency"] * 100, "x", color="red", ms=8)
        ax.axhline(80, color="grey", lw=0.8)
        ax.set_xscale("log", base=2)
        ax.set_xlabel("GPUs (H200, 8 per node, NVLink; 4x200 Gb/s IB between nodes)")
        ax.set_ylabel("parallel efficiency (%)")
        ax.set_ylim(0, 105)
        if one_host:
            ax.set_title("one host, 1-8 H200 (model; weak: stacked along z)", fontsize=9)
        else:
            ax.set_title(f"{scaling} scaling (model); x = does not fit in 141 GB", fontsize=9)
        ax.legend(fontsize=6, loc="lower left")
    fig.tight_layout()
    fig.savefig(dst, dpi=130)
    print("wrote", dst)


if __name__ == "__main__":
    main()
