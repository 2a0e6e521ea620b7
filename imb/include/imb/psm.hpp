#pragma once
// Partially saturated cells (Noble & Torczynski 1998; first paper Eqs. 1-3).
//
// Per cell with solid fractions eps_k of the overlapping particles k:
//   eps = min(1, sum eps_k),  B = eps (tau - 1/2) / ((1 - eps) + (tau - 1/2))   (or B = eps),
//   B_k = B eps_k / eps,
//   f_q* = f_q - (1 - B) [omega+ (f+_q - eq+_q) + omega- (f-_q - eq-_q)]      (TRT; BGK: omega+ = omega-)
//          + sum_k B_k Omega^S_{q,k} + (1 - B) S_q,
// with the solid operator either
//   NEBB:                Omega^S_q = f_qbar - f_q + 3 w_q rho c_q.(V_k + u)  (the odd part of paper
//                        Eq. 2, f_qbar - f_q + f^eq_q(rho, V_k) - f^eq_qbar(rho, u); see below), or
//   superposition:       Omega^S_q = f^eq_q(rho, V_k) - f^eq_q(rho, u) - Omega^F_q (Holdych et al. 2003:
//                        f^eq(V) - f + (1 - 1/tau)(f - f^eq(u)); Omega^F the fluid collision term), so
//                        that f* = f^post + B (f^eq(V) - f^eq(u)),
// V_k = v_k + w_k x (x_cell - x_k) the particle's velocity at the cell centre.
// The hydrodynamic force on particle k from this cell is minus the momentum
// the solid term gives the fluid: F_k = - sum_q B_k Omega^S_{q,k} c_q (lattice
// units per step; the paper's Eq. 3 with the sign of the action on the solid;
// plus the particle's share B_k F of the body force where the body force is a
// mean pressure gradient, PsmOptions::body_force_on_solid), torque
// (x_cell - x_k) x F_k. Forces are written per (slot, cell) and then
// gathered per particle (deterministic: no atomics).
//
// Why NEBB keeps only the odd part of Eq. 2. With f^eq = w rho (1 + 3 c.u +
// P_q(u)), P_q(u) = 4.5 (c.u)^2 - 1.5 u^2 (even in c), Eq. 2 is
//   Omega^S_q = f_qbar - f_q + 3 w rho c.(V + u) + w rho (P_q(V) - P_q(u)).
// The last term carries no mass and no momentum (sum_q w P_q = 0, sum_q w c P_q
// = 0): it only adds rho (V V - u u) to the momentum flux, i.e. to the even
// populations, every step. Nothing relaxes the even populations in a covered
// cell but the fluid collision, weighted by 1 - B, so there this stress
// accumulates as B / ((1 - B) omega+) times the source, without bound where
// B -> 1. And u != V in a covered cell at rest under a body force: u is shifted
// by F / 2 (Guo) while the solid term returns the momentum rho V + F / 2, so
// u = V + F / rho at steady state. The stress rho (V V - u u) ~ -(V F + F V +
// F F / rho) then builds up inside the particle and its divergence at the
// surface moves fluid mass into the covered cells (a drift ~ F^2 at rest,
// hardly depending on Lambda; bench/imb/NOTES.md, "Mass drift into covered
// cells"). Dropping the even part leaves the force (and so the torque), the
// mass and the momentum of every step exactly as Eq. 2 gives them and
// removes the source; a steady drag moves only at O(Re).
//
// Even relaxation (PsmOptions::even_relaxation = phi, NEBB; off by default).
// Without it the even populations f+ of a cell relax only through the fluid
// collision, at (1 - B) omega+: not at all in a covered cell (B = 1), slowly
// where B is near 1, so covered cells keep a density of their own that they
// exchange with the fluid over ~10^5 steps at tau 1.24 (bench/imb/NOTES.md).
// With phi > 0 the solid term gets the even part
//   Omega^S,even_q = -(Be / B) omega+ (f+_q - eq+_q(rho, u)),  Be = max(0, B - (1 - phi)),
// summed over the slots -Be omega+ (f+_q - eq+_q), so that the even
// populations relax at max(1 - B, phi) omega+ (phi = 1: at omega+ in every
// cell, as in the fluid). It carries no mass (sum_q (f+_q - eq+_q) = rho -
// rho = 0) and no momentum (f+ - eq+ is even in c, sum_q c_q (...) = 0): per
// cell mass and momentum, hence the force and the torque on the particles
// (minus the momentum the solid term gives the fluid), are those without it;
// only the density and stress of nearly covered cells change. It does move a
// steady drag (the partially covered cells' stress relaxes faster, a lower
// effective viscosity there): bench/imb/NOTES.md, "Even relaxation".
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <type_traits>

