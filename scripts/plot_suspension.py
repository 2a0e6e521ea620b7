#!/usr/bin/env python3
"""Pictures of a `particles` run (a suspension, a settling sphere), like the first
paper's Figs. 4-7: particles coloured by their velocity over the gas velocity, and
the time series of the slip velocity and the drag.

usage: scripts/plot_suspension.py RUN_DIR [--out DIR] [--steps S1,S2,...] [--component y]

Writes to --out (default RUN_DIR):
  snapshots.png  up to four instants side by side (the last four field/particle
                 outputs, or --steps): the gas velocity component along gravity
                 (--component) as a colour map, the particles as disks of their
                 size coloured by the same component of their velocity. 2D runs
                 show the whole box; 3D runs a slice through the middle of z,
                 with the particles whose centres lie within one diameter of it.
  series.png     from series.csv: the slip velocity (fluid over the fluid volume
                 minus the mean particle velocity) along -gravity with the Wen-Yu
                 homogeneous slip of summary.json, the drag over the particles'
                 net weight, the granular temperature, and the cluster measure
                 (coarse-grained solid-fraction variance over its random value).

Physical-unit runs (summary.json "units": "physical") are drawn in SI (m, s,
m/s) with the conversion factors of summary.json; lattice runs in cells and steps.
Needs matplotlib, numpy and h5py (apt: python3-matplotlib python3-h5py).
"""
import argparse
import csv
import glob
import json
import os
import re
import sys

import numpy as np

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.collections import EllipseCollection

try:
    import h5py
except ImportError:  # the series alone can still be drawn
    h5py = None

AXES = {"x": 0, "y": 1, "z": 2}


def read_summary(run):
    path = os.path.join(run, "summary.json")
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        return json.load(f)


def scales(summary):
    """Length, time and velocity factors from lattice to the units drawn, and their names."""
    conv = summary.get("conversion", {})
    if summary.get("units") == "physical" and conv:
        dx, dt = conv["dx_m"], conv["dt_s"]
        return dx, dt, dx / dt, ("m", "s", "m/s")
    return 1.0, 1.0, 1.0, ("cells", "steps", "cells/step")


def read_series(run):
    path = os.path.join(run, "series.csv")
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        rows = list(csv.reader(f))
    head = rows[0]
    data = np.array([[float(v) for v in r] for r in rows[1:] if len(r) == len(head)])
    return {h: data[:, i] for i, h in enumerate(head)} if len(data) else {}


def step_files(run, prefix):
    """step -> the files of that step: the whole file (a run on one rank, or
    joined by `lbdem join`), else the per-rank pieces (<prefix>_<step>_r<rank>.h5)."""
    whole, pieces = {}, {}
    for p in glob.glob(os.path.join(run, prefix + "_*.h5")):
        m = re.search(r"_(\d{8,})(?:_r(\d+))?\.h5$", os.path.basename(p))
        if not m:
            continue
        s = int(m.group(1))
        if m.group(2) is None:
            whole[s] = [p]
        else:
            pieces.setdefault(s, []).append(p)
    out = {s: sorted(v) for s, v in pieces.items()}
    out.update(whole)
    return out


def read_slice(files, a):
    """Component a of the velocity in the middle z layer of the whole grid, (ny, nx),
    read from the pieces that hold that layer only (no whole field in memory), its
    z index, the grid's nz and the time."""
    with h5py.File(files[0], "r") as f:
        t = float(f.attrs.get("time", 0.0))
        g = f.attrs.get("global_cells")
        if g is None:  # a file of an older lbdem: the whole grid
            u = f["velocity"]
            nz = u.shape[0]
            k = nz // 2
            return np.asarray(u[k, :, :, a]), k, nz, t
    gx, gy, gz = (int(v) for v in g)
    k = gz // 2
    sl = np.zeros((gy, gx))
    for p in files:
        with h5py.File(p, "r") as f:
            ox, oy, oz = (int(v) for v in f.attrs["piece_offset"])
            u = f["velocity"]
            if oz <= k < oz + u.shape[0]:
                sl[oy:oy + u.shape[1], ox:ox + u.shape[2]] = u[k - oz, :, :, a]
    return sl, k, gz, t


def read_particles(files):
    xs, vs, rs = [], [], []
    for p in files:
        with h5py.File(p, "r") as f:
            xs.append(np.asarray(f["positions"]).reshape(-1, 3))
            vs.append(np.asarray(f["velocity"]).reshape(-1, 3))
            rs.append(np.asarray(f["radius"]).reshape(-1))
    return np.concatenate(xs), np.concatenate(vs), np.concatenate(rs)


