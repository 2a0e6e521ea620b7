#!/usr/bin/env python3
"""Compares fluidized_bed runs of Mueller et al.'s bed with the measured profiles.

    compare_mueller.py --run LABEL CASE RUN_DIR [--run ...] [--reference LABEL] [--out DIR] [--data DIR]

CASE is u06 or u09 (the superficial velocity 0.6 or 0.9 m/s, which selects the
measured profiles of bench/cfd/mueller2009/); RUN_DIR holds the run's
profiles.csv (cases/src/cfd_case.cpp: quantity,height,x,value,samples[,standard_error];
one row per gas cell along x, the time average over y and over the statistics
window, and its standard error from batch means where the run wrote one).

Per run and measured profile:
  rms         root mean square of (simulation - measurement) over the measured
              points, the simulation interpolated linearly in x to them (held
              constant beyond its outermost cell centres);
  centre      the simulation and the measurement at the bed's centre x = 22 mm
              (each interpolated linearly);
  wall        the mean over both walls of the simulation and the measurement at
              the measured point nearest each wall;
  noise       the RMS over the measured points of the simulation's standard
              error (null where profiles.csv has none).
With --reference LABEL, every other run of the same case is also compared with
that run, profile by profile on the simulation's own cells (comparison_runs.jsonl,
and a second table): the RMS of their difference, the RMS of their combined
standard error sqrt(se_a^2 + se_b^2), and "within_noise" when the difference is
at most twice the combined error (two standard errors: the batch means' own
estimate of the error is uncertain by about a third with five blocks).
The simulated profile must be sampled at the measured height (within 0.01 mm);
a height between two sampled ones is interpolated linearly between them (said in
the "sim_height" column); otherwise the profile is reported as not sampled.

Writes DIR/comparison.md (a markdown table, also printed), DIR/comparison.jsonl
(one JSON object per row) and, with matplotlib, DIR/mueller_<case>_<profile>.png
(every run of that case and the measured points). Exit 0; 2 on a missing or
malformed profiles.csv; 77 without numpy (the CTest's skip code).
"""
import argparse
import json
import math
import os
import sys

try:
    import numpy as np
except ImportError:  # the CTest skips (its SKIP_RETURN_CODE)
    print("compare_mueller.py: numpy is not installed (apt install python3-numpy); skipped")
    sys.exit(77)

HERE = os.path.dirname(os.path.abspath(__file__))
BED_WIDTH = 0.044  # m, along x (the case files' domain)
CENTRE = 0.5 * BED_WIDTH

# (case, quantity as in profiles.csv, height [m], file, x offset [m] added to the file's x, target RMS)
PROFILES = [
    ("u06", "void_fraction", 0.0164, "u06_void_fraction_z16.4mm.dat", 0.0, 0.03),
    ("u06", "void_fraction", 0.0312, "u06_void_fraction_z31.2mm.dat", 0.0, 0.03),
    ("u06", "particle_velocity_z", 0.020, "u06_particle_vz_z20mm.dat", CENTRE, 0.025),
    ("u09", "void_fraction", 0.0164, "u09_void_fraction_z16.4mm.dat", 0.0, 0.03),
    ("u09", "void_fraction", 0.0312, "u09_void_fraction_z31.2mm.dat", 0.0, 0.03),
    ("u09", "particle_velocity_z", 0.015, "u09_particle_vz_z15mm.dat", 0.0, 0.025),
    ("u09", "particle_velocity_z", 0.025, "u09_particle_vz_z25mm.dat", 0.0, 0.025),
    ("u09", "particle_velocity_z", 0.035, "u09_particle_vz_z35mm.dat", 0.0, 0.025),
]
HEIGHT_TOL = 1e-5  # m


def fail(msg):
    print("compare_mueller.py: " + msg, file=sys.stderr)
    sys.exit(2)


def read_measured(data_dir, name, offset):
    path = os.path.join(data_dir, name)
    try:
        a = np.loadtxt(path, ndmin=2)
    except (OSError, ValueError) as e:
        fail("cannot read the measured profile %s: %s" % (path, e))
    if a.shape[1] < 2 or a.shape[0] < 2:
        fail("%s: expected two columns (x [m], value) and at least two rows" % path)
    order = np.argsort(a[:, 0] + offset)
    return a[order, 0] + offset, a[order, 1]