#include "core/hd.hpp"
#include "imb/cell_slots.hpp"
#include "lbm/kernels.hpp"

namespace lbdem::imb {

enum class PsmVariant { NEBB, Superposition };

// Calls fn(std::integral_constant<PsmVariant, V>) for the runtime choice v (the
// PSM steps' dispatch, beside lbm::dispatch_step).
template <class Fn>
void dispatch_variant(PsmVariant v, Fn&& fn) {
  if (v == PsmVariant::NEBB) fn(std::integral_constant<PsmVariant, PsmVariant::NEBB>{});
  else fn(std::integral_constant<PsmVariant, PsmVariant::Superposition>{});
}
// NobleTorczynski: B of first paper Eq. 1 with t = tau - 1/2. NobleTorczynskiWall:
// the same form with t = psm_wall_weight_t(tau) (below), which moves the PSM
// surface back toward where it sits as tau -> 1/2; the kernels treat both alike
// (only the host-side t differs). Linear: B = eps.
enum class PsmWeight { NobleTorczynski, Linear, NobleTorczynskiWall };

// Narrow particle view for the coupling (lattice units, SoA): centres, radii,
// velocities (imb/particle_view.hpp).
using PsmParticles = SphereView;

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

// Noble-Torczynski weighting B(eps) = eps (tau - 1/2) / ((1 - eps) + (tau - 1/2))
// (first paper Eq. 1), or B = eps; tm = the weighting's t (psm_weight_t: tau - 1/2
// for NT).
template <class R>
LBDEM_HD inline R psm_weight(R eps, R tm, PsmWeight w) {
  return w == PsmWeight::Linear ? eps : eps * tm / ((R(1) - eps) + tm);
}

// The weighting's t for tau under the wall rule (bench/imb/NOTES.md, "Where the
// PSM wall sits", "One rule for every tau"). With the NT weight and
// t = tau - 1/2 the PSM surface moves into the solid as tau grows: the solid
// term B = eps t / ((1 - eps) + t) grows slower than the viscosity (~ t), so
// the partial cells resist less, the drag falls. As tau -> 1/2, B / t ->
// eps / (1 - eps) and the surface is where the fixed-sphere study calibrated
// it. The rule
//   t = m / (1 - 2 m)^(3/2),   m = tau - 1/2,
// keeps t -> m as tau -> 1/2 and lets t grow without bound as tau -> 1, where
// B -> eps, the largest weight the form of Eq. 1 admits (B < eps for every
// finite t). The smallest sphere of the map (d/l 4, bar 8 %, -7.8 % as
// tau -> 1/2) needs that limit: its drag rises monotonically with t, and at
// tau = 1 even B = eps leaves it at -8.3 %. The exponent 3/2 is fitted at
// d/l 4 (-5.2 ... -6.9 % at Lambda 1e-4 over tau 0.52 ... 0.9); larger spheres get too
// much drag, which the TRT Lambda takes out (psm_magic_auto, drag_error.hpp:
// Lambda shifts the drag like a radius change, ~ 1/d). 1 - 2m is floored at
// 1e-3 so that t stays finite at and above tau = 1 (B within 1e-4 of eps).
inline double psm_wall_weight_t(double tau) {
  const double m = tau - 0.5;
  const double s = std::max(1.0 - 2.0 * m, 1e-3);
  return m / (s * std::sqrt(s));
}

// The weighting's t for the given tau and weighting (NT: tau - 1/2).
inline double psm_weight_t(double tau, PsmWeight w) {
  return w == PsmWeight::NobleTorczynskiWall ? psm_wall_weight_t(tau) : tau - 0.5;
}

// Minimum-image displacement on a periodic axis of length n (cells).
LBDEM_HD inline double min_image(double d, double n, bool periodic) {
  if (!periodic) return d;
  if (d > 0.5 * n) d -= n;
  else if (d < -0.5 * n) d += n;
  return d;
}

// Total weight B of a cell from the sum of its slots' fractions:
// B(min(1, sum eps_k)) (first paper Eq. 1).
template <class R>
LBDEM_HD LBDEM_FORCEINLINE R psm_cell_weight(R eps_tot, R tm, PsmWeight w) {
  const R eps = eps_tot < R(1) ? eps_tot : R(1);
  return psm_weight(eps, tm, w);
}

// Weight of one slot, B_k = B eps_k / sum eps (eps_tot > 0).
template <class R>
LBDEM_HD LBDEM_FORCEINLINE R psm_slot_weight(R B, R eps_k, R eps_tot) {
  return B * eps_k / eps_tot;
}

// The PSM collision runs on every cell (fluid cells are the B = 0 case of the
// same arithmetic, so warps hardly diverge), and it needs the particles only
// through moments of their weighted velocities. With Omega^S linear in
// f^eq(V_k) and f^eq quadratic in V,
//   sum_k B_k f^eq_q(V_k) = w_q [M0 d + rho (3 c.M1 + 4.5 c.M2.c - 1.5 tr M2)],
//   M0 = sum B_k = B, M1 = sum B_k V_k, M2 = sum B_k V_k V_k^T,
// so a cell loads its slots once and accumulates these 10 numbers, and the
// per-direction loop carries no per-particle state. Adds slot k's weight
// B_k and solid velocity V_k to M1 and M2 = (xx yy zz xy xz yz).
template <class R>
LBDEM_HD LBDEM_FORCEINLINE void add_solid_moments(R Bk, const R (&vs)[3], R (&M1)[3], R (&M2)[6]) {
  for (int a = 0; a < 3; ++a) M1[a] += Bk * vs[a];
  M2[0] += Bk * vs[0] * vs[0];
  M2[1] += Bk * vs[1] * vs[1];
  M2[2] += Bk * vs[2] * vs[2];
  M2[3] += Bk * vs[0] * vs[1];
  M2[4] += Bk * vs[0] * vs[2];
  M2[5] += Bk * vs[1] * vs[2];
}

// The force on particle k from one cell has a closed form from the moments of
// Omega^S (c_qbar = -c_q, sum c f^eq(V) = rho V, rho u = j + F/2):
//   NEBB:          sum_q c_q Omega^S_q = rho V_k - j + F/2 = rho (V_k - u) + F,
//   superposition: sum_q c_q Omega^S_q = rho (V_k - u) - sum_q c_q (f_q - f^post_q)
//                                      = rho (V_k - u) + omega_- F / 2,
// F_k = -B_k (sum_q c_q Omega^S_q - G): minus the momentum the solid term
// gives the fluid, plus the particle's share B_k G of the body force the
// (1 - B) weighting withholds from the fluid in this cell (G = F where the
// body force stands for a mean pressure gradient, PsmOptions::body_force_on_solid;
// else G = 0). With G = F the cell's fluid and particles together receive
// exactly F per step, whatever B is.
template <class R, bool Force, PsmVariant V>
LBDEM_HD LBDEM_FORCEINLINE void psm_particle_force(R Bk, R rho, const R (&vs)[3], const R (&u)[3], const R (&F)[3],
                                                   const R (&G)[3], R omega_m, R (&Fk)[3]) {
  for (int a = 0; a < 3; ++a) {
    if constexpr (Force) {
      const R extra = V == PsmVariant::NEBB ? F[a] : R(0.5) * omega_m * F[a];
      Fk[a] = -(Bk * (rho * (vs[a] - u[a]) + extra - G[a]));
    } else {
      Fk[a] = -(Bk * (rho * (vs[a] - u[a]) + R(0)));  // no body force: G plays no part
    }
  }
}

// c_q . M2 . c_q for M2 = (xx yy zz xy xz yz), components of c in {-1, 0, 1}:
// the constant pattern folded in once the direction loop is unrolled.
template <class L, class R>
LBDEM_HD LBDEM_FORCEINLINE R cM2(int q, const R (&M2)[6]) {
  const int c0 = L::c(q, 0), c1 = L::c(q, 1), c2 = L::c(q, 2);
  R s = 0;
  if (c0 != 0) s += M2[0];
  if (c1 != 0) s += M2[1];
  if (c2 != 0) s += M2[2];
  if (c0 * c1 != 0) s += c0 * c1 > 0 ? R(2) * M2[3] : R(-2) * M2[3];
  if (c0 * c2 != 0) s += c0 * c2 > 0 ? R(2) * M2[4] : R(-2) * M2[4];
  if (c1 * c2 != 0) s += c1 * c2 > 0 ? R(2) * M2[5] : R(-2) * M2[5];
  return s;
}

// The PSM update of lbm::Collider::collide: the fluid collision's terms scaled
// by 1 - B plus the solid term sum_k B_k Omega^S_{q,k} (formulas at the top),
//   f*_q = f_q - (1 - B)(dp +- dm) + (1 - B)(Sp +- Sm) + solid_q,
// with B the total weight and M1, M2 the solid moments above.
//
// Hoist: where 1 - B and 1.5 tr M2 are formed. The same values either way; it
// only moves work between registers and instructions. true: once, before the
// moment sums (the mapped kernel, whose 80-register bound otherwise spills
// more); false: where each direction uses them (the fused kernel, which then
// holds fewer values across the moment sums).
template <class L, class R, bool Force, PsmVariant V, bool Hoist = false>
struct PsmSolidUpdate {
  R B;
  R Be;  // NEBB: weight of the solid term's even part -Be dp (max(0, B - (1 - phi)), phi = PsmOptions::even_relaxation)
  R M1[3], M2[6];
  R fw_ = 0, tr_ = 0;  // 1 - B and 1.5 tr M2 when hoisted

