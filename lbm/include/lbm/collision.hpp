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
#include "core/hd.hpp"
#include "lbm/lattice.hpp"

namespace lbdem::lbm {

enum class CollisionKind { BGK, TRT };

template <class L, class R, bool Force>
struct Collider {
  R omega_p = 1, omega_m = 1;  // 1/tau+, 1/tau-
  R F[3] = {0, 0, 0};          // body force per unit volume, lattice units

  // f: shifted populations in (incoming), post-collision out.
  // Returns the density deviation and velocity (with the F/2 shift).
  LBDEM_HD LBDEM_FORCEINLINE void operator()(R (&f)[L::Q], R& drho, R (&u)[3]) const {
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
    const R usq15 = R(1.5) * (ux * ux + uy * uy + uz * uz);
    R uF = 0, sp = 0, sm = 0;
    if constexpr (Force) {
      uF = ux * F[0] + uy * F[1] + uz * F[2];
      sp = R(1) - R(0.5) * omega_p;
      sm = R(1) - R(0.5) * omega_m;
    }
    // Rest population: symmetric only.
    {
      const R w = R(L::w(0));
      const R eq = w * (d - rho * usq15);
      f[0] = f[0] - omega_p * (f[0] - eq);
      if constexpr (Force) f[0] += sp * w * (R(-3) * uF);
    }
    LBDEM_UNROLL
    for (int q = 1; q < L::Q; q += 2) {
      const int qb = q + 1;  // opposite
      const R w = R(L::w(q));
      const R cu = R(L::c(q, 0)) * ux + R(L::c(q, 1)) * uy + R(L::c(q, 2)) * uz;
      const R eqp = w * (d + rho * (R(4.5) * cu * cu - usq15));
      const R eqm = w * rho * R(3) * cu;
      const R fp = R(0.5) * (f[q] + f[qb]);
      const R fm = R(0.5) * (f[q] - f[qb]);
      const R dp = omega_p * (fp - eqp);
      const R dm = omega_m * (fm - eqm);
      R a = f[q] - dp - dm;
      R b = f[qb] - dp + dm;
      if constexpr (Force) {
        const R cF = R(L::c(q, 0)) * F[0] + R(L::c(q, 1)) * F[1] + R(L::c(q, 2)) * F[2];
        const R Sp = sp * w * (R(9) * cu * cF - R(3) * uF);
        const R Sm = sm * w * R(3) * cF;
        a += Sp + Sm;
        b += Sp - Sm;
      }
      f[q] = a;
      f[qb] = b;
    }
    drho = d;
    u[0] = ux;
    u[1] = uy;
    u[2] = uz;
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