def read_profiles(run_dir):
    """{(quantity, height): (x, value, min samples, standard error or None)} from RUN_DIR/profiles.csv."""
    path = os.path.join(run_dir, "profiles.csv")
    if not os.path.isfile(path):
        fail("%s: no profiles.csv (does the case have statistics.profiles, and did the run end?)" % run_dir)
    rows = {}
    with open(path) as f:
        head = f.readline().strip()
        heads = ("quantity,height,x,value,samples", "quantity,height,x,value,samples,standard_error")
        if head not in heads:
            fail("%s: header '%s', expected '%s' or '%s'" % (path, head, heads[0], heads[1]))
        fields = head.count(",") + 1
        for n, line in enumerate(f, start=2):
            parts = line.strip().split(",")
            if not parts or parts == [""]:
                continue
            if len(parts) != fields:
                fail("%s line %d: expected %d fields" % (path, n, fields))
            try:
                nums = [float(p) for p in parts[1:]]
            except ValueError:
                fail("%s line %d: not numbers" % (path, n))
            if fields == 5:
                nums.append(float("nan"))
            rows.setdefault((parts[0], nums[0]), []).append(tuple(nums[1:]))
    out = {}
    for key, r in rows.items():
        r.sort()
        a = np.array(r)
        ok = np.isfinite(a[:, 1])
        if ok.sum() < 1:
            continue
        se = a[ok, 3]
        out[key] = (a[ok, 0], a[ok, 1], float(a[:, 2].min()), se if np.all(np.isfinite(se)) else None)
    return out


def simulated(profiles, quantity, height):
    """(x, values, samples, description, standard error or None) at `height`: sampled there, or between the
    two nearest sampled heights (the errors then combined as of independent averages)."""
    hs = sorted(h for (q, h) in profiles if q == quantity)
    for h in hs:
        if abs(h - height) <= HEIGHT_TOL:
            x, v, s, se = profiles[(quantity, h)]
            return x, v, s, "%.4g mm" % (1e3 * h), se
    below = [h for h in hs if h < height]
    above = [h for h in hs if h > height]
    if not below or not above:
        return None
    h0, h1 = below[-1], above[0]
    x0, v0, s0, e0 = profiles[(quantity, h0)]
    x1, v1, s1, e1 = profiles[(quantity, h1)]
    x = np.union1d(x0, x1)
    w = (height - h0) / (h1 - h0)
    v = (1 - w) * np.interp(x, x0, v0) + w * np.interp(x, x1, v1)
    se = None
    if e0 is not None and e1 is not None:
        se = np.sqrt(((1 - w) * np.interp(x, x0, e0)) ** 2 + (w * np.interp(x, x1, e1)) ** 2)
    return x, v, min(s0, s1), "%.4g-%.4g mm interpolated" % (1e3 * h0, 1e3 * h1), se


def rms(a):
    return float(np.sqrt(np.mean(np.asarray(a) ** 2)))


def compare_runs(a, b):
    """A run's profile against a reference run's: (RMS difference, RMS combined error or None, points)."""
    xa, va, sa = a
    xb, vb, sb = b
    x = np.union1d(xa, xb)
    d = np.interp(x, xa, va) - np.interp(x, xb, vb)
    noise = None
    if sa is not None and sb is not None:
        noise = rms(np.sqrt(np.interp(x, xa, sa) ** 2 + np.interp(x, xb, sb) ** 2))
    return rms(d), noise, int(len(x))


def compare(xs, vs, xm, vm):
    """RMS, centre and wall values of a simulated profile (xs, vs) against a measured one (xm, vm)."""
    at = np.interp(xm, xs, vs)
    rms = float(np.sqrt(np.mean((at - vm) ** 2)))
    sim_c = float(np.interp(CENTRE, xs, vs))
    exp_c = float(np.interp(CENTRE, xm, vm))
    sim_w = float(0.5 * (at[0] + at[-1]))
    exp_w = float(0.5 * (vm[0] + vm[-1]))
    return rms, sim_c, exp_c, sim_w, exp_w