  LBDEM_HD LBDEM_FORCEINLINE PsmSolidUpdate(R B_, R Be_, const R (&M1_)[3], const R (&M2_)[6]) : B(B_), Be(Be_) {
    for (int a = 0; a < 3; ++a) M1[a] = M1_[a];
    for (int a = 0; a < 6; ++a) M2[a] = M2_[a];
    if constexpr (Hoist) {
      fw_ = R(1) - B;
      tr_ = R(1.5) * (M2[0] + M2[1] + M2[2]);
    }
  }
  LBDEM_HD LBDEM_FORCEINLINE R fluid_weight() const {
    if constexpr (Hoist) return fw_;
    else return R(1) - B;
  }
  LBDEM_HD LBDEM_FORCEINLINE R trace15() const {
    if constexpr (Hoist) return tr_;
    else return R(1.5) * (M2[0] + M2[1] + M2[2]);
  }

  template <class Src>
  LBDEM_HD LBDEM_FORCEINLINE void rest(R& f0, const lbm::TrtTerms<R>& t, const lbm::CellMoments<R>& m,
                                       const Src& src) const {
    const R fw = fluid_weight();
    // NEBB: the rest direction has no odd part (formulas at the top); the
    // even part -Be dp where it is on (Be = 0: r - 0 = r, the same bits).
    R solid = 0;
    if constexpr (V == PsmVariant::NEBB) {
      solid = -(Be * t.dp);
    } else {
      const R seq0 = t.w * (B * m.d - m.rho * trace15());  // sum_k B_k f^eq_0(V_k)
      solid = seq0 - B * (t.eqp + t.dp);
    }
    R r = f0 - fw * t.dp;
    if constexpr (Force) {
      R Sp, Sm;
      src(Sp, Sm);
      r += fw * Sp;
    }
    f0 = r + solid;
  }

