#pragma once
// Partially saturated cells (Noble & Torczynski 1998; first paper Eqs. 1-3).
//
// Per cell with solid fractions eps_k of the overlapping particles k:
//   eps = min(1, sum eps_k),  B = eps (tau - 1/2) / ((1 - eps) + (tau - 1/2))   (or B = eps),
//   B_k = B eps_k / eps,
//   f_q* = f_q - (1 - B) [omega+ (f+_q - eq+_q) + omega- (f-_q - eq-_q)]      (TRT; BGK: omega+ = omega-)
//          + sum_k B_k Omega^S_{q,k} + (1 - B) S_q,
// with the solid operator either
//   NEBB (paper Eq. 2):  Omega^S_q = f_qbar - f_q + f^eq_q(rho, V_k) - f^eq_qbar(rho, u), or
//   superposition:       Omega^S_q = f^eq_q(rho, V_k) - f^eq_q(rho, u) - Omega^F_q (Holdych et al. 2003:
//                        f^eq(V) - f + (1 - 1/tau)(f - f^eq(u)); Omega^F the fluid collision term), so
//                        that f* = f^post + B (f^eq(V) - f^eq(u)),
// V_k = v_k + w_k x (x_cell - x_k) the particle's velocity at the cell centre.
// The hydrodynamic force on particle k from this cell is minus the momentum
// the solid term gives the fluid: F_k = - sum_q B_k Omega^S_{q,k} c_q (lattice
// units per step; the paper's Eq. 3 with the sign of the action on the solid),
// torque (x_cell - x_k) x F_k. Forces are written per (slot, cell) and then
// gathered per particle (deterministic: no atomics).
#include <cmath>
#include <cstdint>

#include "core/hd.hpp"
#include "imb/cell_slots.hpp"
#include "lbm/kernels.hpp"

namespace lbdem::imb {

enum class PsmVariant { NEBB, Superposition };
enum class PsmWeight { NobleTorczynski, Linear };

// Narrow particle view for the coupling (lattice units, SoA).
struct PsmParticles {
  const double* x = nullptr;
  const double* y = nullptr;
  const double* z = nullptr;
  const double* r = nullptr;
  const double* vx = nullptr;
  const double* vy = nullptr;
  const double* vz = nullptr;
  const double* wx = nullptr;
  const double* wy = nullptr;
  const double* wz = nullptr;
  Index n = 0;
  int stride = 1;  // element i of each array at [i * stride] (4: DEM's Real4 records)
};

// Per (slot, cell) force on the slot's particle: component a of slot k of
// cell c at (a * K + k) * ncells + c, a = 0..2. The torque is not stored: the
// gather forms (x_cell - x_p) x F from the cell it reads (half the bytes).
struct SlotForceView {
  double* v = nullptr;
  Index ncells = 0;
  int K = 0;
  static constexpr int kComponents = 3;
  LBDEM_HD double& at(int a, int k, Index cell) const { return v[(static_cast<Index>(a) * K + k) * ncells + cell]; }
};

// Minimum-image displacement on a periodic axis of length n (cells).
LBDEM_HD inline double min_image(double d, double n, bool periodic) {
  if (!periodic) return d;
  if (d > 0.5 * n) d -= n;
  else if (d < -0.5 * n) d += n;
  return d;
}

// The fluid cells of a PSM step: the plain LBM stream-collide (lbm::StepKernel)
// on every cell that no particle overlaps (count == 0). The cells that a
// particle overlaps are left to PsmSolidKernel in the same step; every
// population slot is read and written by exactly one cell's thread under both
// streaming policies, so the two kernels never touch the same memory and may
// run in either order. This keeps the fluid cells (~85 % at a solid fraction
// of 0.13) on the lean, high-occupancy kernel of a particle-free scene: the
// one-kernel version carried the solid path's registers into every cell and
// ran at a fifth of the plain kernel's throughput.
template <class L, class T, lbm::StreamKind S, int Parity, bool Bnd, bool Force>
struct PsmFluidKernel {
  lbm::StepKernel<L, T, S, Parity, Bnd, Force> k;
  const int* count;
  LBDEM_HD void operator()(Index cell) const {
    if (count[cell] != 0) return;
    k(cell);
  }
};

// The cells with at least one overlapping particle (count > 0), launched over
// the map's compact list of them (CellSlots::solid_list) so that whole warps
// do PSM work instead of a few lanes of warps that are mostly fluid.
template <class L, class T, lbm::StreamKind S, int Parity, bool Bnd, PsmVariant V>
struct PsmSolidKernel {
  using R = T;
  lbm::PopView<T> src, dst;
  lbm::GridView g;
  const std::uint8_t* flags;
  lbm::BoundaryTable bt;
  R omega_p, omega_m, F[3];
  R tm;  // tau - 1/2
  PsmWeight weight;
  bool periodic[3];
  CellSlotsView slots;
  const int* list;  // SolidCellList: the kernel runs over these cells only
  PsmParticles p;
  SlotForceView out;

