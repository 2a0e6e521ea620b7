#!/usr/bin/env python3
"""Test of compare_mueller.py on synthetic runs with a known answer (CTest CompareMueller.KnownRms).

Run u06/u09 "shifted": profiles.csv holds every measured profile at the measured
x, each shifted by its own constant c; the simulation interpolated to the
measured points is then the measurement plus c, so the RMS difference is |c|
and the centre and wall differences are c, to round-off (asserted to 1e-9).
Run u09 "between": constant void-fraction profiles 0.40 at 10 mm and 0.70 at
40 mm only: the 16.4 and 31.2 mm profiles are interpolated between them
(0.464 and 0.612 everywhere), the velocity profiles are reported as not
sampled. Runs "se_a", "se_b", "se_c" (u09, with the standard_error column, 0.01
everywhere) hold the measurement plus 0, 0.01 and 0.04: each reports a noise of
0.01; against --reference se_a, b differs by 0.01 RMS with a combined noise of
0.01 sqrt(2) (within two of it), c by 0.04 (not within). Exit 77 (skipped)
without numpy.
"""
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
try:
    import numpy  # noqa: F401
except ImportError:
    print("numpy missing: skipped")
    sys.exit(77)
import compare_mueller as cm  # noqa: E402

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print("FAIL: " + what)


def main():
    tmp = tempfile.mkdtemp(prefix="compare_mueller_")
    shifts = {}
    for case in ("u06", "u09"):
        d = os.path.join(tmp, case)
        os.makedirs(d)
        with open(os.path.join(d, "profiles.csv"), "w") as f:
            f.write("quantity,height,x,value,samples\n")
            for k, (pc, q, h, name, offset, _) in enumerate(cm.PROFILES):
                if pc != case:
                    continue
                c = (0.0035 + 0.003 * k) * (1 if k % 2 == 0 else -1)
                shifts[(case, q, round(1e3 * h, 3))] = c
                xm, vm = cm.read_measured(os.path.join(HERE, "mueller2009"), name, offset)
                for x, v in zip(xm, vm):
                    f.write("%s,%.6g,%r,%r,100\n" % (q, h, float(x), float(v + c)))
    between = os.path.join(tmp, "between")
    os.makedirs(between)
    with open(os.path.join(between, "profiles.csv"), "w") as f:
        f.write("quantity,height,x,value,samples\n")
        for h, v in ((0.01, 0.40), (0.04, 0.70)):
            for i in range(22):
                f.write("void_fraction,%g,%g,%g,50\n" % (h, 1e-3 + 2e-3 * i, v))
    out = os.path.join(tmp, "out")
    r = subprocess.run([sys.executable, os.path.join(HERE, "compare_mueller.py"), "--out", out,
                        "--run", "shifted06", "u06", os.path.join(tmp, "u06"),
                        "--run", "shifted09", "u09", os.path.join(tmp, "u09"),
                        "--run", "between", "u09", between], capture_output=True, text=True)
    print(r.stdout, r.stderr)
    check(r.returncode == 0, "compare_mueller.py exit %d" % r.returncode)
    rows = [json.loads(l) for l in open(os.path.join(out, "comparison.jsonl"))]
    check(len(rows) == 3 + 5 + 5, "%d rows (3 + 5 + 5 expected)" % len(rows))
    for row in rows:
        key = (row["case"], row["quantity"], row["height_mm"])
        if row["run"].startswith("shifted"):
            c = shifts[key]
            check(abs(row["rms"] - abs(c)) < 1e-9, "%s: RMS %r, expected %r" % (key, row["rms"], abs(c)))
            check(abs(row["sim_centre"] - row["exp_centre"] - c) < 1e-9, "%s: centre difference" % (key,))
            check(abs(row["sim_wall"] - row["exp_wall"] - c) < 1e-9, "%s: wall difference" % (key,))
            check(row["within_target"] == (abs(c) <= row["target_rms"]), "%s: within_target" % (key,))
        elif row["quantity"] == "void_fraction":
            want = 0.40 + 0.30 * (row["height_mm"] - 10.0) / 30.0
            check(abs(row["sim_centre"] - want) < 1e-9, "between %s: centre %r, expected %r" %
                  (key, row["sim_centre"], want))
            check("interpolated" in row["sim_height"], "between %s: %s" % (key, row["sim_height"]))
        else:
            check(row["rms"] is None and row["sim_height"] == "not sampled", "between %s: %r" % (key, row))
    table = open(os.path.join(out, "comparison.md")).read()
    check(table.count("\n| ") == 13, "markdown table: 13 rows below its header")
    try:
        import matplotlib  # noqa: F401
        pngs = [f for f in os.listdir(out) if f.endswith(".png")]
        check(len(pngs) == 8, "%d PNGs (8 expected: one per measured profile)" % len(pngs))
    except ImportError:
        print("matplotlib missing: PNGs not checked")
    # Runs with standard errors, compared with one of them.
    offsets = {"se_a": 0.0, "se_b": 0.01, "se_c": 0.04}
    for label, off in offsets.items():
        d = os.path.join(tmp, label)
        os.makedirs(d)
        with open(os.path.join(d, "profiles.csv"), "w") as f:
            f.write("quantity,height,x,value,samples,standard_error\n")
            for pc, q, h, name, offset, _ in cm.PROFILES:
                if pc != "u09":
                    continue
                xm, vm = cm.read_measured(os.path.join(HERE, "mueller2009"), name, offset)
                for x, v in zip(xm, vm):
                    f.write("%s,%.6g,%r,%r,100,0.01\n" % (q, h, float(x), float(v + off)))
    out2 = os.path.join(tmp, "out2")
    args = [sys.executable, os.path.join(HERE, "compare_mueller.py"), "--out", out2, "--reference", "se_a"]
    for label in offsets:
        args += ["--run", label, "u09", os.path.join(tmp, label)]
    r = subprocess.run(args, capture_output=True, text=True)
    print(r.stdout, r.stderr)
    check(r.returncode == 0, "compare_mueller.py --reference exit %d" % r.returncode)
    rows = [json.loads(l) for l in open(os.path.join(out2, "comparison.jsonl"))]
    check(len(rows) == 15 and all(abs(row["noise"] - 0.01) < 1e-12 for row in rows), "noise 0.01 in 15 rows")
    pairs = [json.loads(l) for l in open(os.path.join(out2, "comparison_runs.jsonl"))]
    check(len(pairs) == 10, "%d run pairs (10 expected)" % len(pairs))
    for p in pairs:
        off = offsets[p["run"]]
        check(abs(p["rms_difference"] - off) < 1e-9, "%s: difference %r, expected %r" % (p["run"], p["rms_difference"], off))
        check(abs(p["combined_noise"] - 0.01 * 2 ** 0.5) < 1e-12, "%s: combined noise %r" % (p["run"], p["combined_noise"]))
        check(p["within_noise"] == (p["run"] == "se_b"), "%s: within_noise %r" % (p["run"], p["within_noise"]))
    r = subprocess.run(args[:5] + ["nobody"] + args[6:], capture_output=True, text=True)
    check(r.returncode == 2 and "--reference nobody" in r.stderr, "unknown --reference refused: %r" % r.stderr)
    if failures:
        print("%d failures; files kept in %s" % (len(failures), tmp))
        return 1
    import shutil
    shutil.rmtree(tmp, ignore_errors=True)
    print("ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
