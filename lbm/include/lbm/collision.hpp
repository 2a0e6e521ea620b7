#pragma once
// Collision operators on one cell, acting on shifted populations
// g_q = f_q - w_q (deviation from the rest state rho = 1, u = 0). Storing the
// deviation keeps fp32 accurate: round-off scales with |g| ~ w*(drho + u)
// instead of w. The algebra is otherwise that of plain populations.
//
// LBGK (first paper Eq. 1 without solid term) and TRT (Ginzburg) with a second
// order equilibrium
//   f^eq_q = w_q rho [1 + c.u/cs^2 + (c.u)^2/(2cs^4) - u^2/(2cs^2)],
// and Guo et al. (2002) forcing, split for TRT into its symmetric part
// (relaxed with omega+) and antisymmetric part (omega-):
//   S_q = (1 - omega+/2) w_q [ (c.u)(c.F)/cs^4 - u.F/cs^2 ] + (1 - omega-/2) w_q (c.F)/cs^2,
//   u = (sum c f + F/2) / rho.
// BGK is the special case omega+ = omega- = 1/tau.
//
// Collider::collide is the one place these terms are written: the plain step
// applies them as they are (FluidUpdate), the PSM step of imb/psm.hpp scales
// them by 1 - B and adds its solid term. A new collision operator goes here.
#include "core/hd.hpp"
#include "lbm/lattice.hpp"

// The source-term lambdas below are always inlined into the collision on the
// host: without that GCC keeps the direction loop that calls them rolled, and
// the host row loop (core/exec.hpp for_each_cell_host) cannot vectorise the
// forced step. The device compiler inlines them as it is.
#if defined(__CUDACC__)
#define LBDEM_LAMBDA_INLINE
#else
#define LBDEM_LAMBDA_INLINE __attribute__((always_inline))
#endif

namespace lbdem::lbm {

enum class CollisionKind { BGK, TRT };

// The TRT terms of one direction pair (q, qbar = q + 1) of one cell, as the
// collision hands them to its update (for the rest population q = 0: the
// symmetric terms only, cu = eqm = dm = 0). The Guo source comes from a
// callable src(Sp, Sm) (its symmetric and antisymmetric parts, Sm = 0 at
// q = 0) that an update calls only with a body force, where it adds it: each
// update then forms its terms in its own order, and the plain collision's
// arithmetic stays what it is instruction for instruction.
template <class R>
struct TrtTerms {
  R w;         // weight w_q
  R cu;        // c_q . u
  R even;      // eqp / w = d + rho (4.5 (c_q . u)^2 - 1.5 u^2)
  R eqp, eqm;  // even and odd parts of f^eq: f^eq_q = eqp + eqm, f^eq_qbar = eqp - eqm
  R dp, dm;    // relaxations omega+ (f+_q - eqp), omega- (f-_q - eqm), f+- = (f_q +- f_qbar) / 2
};

// Density deviation d = sum f, rho = 1 + d and velocity u = (sum c f + F/2) / rho of one cell.
template <class R>
struct CellMoments {
  R d, rho, u[3];
};

// c_q . (x, y, z), in one of two forms of the same value. Explicit: every
// component multiplied by its (constant) c, zeros included: IEEE rules keep
// 0 * x, so this is the plain collision's arithmetic, bit for bit. Folded: only
// the non-zero components, added or subtracted (no multiplications once the
// direction loop is unrolled): fewer instructions and registers, for the PSM
// collision, where the solid term competes for them. The two differ at most
// in the sign of a zero. cdot is the folded form on an array.
template <class L, class R>
LBDEM_HD LBDEM_FORCEINLINE R cdot(int q, const R (&v)[3]) {
  R s = 0;
  bool any = false;
  LBDEM_UNROLL
  for (int a = 0; a < 3; ++a) {
    if (L::c(q, a) == 0) continue;
    const R t = L::c(q, a) > 0 ? v[a] : -v[a];
    s = any ? s + t : t;
    any = true;
  }
  return s;
}

template <class L, bool Folded, class R>
LBDEM_HD LBDEM_FORCEINLINE R c_dot(int q, R x, R y, R z) {
  if constexpr (!Folded) {
    return R(L::c(q, 0)) * x + R(L::c(q, 1)) * y + R(L::c(q, 2)) * z;
  } else {
    const R v[3] = {x, y, z};
    return cdot<L>(q, v);
  }
}

template <class L, class R, bool Force>
struct Collider {
  R omega_p = 1, omega_m = 1;  // 1/tau+, 1/tau-
  R F[3] = {0, 0, 0};          // body force per unit volume, lattice units