  LBDEM_HD void operator()(Index item) const {
    const Index cell = list[item];
    const int m = slots.used(cell);
    if constexpr (Bnd) {
      if (flags[cell] != 0) {  // boundary cell: no fluid, no solid term; its slots carry no force
        for (int k = 0; k < m; ++k)
          for (int a = 0; a < SlotForceView::kComponents; ++a) out.at(a, k, cell) = 0.0;
        return;
      }
    }
    const lbm::Neighbours nb = lbm::neighbours<L>(g, cell);
    R f[L::Q];
    lbm::load_incoming<L, T, R, S, Parity>(src, nb, cell, f);
    R u[3];
    // Moments (shifted populations, see lbm/collision.hpp).
    R d, j[3];
    lbm::moments<L>(f, d, j);
    const R rho = R(1) + d;
    for (int a = 0; a < 3; ++a) u[a] = (j[a] + R(0.5) * F[a]) / rho;
    const R usq15 = R(1.5) * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    R eq[L::Q];
    LBDEM_UNROLL
    for (int q = 0; q < L::Q; ++q) {
      const R cu = R(L::c(q, 0)) * u[0] + R(L::c(q, 1)) * u[1] + R(L::c(q, 2)) * u[2];
      eq[q] = R(L::w(q)) * (d + rho * (R(3) * cu + R(4.5) * cu * cu - usq15));
    }
    // Weights (in the storage precision: B enters the populations there).
    R eps_tot = 0;
    for (int k = 0; k < m; ++k) eps_tot += R(slots.eps_at(cell, k));
    const R eps = eps_tot < R(1) ? eps_tot : R(1);
    const R Btot = weight == PsmWeight::Linear ? eps : eps * tm / ((R(1) - eps) + tm);
    const R fw = R(1) - Btot;
    // Fluid collision (TRT split), weighted by (1 - B), plus (1 - B) Guo forcing.
    R post[L::Q], out_f[L::Q];
    {
      const R uF = u[0] * F[0] + u[1] * F[1] + u[2] * F[2];
      const R sp = R(1) - R(0.5) * omega_p, sm = R(1) - R(0.5) * omega_m;
      const R w0 = R(L::w(0));
      post[0] = f[0] - omega_p * (f[0] - eq[0]);
      R S0 = sp * w0 * (R(-3) * uF);
      out_f[0] = f[0] - fw * omega_p * (f[0] - eq[0]) + fw * S0;
      LBDEM_UNROLL
      for (int q = 1; q < L::Q; q += 2) {
        const int qb = q + 1;
        const R w = R(L::w(q));
        const R cu = R(L::c(q, 0)) * u[0] + R(L::c(q, 1)) * u[1] + R(L::c(q, 2)) * u[2];
        const R cF = R(L::c(q, 0)) * F[0] + R(L::c(q, 1)) * F[1] + R(L::c(q, 2)) * F[2];
        const R dp = omega_p * (R(0.5) * (f[q] + f[qb]) - R(0.5) * (eq[q] + eq[qb]));
        const R dm = omega_m * (R(0.5) * (f[q] - f[qb]) - R(0.5) * (eq[q] - eq[qb]));
        const R Sp = sp * w * (R(9) * cu * cF - R(3) * uF), Sm = sm * w * R(3) * cF;
        post[q] = f[q] - dp - dm;
        post[qb] = f[qb] - dp + dm;
        out_f[q] = f[q] - fw * (dp + dm) + fw * (Sp + Sm);
        out_f[qb] = f[qb] - fw * (dp - dm) + fw * (Sp - Sm);
      }
    }
    // Solid terms, one per overlapping particle.
    int x, y, zc;
    g.coords(cell, x, y, zc);
    const double xc[3] = {x + 0.5, y + 0.5, zc + 0.5};
    const double len[3] = {double(g.nx), double(g.ny), double(g.nz)};
    for (int k = 0; k < m; ++k) {
      const int pi = slots.particle_at(cell, k);
      const R Bk = eps_tot > R(0) ? Btot * R(slots.eps_at(cell, k)) / eps_tot : R(0);
      const Index o = static_cast<Index>(pi) * p.stride;
      const double px[3] = {p.x[o], p.y[o], p.z ? p.z[o] : 0.5};
      double rr[3];
      for (int a = 0; a < 3; ++a) rr[a] = min_image(xc[a] - px[a], len[a], periodic[a]);
      if (L::D == 2) rr[2] = 0;
      const double w3[3] = {p.wx ? p.wx[o] : 0.0, p.wy ? p.wy[o] : 0.0, p.wz ? p.wz[o] : 0.0};
      const R vs[3] = {R(p.vx[o] + w3[1] * rr[2] - w3[2] * rr[1]), R(p.vy[o] + w3[2] * rr[0] - w3[0] * rr[2]),
                       R(L::D == 3 ? p.vz[o] + w3[0] * rr[1] - w3[1] * rr[0] : 0.0)};
      const R vsq15 = R(1.5) * (vs[0] * vs[0] + vs[1] * vs[1] + vs[2] * vs[2]);
      R mom[3] = {0, 0, 0};
      LBDEM_UNROLL
      for (int q = 0; q < L::Q; ++q) {
        const R cv = R(L::c(q, 0)) * vs[0] + R(L::c(q, 1)) * vs[1] + R(L::c(q, 2)) * vs[2];
        const R eqs = R(L::w(q)) * (d + rho * (R(3) * cv + R(4.5) * cv * cv - vsq15));
        R om;
        if constexpr (V == PsmVariant::NEBB) om = f[L::opp(q)] - f[q] + eqs - eq[L::opp(q)];
        else om = eqs - eq[q] - (f[q] - post[q]);  // Holdych et al.: eq(V) - f + (1 - omega)(f - eq(u))
        const R bo = Bk * om;
        out_f[q] += bo;
        LBDEM_UNROLL
        for (int a = 0; a < 3; ++a)
          if (L::c(q, a) != 0) mom[a] += L::c(q, a) > 0 ? bo : -bo;
      }
      // Force on the particle = - momentum given to the fluid (torque: in the gather).
      for (int a = 0; a < 3; ++a) out.at(a, k, cell) = -double(mom[a]);
    }
    lbm::store_outgoing<L, T, R, S, Parity, Bnd>(dst, nb, cell, out_f, flags, bt, u);
  }
};

// Force gather, deterministic (fixed order, no atomics): one warp (32
// consecutive work items) per particle walks the particle's map pairs
// (PairView, contiguous per particle), lane j taking entries j, j + 32, ...;
// the 32 partial sums are then combined by a fixed tree (shuffles on the
// device; the same tree in the same order on the host, so both backends add
// in one order). Torque = sum (x_cell - x_p) x F with the unwrapped box
// coordinate, the kernel's minimum-image lever arm. Writes (not adds) force
// (+ buoyancy per_volume times the volume) and torque.
struct GatherPairs {
  PsmParticles p;
  CellSlotsView slots;
  SlotForceView sf;
  PairView pairs;
  int dim;
  double* force;
  double* torque;
  int fstride, tstride;
  double per_volume[3];