  template <class Src>
  LBDEM_HD LBDEM_FORCEINLINE void pair(int q, R& fq, R& fqb, const lbm::TrtTerms<R>& t, const lbm::CellMoments<R>& m,
                                       const Src& src) const {
    R Sp = 0, Sm = 0;
    if constexpr (Force) src(Sp, Sm);
    const R cM1 = lbm::cdot<L>(q, M1);
    const R fw = fluid_weight();
    R solid_q, solid_qb;
    if constexpr (V == PsmVariant::NEBB) {
      // Omega_q = f_qb - f_q + 3 w rho c_q.(V + u), summed over the slots:
      // B (f_qb - f_q) + 3 w rho (c.M1 + B c.u) (the odd part of
      // f^eq_q(V) - f^eq_qb(u); formulas at the top).
      // With even relaxation also -Be omega+ (f+_q - eq+_q) on both (Be = 0:
      // x - 0 = x, the same bits as without).
      const R odd = R(3) * t.w * m.rho * (cM1 + B * t.cu);
      const R even = Be * t.dp;
      solid_q = B * (fqb - fq) + odd - even;
      solid_qb = B * (fq - fqb) - odd - even;
    } else {  // Omega_q = f^eq_q(V) - f^eq_q(u) - (f_q - f^post_q)
      // f^eq_q and f^eq_qb as w (even +- 3 rho c.u): the same as eqp +- eqm up to
      // round-off, and in this form the PSM kernels need fewer registers.
      const R eq_q = t.w * (t.even + R(3) * m.rho * t.cu), eq_qb = t.w * (t.even - R(3) * m.rho * t.cu);
      // sum_k B_k f^eq(V_k) for q and qb.
      const R seven = B * m.d + m.rho * (R(4.5) * cM2<L>(q, M2) - trace15());
      const R seq_q = t.w * (seven + R(3) * m.rho * cM1), seq_qb = t.w * (seven - R(3) * m.rho * cM1);
      solid_q = seq_q - B * (eq_q + t.dp + t.dm);
      solid_qb = seq_qb - B * (eq_qb + t.dp - t.dm);
    }
    R a = fq - fw * (t.dp + t.dm);
    R b = fqb - fw * (t.dp - t.dm);
    if constexpr (Force) {
      a += fw * (Sp + Sm);
      b += fw * (Sp - Sm);
    }
    fq = a + solid_q;
    fqb = b + solid_qb;
  }
};

// The PSM collision of one cell from its incoming populations f (in place),
// the total weight B and the solid moments M1 = sum B_k V_k, M2 = sum B_k V_k V_k^T:
// the fluid collision `coll` with the solid update. Returns rho and the
// (half-force shifted) velocity u that the force on the particles needs.
// Be: the weight of NEBB's even part (PsmLatticeFields::even_weight; 0: off).
template <class L, class R, bool Force, PsmVariant V, bool Hoist = false>
LBDEM_HD LBDEM_FORCEINLINE void psm_collide(const lbm::Collider<L, R, Force>& coll, R (&f)[L::Q], R B, R Be,
                                            const R (&M1)[3], const R (&M2)[6], R& rho, R (&u)[3]) {
  lbm::CellMoments<R> m;
  coll.template collide<true>(f, m, PsmSolidUpdate<L, R, Force, V, Hoist>(B, Be, M1, M2));
  rho = m.rho;
  for (int a = 0; a < 3; ++a) u[a] = m.u[a];
}

// The lattice side of a PSM stream-collide kernel, shared by the mapped
// (PsmStepKernel) and the fused (PsmFusedKernel) kernels: populations, grid,
// boundaries, relaxation rates, body force, tau - 1/2 and the weighting.
// Populations are stored as T and the arithmetic is in C = lbm::compute_t<T>
// (T itself for fp32/fp64, float for 16-bit storage).
template <class T>
struct PsmLatticeFields {
  using C = lbm::compute_t<T>;
  lbm::PopView<T> src, dst;
  lbm::GridView g;
  const std::uint8_t* flags;
  lbm::BoundaryTable bt;
  C omega_p, omega_m, F[3];
  C G[3];  // the body force the particles take on their share B of a cell (psm_particle_force)
  C tm;    // the weighting's t (psm_weight_t: tau - 1/2 for NT)
  C even_c;  // 1 - PsmOptions::even_relaxation: NEBB's even part acts where B > even_c (1: nowhere)
  PsmWeight weight;