def fmt(v):
    return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) else "%.3f" % v


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--run", nargs=3, action="append", metavar=("LABEL", "CASE", "RUN_DIR"), required=True,
                    help="a run to compare: its label, u06 or u09, its folder")
    ap.add_argument("--out", default=".", help="folder for comparison.md, comparison.jsonl and the PNGs")
    ap.add_argument("--data", default=os.path.join(HERE, "mueller2009"), help="folder of the measured profiles")
    ap.add_argument("--reference", metavar="LABEL",
                    help="compare every other run of the same case with this run (its label in --run)")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    runs = []
    for label, case, run_dir in args.run:
        if case not in ("u06", "u09"):
            fail("--run %s: case '%s' (valid: u06, u09)" % (label, case))
        runs.append((label, case, read_profiles(run_dir)))
    if args.reference is not None and args.reference not in [r[0] for r in runs]:
        fail("--reference %s: no --run has that label (labels: %s)" % (args.reference, ", ".join(r[0] for r in runs)))

    rows = []
    curves = {}  # (case, quantity, height) -> [(label, x, v)]
    for label, case, prof in runs:
        for pc, quantity, height, name, offset, target in PROFILES:
            if pc != case:
                continue
            xm, vm = read_measured(args.data, name, offset)
            sim = simulated(prof, quantity, height)
            row = {"run": label, "case": case, "quantity": quantity, "height_mm": round(1e3 * height, 3),
                   "measured_points": int(len(xm)), "target_rms": target}
            if sim is None:
                row.update({"sim_height": "not sampled", "rms": None, "sim_centre": None, "exp_centre": None,
                            "sim_wall": None, "exp_wall": None, "within_target": None, "sim_samples": None,
                            "noise": None})
            else:
                xs, vs, samples, desc, se = sim
                r, sc, ec, sw, ew = compare(xs, vs, xm, vm)
                row.update({"sim_height": desc, "rms": r, "sim_centre": sc, "exp_centre": ec, "sim_wall": sw,
                            "exp_wall": ew, "within_target": bool(r <= target), "sim_samples": samples,
                            "noise": None if se is None else rms(np.interp(xm, xs, se))})
                curves.setdefault((case, quantity, height), []).append((label, xs, vs, se))
            rows.append(row)

    lines = ["| run | profile | height | sim height | RMS | target | noise | centre sim | centre exp | wall sim | wall exp |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        q = "void fraction" if r["quantity"] == "void_fraction" else "particle vz [m/s]"
        ok = "" if r["within_target"] is None else (" ok" if r["within_target"] else " **over**")
        lines.append("| %s | %s %s | %g mm | %s | %s%s | %g | %s | %s | %s | %s | %s |" % (
            r["run"], r["case"], q, r["height_mm"], r["sim_height"], fmt(r["rms"]), ok, r["target_rms"],
            fmt(r["noise"]), fmt(r["sim_centre"]), fmt(r["exp_centre"]), fmt(r["sim_wall"]), fmt(r["exp_wall"])))
    lines.append("")
    lines.append("RMS: simulation interpolated to the measured x; centre: x = 22 mm; wall: mean of both walls at the "
                 "measured points nearest them. Measured: Mueller et al., Particuology 7 (2009) 297-306 "
                 "(bench/cfd/mueller2009/README.md). noise: RMS of the simulation's standard error (batch means) "
                 "at the measured points.")
    pairs = []
    if args.reference is not None:
        ref = next(r for r in runs if r[0] == args.reference)
        for (case, quantity, height), cs in sorted(curves.items()):
            if case != ref[1]:
                continue
            base = next((c for c in cs if c[0] == ref[0]), None)
            if base is None:
                continue
            for label, xs, vs, se in cs:
                if label == ref[0]:
                    continue
                d, noise, n = compare_runs((xs, vs, se), (base[1], base[2], base[3]))
                pairs.append({"run": label, "reference": ref[0], "case": case, "quantity": quantity,
                              "height_mm": round(1e3 * height, 3), "points": n, "rms_difference": d,
                              "combined_noise": noise,
                              "within_noise": None if noise is None else bool(d <= 2 * noise)})
        lines += ["", "| run | reference | profile | height | RMS difference | combined noise | within 2 noise |",
                  "|---|---|---|---|---|---|---|"]
        for p in pairs:
            q = "void fraction" if p["quantity"] == "void_fraction" else "particle vz [m/s]"
            w = "n/a" if p["within_noise"] is None else ("yes" if p["within_noise"] else "**no**")
            lines.append("| %s | %s | %s %s | %g mm | %s | %s | %s |" % (
                p["run"], p["reference"], p["case"], q, p["height_mm"], fmt(p["rms_difference"]),
                fmt(p["combined_noise"]), w))
        with open(os.path.join(args.out, "comparison_runs.jsonl"), "w") as f:
            for p in pairs:
                f.write(json.dumps(p) + "\n")
    table = "\n".join(lines) + "\n"
    with open(os.path.join(args.out, "comparison.md"), "w") as f:
        f.write(table)
    with open(os.path.join(args.out, "comparison.jsonl"), "w") as f:
        for r in rows:
            f.write(json.dumps(r) + "\n")
    print(table, end="")

    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("(matplotlib not installed: no PNGs; apt install python3-matplotlib)")
        return 0
    for pc, quantity, height, name, offset, _ in PROFILES:
        if not any(r[1] == pc for r in runs):
            continue
        xm, vm = read_measured(args.data, name, offset)
        fig, ax = plt.subplots(figsize=(5, 3.5))
        ax.plot(1e3 * xm, vm, "ko", ms=4, label="Mueller et al. 2009 (MRI)")
        for label, xs, vs, se in curves.get((pc, quantity, height), []):
            line, = ax.plot(1e3 * xs, vs, "-", label=label)
            if se is not None:
                ax.fill_between(1e3 * xs, vs - 2 * se, vs + 2 * se, color=line.get_color(), alpha=0.2, lw=0)
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("void fraction" if quantity == "void_fraction" else "particle vz [m/s]")
        ax.set_title("U = %s m/s, z = %g mm" % ("0.6" if pc == "u06" else "0.9", 1e3 * height))
        ax.set_xlim(0, 1e3 * BED_WIDTH)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(args.out, "mueller_%s_%s_%gmm.png" % (pc, quantity, 1e3 * height)), dpi=110)
        plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