  // The fluid update: f*_q = f_q - dp - dm + Sp + Sm, f*_qbar = f_qbar - dp + dm + Sp - Sm.
  // rest(f_0, terms, moments, src) and pair(q, f_q, f_qbar, terms, moments, src)
  // are what collide() asks of an update.
  struct FluidUpdate {
    template <class Src>
    LBDEM_HD LBDEM_FORCEINLINE void rest(R& f0, const TrtTerms<R>& t, const CellMoments<R>&, const Src& src) const {
      f0 = f0 - t.dp;
      if constexpr (Force) {
        R Sp, Sm;
        src(Sp, Sm);
        f0 += Sp;
      }
    }
    template <class Src>
    LBDEM_HD LBDEM_FORCEINLINE void pair(int, R& fq, R& fqb, const TrtTerms<R>& t, const CellMoments<R>&,
                                         const Src& src) const {
      R a = fq - t.dp - t.dm;
      R b = fqb - t.dp + t.dm;
      if constexpr (Force) {
        R Sp, Sm;
        src(Sp, Sm);
        a += Sp + Sm;
        b += Sp - Sm;
      }
      fq = a;
      fqb = b;
    }
  };

  // The collision written once: moments, then per direction pair the
  // equilibrium, relaxation and source terms, which `up` turns into the
  // post-collision populations (FluidUpdate above; the PSM collision of
  // imb/psm.hpp scales them by 1 - B and adds its solid term). f: shifted
  // populations in, post-collision out; m: the cell's moments. Folded: the
  // form of the c_q . u and c_q . F products (c_dot).
  template <bool Folded, class Update>
  LBDEM_HD LBDEM_FORCEINLINE void collide(R (&f)[L::Q], CellMoments<R>& m, const Update& up) const {
    R d = 0, jx = 0, jy = 0, jz = 0;
    LBDEM_UNROLL
    for (int q = 0; q < L::Q; ++q) {
      d += f[q];
      if (L::c(q, 0)) jx += L::c(q, 0) * f[q];
      if (L::c(q, 1)) jy += L::c(q, 1) * f[q];
      if (L::c(q, 2)) jz += L::c(q, 2) * f[q];
    }
    const R rho = R(1) + d;
    const R inv_rho = R(1) / rho;
    if constexpr (Force) {
      jx += R(0.5) * F[0];
      jy += R(0.5) * F[1];
      jz += R(0.5) * F[2];
    }
    const R ux = jx * inv_rho, uy = jy * inv_rho, uz = jz * inv_rho;
    m.d = d;
    m.rho = rho;
    m.u[0] = ux;
    m.u[1] = uy;
    m.u[2] = uz;
    const R usq15 = R(1.5) * (ux * ux + uy * uy + uz * uz);
    R uF = 0, sp = 0, sm = 0;
    if constexpr (Force) {
      uF = ux * F[0] + uy * F[1] + uz * F[2];
      sp = R(1) - R(0.5) * omega_p;
      sm = R(1) - R(0.5) * omega_m;
    }
    // Rest population: symmetric only.
    {
      TrtTerms<R> t;
      t.w = R(L::w(0));
      t.cu = 0;
      t.even = d - rho * usq15;
      t.eqp = t.w * t.even;
      t.eqm = 0;
      t.dp = omega_p * (f[0] - t.eqp);
      t.dm = 0;
      const R w = t.w;
      up.rest(f[0], t, m, [&](R& Sp, R& Sm) LBDEM_LAMBDA_INLINE {
        Sp = sp * w * (R(-3) * uF);
        Sm = 0;
      });
    }
    LBDEM_UNROLL
    for (int q = 1; q < L::Q; q += 2) {
      const int qb = q + 1;  // opposite
      TrtTerms<R> t;
      t.w = R(L::w(q));
      const R w = t.w;
      const R cu = c_dot<L, Folded>(q, ux, uy, uz);
      t.cu = cu;
      t.even = d + rho * (R(4.5) * cu * cu - usq15);
      t.eqp = w * t.even;
      t.eqm = w * rho * R(3) * cu;
      const R fp = R(0.5) * (f[q] + f[qb]);
      const R fm = R(0.5) * (f[q] - f[qb]);
      t.dp = omega_p * (fp - t.eqp);
      t.dm = omega_m * (fm - t.eqm);
      up.pair(q, f[q], f[qb], t, m, [&](R& Sp, R& Sm) LBDEM_LAMBDA_INLINE {
        const R cF = c_dot<L, Folded>(q, F[0], F[1], F[2]);
        Sp = sp * w * (R(9) * cu * cF - R(3) * uF);
        Sm = sm * w * R(3) * cF;
      });
    }
  }

  // The fluid collision. Returns the density deviation and velocity (with the F/2 shift).
  LBDEM_HD LBDEM_FORCEINLINE void operator()(R (&f)[L::Q], R& drho, R (&u)[3]) const {
    CellMoments<R> m;
    collide<false>(f, m, FluidUpdate{});
    drho = m.d;
    u[0] = m.u[0];
    u[1] = m.u[1];
    u[2] = m.u[2];
  }
};

// Relaxation rates from tau (= tau+) and the TRT magic parameter
// Lambda = (tau+ - 1/2)(tau- - 1/2).
struct Relaxation {
  double omega_p, omega_m;
};
inline Relaxation relaxation(CollisionKind k, double tau, double magic) {
  if (k == CollisionKind::BGK) return {1.0 / tau, 1.0 / tau};
  const double tau_m = magic / (tau - 0.5) + 0.5;
  return {1.0 / tau, 1.0 / tau_m};
}

}  // namespace lbdem::lbm