def plot_snapshots(run, out, summary, steps, comp):
    if h5py is None:
        print("h5py missing (apt: python3-h5py): no snapshots.png", file=sys.stderr)
        return None
    fields, parts = step_files(run, "fields"), step_files(run, "particles")
    common = sorted(set(fields) & set(parts))
    if steps:
        common = [s for s in steps if s in fields and s in parts]
    else:
        common = common[-4:]
    if not common:
        print("no step with both fields_*.h5 and particles_*.h5 in " + run, file=sys.stderr)
        return None
    L, T, V, names = scales(summary)
    a = AXES[comp]
    panels = []
    vmax = 0.0
    for s in common:
        sl, k, nz, t = read_slice(fields[s], a)
        x, v, r = read_particles(parts[s])
        if nz > 1:  # 3D: the middle z slice and the particles within a diameter of it
            keep = np.abs(x[:, 2] - (k + 0.5)) < 2 * r
            x, v, r = x[keep], v[keep], r[keep]
            # The disk a sphere cuts from the slice plane.
            r = np.sqrt(np.maximum(r ** 2 - (x[:, 2] - (k + 0.5)) ** 2, 0.0))
        panels.append((s, t, sl * V, x * L, v[:, a] * V, r * L))
        vmax = max(vmax, float(np.max(np.abs(sl))) * V, float(np.max(np.abs(v[:, a])) if len(v) else 0.0) * V)
    vmax = vmax if vmax > 0 else 1.0
    ny, nx = panels[0][2].shape
    width = 4.0 * len(panels)
    height = min(12.0, max(3.0, 4.0 * ny / nx))
    fig, axs = plt.subplots(1, len(panels), figsize=(width, height + 0.8), squeeze=False, layout="constrained")
    for ax, (s, t, sl, x, vc, r) in zip(axs[0], panels):
        im = ax.imshow(sl, origin="lower", extent=[0, nx * L, 0, ny * L], cmap="RdBu_r", vmin=-vmax, vmax=vmax,
                       interpolation="nearest")
        if len(r):
            ec = EllipseCollection(2 * r, 2 * r, np.zeros_like(r), units="xy", offsets=x[:, :2],
                                   offset_transform=ax.transData, cmap="RdBu_r", edgecolors="k", linewidths=0.2)
            ec.set_array(vc)
            ec.set_clim(-vmax, vmax)
            ax.add_collection(ec)
        ax.set_title(f"step {s}, t = {t:.4g} {names[1]}")
        ax.set_xlabel(f"x [{names[0]}]")
        ax.set_ylabel(f"y [{names[0]}]")
        ax.set_aspect("equal")
    cb = fig.colorbar(im, ax=axs[0].tolist(), shrink=0.8)
    cb.set_label(f"velocity {comp} (gas: map, particles: disks) [{names[2]}]")
    path = os.path.join(out, "snapshots.png")
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return path


def plot_series(run, out, summary):
    s = read_series(run)
    if not s or "slip_y" not in s:
        print("series.csv has no suspension statistics (an older run?)", file=sys.stderr)
        return None
    _, _, V, names = scales(summary)
    lat = summary.get("lattice", {})
    g = np.array(lat.get("gravity", [0, -1, 0]), dtype=float)
    gn = np.linalg.norm(g)
    down = -g / gn if gn > 0 else np.array([0.0, 1.0, 0.0])
    t = s["time"]
    slip = (s["slip_x"] * down[0] + s["slip_y"] * down[1] + s["slip_z"] * down[2]) * V
    st = summary.get("statistics", {})
    fig, axs = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    ax = axs[0][0]
    ax.plot(t, slip, lw=1, label="slip (fluid over fluid volume - particles)")
    if st.get("wen_yu_slip"):
        ax.axhline(st["wen_yu_slip"] * V, color="k", ls="--", lw=1, label="Wen-Yu homogeneous")
    if st.get("averaged_samples"):
        ax.axhline(st["mean_slip"] * V, color="C3", ls=":", lw=1, label="mean of the run's second half")
    ref = summary.get("reference")
    if ref:
        ax.axhline(ref["slip"] * V, color="C2", ls="--", lw=1, label="Stokes, periodic array")
    ax.set_ylabel(f"slip along -g [{names[2]}]")
    ax.legend(fontsize=8)
    ax = axs[0][1]
    ax.plot(t, s["drag_over_weight"], lw=1)
    ax.axhline(1.0, color="k", ls="--", lw=1)
    ax.set_ylabel("drag / net weight")
    ax = axs[1][0]
    ax.plot(t, s["granular_temperature"] * V * V, lw=1, label="T = mean variance")
    for c in "xyz":
        if f"var_v{c}" in s:
            ax.plot(t, s[f"var_v{c}"] * V * V, lw=0.6, label=f"var v{c}")
    ax.set_ylabel(f"granular temperature [{names[2]}^2]")
    ax.legend(fontsize=8)
    ax = axs[1][1]
    for h in s:
        m = re.match(r"phi_var_rel_(.+)d$", h)
        if m:
            ax.plot(t, s[h], lw=1, label=f"filter {m.group(1)} d")
    ax.axhline(1.0, color="k", ls="--", lw=1)
    ax.set_ylabel("solid-fraction variance / random")
    ax.legend(fontsize=8)
    for ax in axs[1]:
        ax.set_xlabel(f"time [{names[1]}]")
    fig.suptitle(os.path.basename(os.path.normpath(run)))
    fig.tight_layout()
    path = os.path.join(out, "series.png")
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return path


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run")
    p.add_argument("--out")
    p.add_argument("--steps", help="comma-separated output steps for snapshots.png (default: the last four)")
    p.add_argument("--component", default="y", choices=list(AXES), help="velocity component drawn (default y)")
    a = p.parse_args()
    out = a.out or a.run
    os.makedirs(out, exist_ok=True)
    summary = read_summary(a.run)
    steps = [int(x) for x in a.steps.split(",")] if a.steps else None
    for path in (plot_snapshots(a.run, out, summary, steps, a.component), plot_series(a.run, out, summary)):
        if path:
            print(path)


if __name__ == "__main__":
    main()
