#!/usr/bin/env python3
"""The mass drift into covered PSM cells, in a small numpy model of the PSM
collision (bench/imb/NOTES.md, "Mass drift into covered cells").

D3Q19, TRT, Guo forcing, B = eps t / ((1 - eps) + t) (t of the wall rule or
tau - 1/2), the solid term of imb/psm.hpp; the simple cubic array of
lbdem_bench_psm sweep (spheres on cell centres, body force for Re_p from the
reference K, start from the Stokes estimate), fractions by 8^3 sub-samples per
cell instead of the exact overlap. Operators:
  nebb   paper Eq. 2 as the kernels had it: f_qb - f_q + f^eq_q(rho, V) - f^eq_qb(rho, u)
  odd    its odd part (the kernels now): f_qb - f_q + 3 w rho c.(V + u)
  super  superposition: f^eq(V) - f^eq(u) - Omega^F
Prints, every `every` steps, the mean fluid density sum (1 - eps) rho / sum (1 - eps),
the mean density of the covered cells (eps = 1), the total (conserved) and the
superficial velocity over the target U.

usage: psm_mass_drift.py [tau=1.0] [lam=4.6e-4] [L=5] [d=4.342453] [rep=2] [steps=2000] [every=500]
                         [op=nebb|odd|super] [weight=ntw|nt|eps] [re=0.2] [Kref=15.4]
  (defaults: the dense array of bench/results/drag_map_host.md, d/l 4.34, chi 0.8685, two periods)
"""
import math, sys
import numpy as np

c = [(0, 0, 0)]
for a in range(3):
    for s in (1, -1):
        v = [0, 0, 0]; v[a] = s; c.append(tuple(v))
for a, b in ((0, 1), (0, 2), (1, 2)):
    for s1 in (1, -1):
        for s2 in (1, -1):
            v = [0, 0, 0]; v[a] = s1; v[b] = s2; c.append(tuple(v))
c = np.array(c)
Q = 19
w = np.array([1 / 3] + [1 / 18] * 6 + [1 / 36] * 12)[:, None, None, None]
opp = np.array([np.where((c == -c[q]).all(1))[0][0] for q in range(Q)])


def run(tau=1.0, lam=4.6e-4, L=5, d=4.342453, rep=2, steps=2000, every=500, op="nebb", weight="ntw", re=0.2,
        Kref=15.4, sub=8):
    N = L * rep
    m = tau - 0.5
    if weight == "ntw":
        s = max(1 - 2 * m, 1e-3)
        t = m / (s * math.sqrt(s))
    else:
        t = m
    wp, wm = 1 / tau, 1 / (lam / m + 0.5)
    nu, a = m / 3, d / 2
    g1 = (np.arange(sub) + 0.5) / sub
    ctr = 0.5 * L + (0.0 if L % 2 else 0.5)
    X = np.arange(N)[:, None, None, None, None, None] + g1[None, None, None, :, None, None]
    Y = np.arange(N)[None, :, None, None, None, None] + g1[None, None, None, None, :, None]
    Z = np.arange(N)[None, None, :, None, None, None] + g1[None, None, None, None, None, :]
    eps = np.zeros((N, N, N))
    for i in range(rep):
        for j in range(rep):
            for k in range(rep):
                dx = (X - ctr - i * L + N / 2) % N - N / 2
                dy = (Y - ctr - j * L + N / 2) % N - N / 2
                dz = (Z - ctr - k * L + N / 2) % N - N / 2
                eps += ((dx * dx + dy * dy + dz * dz) < a * a).mean(axis=(3, 4, 5))
    eps = np.minimum(eps, 1)
    B = eps if weight == "eps" else eps * t / ((1 - eps) + t)
    U = re * nu / d
    F = np.array([6 * math.pi * nu * a * Kref * U / L**3, 0, 0])[:, None, None, None]
    u = np.zeros((3, N, N, N))
    u[0] = U * N**3 / ((1 - eps) ** 2).sum() * (1 - eps)

    def feq(rho, u):
        cu = np.einsum("qa,axyz->qxyz", c, u)
        return w * rho * (1 + 3 * cu + 4.5 * cu * cu - 1.5 * (u * u).sum(0))

    f = feq(np.ones((N, N, N)), u)
    cF = np.einsum("qa,axyz->qxyz", c, F * np.ones((1, N, N, N)))
    for n in range(1, steps + 1):
        rho = f.sum(0)
        u = (np.einsum("qa,qxyz->axyz", c, f) + 0.5 * F) / rho
        cu = np.einsum("qa,axyz->qxyz", c, u)
        eq = feq(rho, u)
        fp, fm = 0.5 * (f + f[opp]), 0.5 * (f - f[opp])
        ep, em = 0.5 * (eq + eq[opp]), 0.5 * (eq - eq[opp])
        S = (1 - 0.5 * wp) * w * (-3 * (u * F).sum(0) + 9 * cu * cF) + (1 - 0.5 * wm) * w * 3 * cF
        coll = wp * (fp - ep) + wm * (fm - em)
        if op == "nebb":
            Om = f[opp] - f + w * rho - eq[opp]
        elif op == "odd":
            Om = f[opp] - f + em  # V = 0: 3 w rho c.u
        else:
            Om = w * rho - eq - coll
        fs = f - (1 - B) * coll + (1 - B) * S + B * Om
        for q in range(Q):
            f[q] = np.roll(fs[q], shift=tuple(c[q]), axis=(0, 1, 2))
        if n % every == 0:
            rho = f.sum(0)
            ux = (np.einsum("qa,qxyz->axyz", c, f)[0] + 0.5 * F[0, 0, 0, 0]) / rho
            print(f"{n:7d} fluid_rho {((1 - eps) * rho).sum() / (1 - eps).sum():.9f} "
                  f"covered_rho {rho[eps >= 1].mean() if (eps >= 1).any() else float('nan'):.6f} "
                  f"mean {rho.mean():.12f} usup/U {((1 - eps) * ux).sum() / N**3 / U:.6f}", flush=True)


if __name__ == "__main__":
    kw = {}
    for arg in sys.argv[1:]:
        k, v = arg.split("=")
        kw[k] = v if k in ("op", "weight") else (int(v) if k in ("L", "rep", "steps", "every", "sub") else float(v))
    run(**kw)
