#!/usr/bin/env python3
"""Fit of the PSM weighting parameter t(tau) from plane walls (bench/imb/NOTES.md,
"Where the PSM wall sits").

The Noble-Torczynski weight B = eps t / ((1 - eps) + t) with t = tau - 1/2 puts
the plane PSM wall at a tau-dependent place. For each tau this finds the t for
which the wall shift, averaged over the wall cell's solid fraction, equals its
tau -> 1/2 value (tau = 0.505), by bisection on runs of
`lbdem_bench_psm wall` (Couette, the given Lambda).

usage: psm_wall_rule.py BENCH [--magic 1e-4] [--tau 0.52,0.55,...] [--flow couette]
"""
import argparse, json, subprocess, sys

EPS = "0.05,0.15,0.25,0.35,0.45,0.55,0.65,0.75,0.85,0.95"

def mean_delta(bench, tau, magic, weight, flow):
    out = subprocess.run([bench, "wall", "--tau", str(tau), "--magic", str(magic), "--eps", EPS, "--flows", flow,
                          "--weights", weight], capture_output=True, text=True, check=True).stdout
    d = [float(l.split("|")[8]) for l in out.splitlines() if l.startswith("| " + flow)]
    return sum(d) / len(d)

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bench")
    ap.add_argument("--magic", default="1e-4")
    ap.add_argument("--tau", default="0.52,0.55,0.6,0.7,0.8,1.0")
    ap.add_argument("--flow", default="couette")
    a = ap.parse_args()
    target = mean_delta(a.bench, 0.505, a.magic, "nt", a.flow)
    rows = [{"tau": 0.505, "t": 0.005, "delta": target}]
    print(f"target mean shift (tau 0.505, NT): {target:+.5f}", file=sys.stderr)
    for tau in [float(x) for x in a.tau.split(",")]:
        tm = tau - 0.5
        lo, hi = tm, 4 * tm  # the shift falls as t grows (stronger solid)
        for _ in range(18):
            mid = 0.5 * (lo + hi)
            if mean_delta(a.bench, tau, a.magic, f"t={mid:.8g}", a.flow) > target: lo = mid
            else: hi = mid
        t = 0.5 * (lo + hi)
        rows.append({"tau": tau, "t": t, "t_over_tm": t / tm,
                     "delta_nt": mean_delta(a.bench, tau, a.magic, "nt", a.flow)})
        print(f"tau {tau}: t = {t:.6f} (t/(tau-1/2) = {t/tm:.4f}), NT mean shift {rows[-1]['delta_nt']:+.5f}", file=sys.stderr)
    json.dump({"magic": float(a.magic), "flow": a.flow, "eps": EPS, "target": target, "rows": rows}, sys.stdout, indent=1)

if __name__ == "__main__":
    main()
