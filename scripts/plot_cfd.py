#!/usr/bin/env python3
"""Plots of the fluidized_bed scene (cases/src/cfd_case.cpp).

  plot_cfd.py sweep SWEEP.csv [--particles 190 --diameter 1.2e-3 --area 1.6e-5 ...]
      pressure drop over the bed's buoyant weight per area against the superficial velocity
      (scripts/cfd_sweep.sh), with Ergun's law at the packing of the slowest (fixed-bed) run and the
      weight (ratio 1); U_mf from the fixed-bed points (a U + b U^2 through them, where it reaches 1)
      against Ergun's and Wen & Yu's (Re_mf = sqrt(33.7^2 + 0.0408 Ar) - 33.7). Writes SWEEP.png.
  plot_cfd.py run DIR [--validation cfd/validation]
      a run's series.csv (pressure drop over weight, bed height against time) and profiles.csv (the
      time-averaged void fraction and particle vertical velocity across the bed), with measured
      profiles from the validation folder where a file matches (CSV x,value with a header, named
      <case>_<quantity>_<height in mm>mm.csv, e.g. muller_u06_void_fraction_16.4mm.csv). Writes
      DIR/series.png and DIR/profiles.png.
Without matplotlib the numbers are printed only.
"""
import argparse
import csv
import math
import os
import sys


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def pyplot():
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        return plt
    except ImportError:
        print("(matplotlib not installed: no figure)")
        return None


def ergun_ratio(u, phi, a):
    """Ergun's pressure drop over the buoyant bed weight, per unit bed height (independent of it)."""
    eps = 1 - phi
    dp_per_l = 150 * a.mu * u * phi ** 2 / (eps ** 3 * a.diameter ** 2) + 1.75 * a.rho_g * u ** 2 * phi / (eps ** 3 * a.diameter)
    return dp_per_l / ((a.rho_s - a.rho_g) * a.g * phi)


def sweep(a):
    rows = sorted(read_csv(a.csv), key=lambda r: float(r["velocity"]))
    u = [float(r["velocity"]) for r in rows]
    ratio = [float(r["pressure_drop_over_weight"]) for r in rows]
    height = [float(r["bed_height"]) for r in rows]
    vp = math.pi / 6 * a.diameter ** 3
    phi = a.phi if a.phi else a.particles * vp / (a.area * height[0])
    # U_mf from the fixed-bed points (ratio < 0.9): least squares a U + b U^2.
    fixed = [(x, y) for x, y in zip(u, ratio) if y < 0.9]
    umf_sim = float("nan")
    if len(fixed) >= 2:
        s11 = sum(x * x for x, _ in fixed); s12 = sum(x ** 3 for x, _ in fixed); s22 = sum(x ** 4 for x, _ in fixed)
        t1 = sum(x * y for x, y in fixed); t2 = sum(x * x * y for x, y in fixed)
        det = s11 * s22 - s12 * s12
        ca, cb = (t1 * s22 - t2 * s12) / det, (s11 * t2 - s12 * t1) / det
        umf_sim = (-ca + math.sqrt(ca * ca + 4 * cb)) / (2 * cb) if cb != 0 else 1 / ca
    lo, hi = 0.0, 10.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ergun_ratio(mid, phi, a) < 1 else (lo, mid)
    umf_ergun = 0.5 * (lo + hi)
    ar = a.rho_g * (a.rho_s - a.rho_g) * a.g * a.diameter ** 3 / a.mu ** 2
    umf_wy = (math.sqrt(33.7 ** 2 + 0.0408 * ar) - 33.7) * a.mu / (a.rho_g * a.diameter)
    print(f"{'U [m/s]':>8} {'dp/W':>8} {'Ergun':>8} {'bed height [m]':>15}")
    for x, y, h in zip(u, ratio, height):
        print(f"{x:8.3f} {y:8.4f} {min(1.0, ergun_ratio(x, phi, a)):8.4f} {h:15.5f}")
    print(f"packing of the fixed bed phi = {phi:.3f}")
    print(f"U_mf: from the fixed-bed points {umf_sim:.4f} m/s, Ergun at phi {umf_ergun:.4f} m/s "
          f"({(umf_sim / umf_ergun - 1) * 100:+.1f} %), Wen-Yu {umf_wy:.4f} m/s ({(umf_sim / umf_wy - 1) * 100:+.1f} %)")
    plt = pyplot()
    if not plt:
        return
    fig, ax = plt.subplots(figsize=(6, 4.5))
    us = [i * max(u) * 1.1 / 200 for i in range(201)]
    ax.plot(us, [ergun_ratio(x, phi, a) for x in us], "--", label=f"Ergun, $\\phi$ = {phi:.3f}")
    ax.axhline(1.0, color="k", lw=0.8, label="bed weight / area")
    ax.axvline(umf_wy, color="gray", ls=":", label=f"Wen-Yu $U_{{mf}}$ = {umf_wy:.3f} m/s")
    ax.plot(u, ratio, "o-", label="lbdem fluidized_bed")
    ax.set_ylim(0, 1.5)
    ax.set_xlabel("superficial velocity U [m/s]")
    ax.set_ylabel("pressure drop / (buoyant weight / area)")
    ax.legend()
    fig.tight_layout()
    png = os.path.splitext(a.csv)[0] + ".png"
    fig.savefig(png, dpi=120)
    print("wrote", png)