  // The weight Be of NEBB's even part in a cell of total weight B: the even
  // populations then relax at max(1 - B, phi) omega+, phi =
  // PsmOptions::even_relaxation = 1 - even_c (phi = 0: Be = 0, B <= 1).
  LBDEM_HD LBDEM_FORCEINLINE C even_weight(C B) const { return B > even_c ? B - even_c : C(0); }

  // From the solver's raw view (lbm::LbmRaw), tau, the weighting and whether
  // the particles take the body force on their share of each cell
  // (PsmOptions::body_force_on_solid), and whether NEBB relaxes the even part
  // (PsmOptions::even_relaxation); host side, once per launch.
  template <class Raw>
  void set_lattice(const Raw& raw, double tau, PsmWeight w, bool body_force_on_solid, double even_relaxation) {
    src = lbm::PopView<T>{static_cast<T*>(raw.src), raw.stride};
    dst = lbm::PopView<T>{static_cast<T*>(raw.dst), raw.stride};
    g = raw.grid;
    flags = raw.flags;
    bt = raw.boundaries;
    omega_p = static_cast<C>(raw.omega_p);
    omega_m = static_cast<C>(raw.omega_m);
    for (int a = 0; a < 3; ++a) F[a] = static_cast<C>(raw.body_force[static_cast<std::size_t>(a)]);
    for (int a = 0; a < 3; ++a) G[a] = body_force_on_solid ? F[a] : C(0);
    tm = static_cast<C>(psm_weight_t(tau, w));
    even_c = static_cast<C>(1.0 - even_relaxation);
    weight = w;
  }