  LBDEM_HD void lane_sum(Index i, int lane, double (&acc)[6]) const {
    for (int a = 0; a < 6; ++a) acc[a] = 0.0;
    const Index o = i * p.stride;
    const double c[3] = {p.x[o], p.y[o], dim == 3 ? p.z[o] : 0.5};
    const double r = p.r[o];
    const double lo[3] = {floor(c[0] - r), floor(c[1] - r), dim == 3 ? floor(c[2] - r) : 0.0};
    const Index* slot = pairs.slot + i * pairs.box;
    const int B = pairs.B;
    for (Index l = lane; l < pairs.box; l += 32) {
      const Index cell = slot[l];
      if (cell < 0) continue;
      int k = 0;  // the slot naming particle i (one per cell; slots are sorted after the map)
      const int m = slots.used(cell);
      while (k < m - 1 && slots.particle_at(cell, k) != static_cast<int>(i)) ++k;
      const double F[3] = {sf.at(0, k, cell), sf.at(1, k, cell), sf.at(2, k, cell)};
      const int li = static_cast<int>(l % B), lj = static_cast<int>((l / B) % B);
      const int lk = dim == 3 ? static_cast<int>(l / (static_cast<Index>(B) * B)) : 0;
      const double rr[3] = {lo[0] + li + 0.5 - c[0], lo[1] + lj + 0.5 - c[1], dim == 3 ? lo[2] + lk + 0.5 - c[2] : 0.0};
      acc[0] += F[0];
      acc[1] += F[1];
      acc[2] += F[2];
      acc[3] += rr[1] * F[2] - rr[2] * F[1];
      acc[4] += rr[2] * F[0] - rr[0] * F[2];
      acc[5] += rr[0] * F[1] - rr[1] * F[0];
    }
  }

  LBDEM_HD void finish(Index i, const double (&acc)[6]) const {
    const double rp = p.r[i * p.stride];
    const double vol = dim == 3 ? 4.18879020478639098 * rp * rp * rp : 3.14159265358979324 * rp * rp;
    for (int a = 0; a < 3; ++a) {
      force[i * fstride + a] = acc[a] + vol * per_volume[a];
      torque[i * tstride + a] = acc[3 + a];
    }
  }

  LBDEM_HD void operator()(Index t) const {
    const Index i = t >> 5;
    const int lane = static_cast<int>(t & 31);
#if defined(__CUDA_ARCH__)
    double acc[6];
    lane_sum(i, lane, acc);
    for (int off = 16; off > 0; off >>= 1)
      for (int a = 0; a < 6; ++a) acc[a] += __shfl_down_sync(0xffffffffu, acc[a], off);
    if (lane == 0) finish(i, acc);
#else
    if (lane != 0) return;
    double part[32][6];
    for (int j = 0; j < 32; ++j) lane_sum(i, j, part[j]);
    for (int off = 16; off > 0; off >>= 1)
      for (int j = 0; j < off; ++j)
        for (int a = 0; a < 6; ++a) part[j][a] += part[j + off][a];
    finish(i, part[0]);
#endif
  }
};

}  // namespace lbdem::imb