def run(a):
    d = a.dir
    name = os.path.basename(os.path.normpath(d))
    series = read_csv(os.path.join(d, "series.csv"))
    t = [float(r["time"]) for r in series]
    ratio = [float(r["pressure_drop_over_weight"]) for r in series]
    height = [float(r["bed_height"]) for r in series]
    prof_path = os.path.join(d, "profiles.csv")
    profiles = {}
    if os.path.exists(prof_path):
        for r in read_csv(prof_path):
            profiles.setdefault((r["quantity"], float(r["height"])), []).append(
                (float(r["x"]), float(r["value"]) if r["value"] != "nan" else float("nan")))
    for (q, h), pts in sorted(profiles.items()):
        print(f"{name}: {q} at z = {h * 1000:.1f} mm:")
        print("  " + "  ".join(f"{x * 1000:.1f}:{v:.3f}" for x, v in pts))
    plt = pyplot()
    if not plt:
        return
    fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    ax[0].plot(t, ratio)
    ax[0].axhline(1.0, color="k", lw=0.8)
    ax[0].set_ylabel("pressure drop / weight")
    ax[1].plot(t, height)
    ax[1].set_ylabel("bed height [m]")
    ax[1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(os.path.join(d, "series.png"), dpi=110)
    if profiles:
        n = len(profiles)
        fig, axs = plt.subplots(1, n, figsize=(4.5 * n, 4))
        axs = axs if n > 1 else [axs]
        for axp, ((q, h), pts) in zip(axs, sorted(profiles.items())):
            axp.plot([x * 1000 for x, _ in pts], [v for _, v in pts], "o-", label="lbdem")
            ref = os.path.join(a.validation, f"{name}_{q}_{h * 1000:g}mm.csv") if a.validation else ""
            if ref and os.path.exists(ref):
                rr = list(csv.reader(open(ref)))[1:]
                axp.plot([float(r[0]) * 1000 for r in rr], [float(r[1]) for r in rr], "s", label="experiment")
            axp.set_title(f"{q}, z = {h * 1000:g} mm")
            axp.set_xlabel("x [mm]")
            axp.legend()
        fig.tight_layout()
        fig.savefig(os.path.join(d, "profiles.png"), dpi=110)
    print("wrote figures in", d)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="mode", required=True)
    s = sub.add_parser("sweep")
    s.add_argument("csv")
    s.add_argument("--particles", type=int, default=190)
    s.add_argument("--diameter", type=float, default=1.2e-3)
    s.add_argument("--area", type=float, default=1.6e-5, help="bed cross-section [m^2]")
    s.add_argument("--rho-s", dest="rho_s", type=float, default=1000.0)
    s.add_argument("--rho-g", dest="rho_g", type=float, default=1.225)
    s.add_argument("--mu", type=float, default=1.8e-5)
    s.add_argument("--g", type=float, default=9.80665)
    s.add_argument("--phi", type=float, default=0.0, help="fixed-bed packing (default: from the slowest run)")
    r = sub.add_parser("run")
    r.add_argument("dir")
    r.add_argument("--validation", default="")
    a = p.parse_args()
    sweep(a) if a.mode == "sweep" else run(a)


if __name__ == "__main__":
    sys.exit(main())