  // The fluid collision at these rates and body force.
  template <class L, bool Force>
  LBDEM_HD LBDEM_FORCEINLINE lbm::Collider<L, C, Force> collider() const {
    lbm::Collider<L, C, Force> coll;
    coll.omega_p = omega_p;
    coll.omega_m = omega_m;
    for (int a = 0; a < 3; ++a) coll.F[a] = F[a];
    return coll;
  }
};

template <class L, class T, lbm::StreamKind S, int Parity, bool Bnd, bool Force, PsmVariant V>
struct PsmStepKernel : PsmLatticeFields<T> {
  using R = lbm::compute_t<T>;
  using Lat = PsmLatticeFields<T>;  // the lattice side's members, by name (a dependent base)
  using Lat::src, Lat::dst, Lat::g, Lat::flags, Lat::bt, Lat::omega_p, Lat::omega_m, Lat::F, Lat::G, Lat::tm,
      Lat::weight;
  CellSlotsView slots;
  SlotForceView out;

  // Solid velocity of slot k's particle at the cell centre (stored by the map:
  // translation + rotation, paper Eq. 2) and its weight B_k = B eps_k / sum eps.
  LBDEM_HD void slot_velocity(Index cell, int k, R B, R eps_tot, R& Bk, R (&vs)[3]) const {
    Bk = eps_tot > R(0) ? psm_slot_weight(B, R(slots.eps_at(cell, k)), eps_tot) : R(0);
    vs[0] = R(slots.vel_at(0, cell, k));
    vs[1] = R(slots.vel_at(1, cell, k));
    vs[2] = R(slots.vel_at(2, cell, k));
  }

  // Cell `cell` at storage coordinates (x, y, z) (core/exec.hpp for_each_cell).
  LBDEM_HD void operator()(Index cell, int x, int y, int z) const {
    const int m = slots.used(cell);
    if constexpr (Bnd) {
      if (flags[cell] != 0) {  // boundary cell: no fluid, no solid term; its slots carry no force
        for (int k = 0; k < m; ++k)
          for (int a = 0; a < SlotForceView::kComponents; ++a) out.at(a, k, cell) = 0.0;
        return;
      }
    }
    // Populations first (independent loads, issued before the slot chain).
    const lbm::Neighbours nb = lbm::neighbours_at<L>(g, x, y, z);
    R f[L::Q];
    lbm::load_incoming<L, T, R, S, Parity>(src, nb, cell, f);
    // 1. Solid moments of the overlapping particles (all zero in a fluid
    // cell), computed while the population loads are in flight (their
    // latency then overlaps the dependent slot -> particle reads).
    R B = 0, eps_tot = 0, M1[3] = {0, 0, 0}, M2[6] = {0, 0, 0, 0, 0, 0};  // M2: xx yy zz xy xz yz
    if (m > 0) {
      for (int k = 0; k < m; ++k) eps_tot += R(slots.eps_at(cell, k));
      B = psm_cell_weight(eps_tot, tm, weight);
      for (int k = 0; k < m; ++k) {
        R Bk, vs[3];
        slot_velocity(cell, k, B, eps_tot, Bk, vs);
        add_solid_moments(Bk, vs, M1, M2);
      }
    }
    // 2. Stream-collide.
    // A warp with no solid cell at all (most warps away from the particles)
    // runs the plain collision: the same result as B = 0 below, fewer instructions.
#if defined(__CUDA_ARCH__)
    const bool plain = !__any_sync(__activemask(), m > 0);
#else
    const bool plain = m == 0;
#endif
    const lbm::Collider<L, R, Force> coll = Lat::template collider<L, Force>();
    if (plain) {
      R drho, uu[3];
      coll(f, drho, uu);
      lbm::store_outgoing<L, T, R, S, Parity, Bnd>(dst, nb, cell, f, flags, bt, uu);
      return;
    }
    R rho, u[3];
    psm_collide<L, R, Force, V, true>(coll, f, B, Lat::even_weight(B), M1, M2, rho, u);
    lbm::store_outgoing<L, T, R, S, Parity, Bnd>(dst, nb, cell, f, flags, bt, u);
    // 3. Force on each particle (psm_particle_force; torque: in the gather),
    // after the populations are stored (slot data re-read from cache).
    for (int k = 0; k < m; ++k) {
      R Bk, vs[3], Fk[3];
      slot_velocity(cell, k, B, eps_tot, Bk, vs);
      psm_particle_force<R, Force, V>(Bk, rho, vs, u, F, G, omega_m, Fk);
      for (int a = 0; a < 3; ++a) out.at(a, k, cell) = double(Fk[a]);
    }
  }
};

// Writes one particle's gathered force (plus its buoyancy: per_volume times
// the volume, for the particles below per_volume_n, all when it is < 0) and
// torque: the common end of both force gathers.
struct ForceWriter {
  PsmParticles p;
  int dim;
  double* force;
  double* torque;
  int fstride, tstride;
  double per_volume[3];
  Index per_volume_n = -1;
  LBDEM_HD void operator()(Index i, const double (&acc)[6]) const {
    const double rp = p.r[i * p.stride];
    const double vol = per_volume_n >= 0 && i >= per_volume_n ? 0.0
                       : dim == 3 ? 4.18879020478639098 * rp * rp * rp
                                  : 3.14159265358979324 * rp * rp;
    for (int a = 0; a < 3; ++a) {
      force[i * fstride + a] = acc[a] + vol * per_volume[a];
      torque[i * tstride + a] = acc[3 + a];
    }
  }
};

// One warp (32 consecutive work items t) per particle i = t / 32: lane j's
// partial sums (g.lane_sum(i, j, acc)) are combined by a fixed tree (shuffles
// on the device; the same tree in the same order on the host, so both
// backends add in one order) and written by g.write.
template <class G>
LBDEM_HD void warp_gather(const G& g, Index t) {
  const Index i = t >> 5;
  const int lane = static_cast<int>(t & 31);
#if defined(__CUDA_ARCH__)
  double acc[6];
  g.lane_sum(i, lane, acc);
  for (int off = 16; off > 0; off >>= 1)
    for (int a = 0; a < 6; ++a) acc[a] += __shfl_down_sync(0xffffffffu, acc[a], off);
  if (lane == 0) g.write(i, acc);
#else
  if (lane != 0) return;
  double part[32][6];
  for (int j = 0; j < 32; ++j) g.lane_sum(i, j, part[j]);
  for (int off = 16; off > 0; off >>= 1)
    for (int j = 0; j < off; ++j)
      for (int a = 0; a < 6; ++a) part[j][a] += part[j + off][a];
  g.write(i, part[0]);
#endif
}

// Force gather of the mapped pipeline, deterministic (fixed order, no
// atomics): particle i's warp walks its map pairs (PairView, contiguous per
// particle), lane j taking entries j, j + 32, ... Torque = sum (x_cell - x_p)
// x F with the unwrapped box coordinate, the kernel's minimum-image lever arm.
struct GatherPairs {
  PsmParticles p;
  CellSlotsView slots;
  SlotForceView sf;
  PairView pairs;
  int dim;
  ForceWriter write;

  LBDEM_HD void lane_sum(Index i, int lane, double (&acc)[6]) const {
    for (int a = 0; a < 6; ++a) acc[a] = 0.0;
    const Index o = i * p.stride;
    const double c[3] = {p.x[o], p.y[o], dim == 3 ? p.z[o] : 0.5};
    const double r = p.r[o];
    const double lo[3] = {floor(c[0] - r), floor(c[1] - r), dim == 3 ? floor(c[2] - r) : 0.0};
    const int* slot = pairs.slot + i * pairs.box;
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

  LBDEM_HD void operator()(Index t) const { warp_gather(*this, t); }
};

}  // namespace lbdem::imb
