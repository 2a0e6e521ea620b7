// The PSM collision of one cell (imb/psm.hpp psm_collide) against identities
// that hold whatever the implementation: it is the fluid collision of
// lbm::Collider with the fluid terms scaled by 1 - B plus a solid term, so
//  - B = 0 gives the fluid collision;
//  - superposition without force: f* = f^post + B (f^eq(rho, V) - f^eq(rho, u))
//    (Holdych et al. 2003), f^post the fluid collision;
//  - NEBB at B = 1 without force: f*_q = f_qbar + the odd part of
//    f^eq_q(rho, V) - f^eq_qbar(rho, u) (first paper Eq. 2 without its even
//    part, imb/psm.hpp; the fluid term switched off), and the even populations
//    f_q + f_qbar are left as they came in;
//  - the momentum the solid term gives the fluid is minus the closed-form force
//    on the particle (psm_particle_force), for both operators, with and without
//    a body force;
//  - fluid and particle together gain (1 - B) F per step, or exactly F when the
//    particle takes its share B F of the body force (PsmOptions::body_force_on_solid);
//  - NEBB with even relaxation (PsmOptions::even_relaxation: a solid term with
//    the even part -B omega+ (f+ - eq+)): every cell keeps its mass, the
//    momentum and the force on the particle are those without it, and without
//    a body force the even populations f_q + f_qbar are the fluid collision's
//    at any B (relaxed at omega+ in full, covered cells included).
//    Without it (Be = 0) the populations are the same bits as before the option.
// D3Q19 and D2Q9 in double: the tolerances are round-off of populations ~1e-2.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "imb/psm.hpp"
#include "lbm/lattice.hpp"

namespace lbdem::imb {
namespace {

constexpr double kTol = 2e-15;

// Shifted equilibrium f^eq_q - w_q at (rho, u), written out independently of the kernels.
template <class L>
double feq_shifted(int q, double rho, const double (&u)[3]) {
  double cu = 0, uu = 0;
  for (int a = 0; a < 3; ++a) {
    cu += L::c(q, a) * u[a];
    uu += u[a] * u[a];
  }
  return L::w(q) * (rho * (1 + 3 * cu + 4.5 * cu * cu - 1.5 * uu) - 1);
}

// Incoming shifted populations near equilibrium, with a non-equilibrium part.
template <class L>
void random_cell(std::mt19937& rng, double (&f)[L::Q]) {
  std::uniform_real_distribution<double> U(-1, 1);
  const double rho = 1 + 0.02 * U(rng);
  const double u[3] = {0.05 * U(rng), 0.05 * U(rng), L::D == 3 ? 0.05 * U(rng) : 0.0};
  for (int q = 0; q < L::Q; ++q) f[q] = feq_shifted<L>(q, rho, u) + 1e-3 * L::w(q) * U(rng);
}

template <class L, bool Force>
lbm::Collider<L, double, Force> collider(const double (&F)[3]) {
  lbm::Collider<L, double, Force> c;
  const lbm::Relaxation r = lbm::relaxation(lbm::CollisionKind::TRT, 0.8, 3.0 / 16.0);
  c.omega_p = r.omega_p;
  c.omega_m = r.omega_m;
  for (int a = 0; a < 3; ++a) c.F[a] = F[a];
  return c;
}

// Solid moments of one particle of weight B moving at V at the cell centre.
void one_particle(double B, const double (&V)[3], double (&M1)[3], double (&M2)[6]) {
  for (double& m : M1) m = 0;
  for (double& m : M2) m = 0;
  add_solid_moments(B, V, M1, M2);
}

template <class L, bool Force, PsmVariant Var>
void check_lattice(std::mt19937& rng, bool even) {
  const double F[3] = {Force ? 2e-5 : 0.0, Force ? -1e-5 : 0.0, Force && L::D == 3 ? 3e-5 : 0.0};
  const auto coll = collider<L, Force>(F);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int trial = 0; trial < 50; ++trial) {
    double f[L::Q];
    random_cell<L>(rng, f);
    double fluid[L::Q];
    for (int q = 0; q < L::Q; ++q) fluid[q] = f[q];
    double drho, uf[3];
    coll(fluid, drho, uf);

    // B = 0: the fluid collision.
    {
      double g[L::Q], rho, u[3];
      for (int q = 0; q < L::Q; ++q) g[q] = f[q];
      const double M1[3] = {0, 0, 0}, M2[6] = {0, 0, 0, 0, 0, 0};
      psm_collide<L, double, Force, Var>(coll, g, 0.0, 0.0, M1, M2, rho, u);
      for (int q = 0; q < L::Q; ++q) ASSERT_NEAR(g[q], fluid[q], kTol) << "q " << q;
      EXPECT_NEAR(rho, 1 + drho, kTol);
      for (int a = 0; a < 3; ++a) EXPECT_NEAR(u[a], uf[a], kTol);
    }

    const double B = 0.5 * (1 + U(rng));
    const double V[3] = {0.04 * U(rng), 0.04 * U(rng), L::D == 3 ? 0.04 * U(rng) : 0.0};
    double M1[3], M2[6];
    one_particle(B, V, M1, M2);
    double g[L::Q], rho, u[3];
    for (int q = 0; q < L::Q; ++q) g[q] = f[q];
    const double Be = even && Var == PsmVariant::NEBB ? B : 0.0;
    psm_collide<L, double, Force, Var>(coll, g, B, Be, M1, M2, rho, u);

    // Every cell keeps its mass (the solid term has none, even part included).
    double m_in = 0, m_out = 0;
    for (int q = 0; q < L::Q; ++q) {
      m_in += f[q];
      m_out += g[q];
    }
    EXPECT_NEAR(m_out, m_in, kTol);
    if (Var == PsmVariant::NEBB && even) {
      // The even part relaxed as in the fluid collision (with a body force the
      // fluid's even source share stays (1 - B) Sp: checked through mass and
      // momentum above and below).
      if constexpr (!Force)
        for (int q = 1; q < L::Q; ++q)
          ASSERT_NEAR(g[q] + g[L::opp(q)], fluid[q] + fluid[L::opp(q)], kTol) << "q " << q;
      // The odd part is that of the step without even relaxation.
      double h[L::Q], rh, uh[3];
      for (int q = 0; q < L::Q; ++q) h[q] = f[q];
      psm_collide<L, double, Force, Var>(coll, h, B, 0.0, M1, M2, rh, uh);
      EXPECT_EQ(rh, rho);
      for (int q = 1; q < L::Q; ++q)
        ASSERT_NEAR(g[q] - g[L::opp(q)], h[q] - h[L::opp(q)], kTol) << "q " << q;
      if constexpr (!Force) {  // and the even part differs where f+ is off equilibrium
        double diff = 0;
        for (int q = 0; q < L::Q; ++q) diff += std::abs(g[q] - h[q]);
        EXPECT_GT(diff, 1e-12);  // B * omega+ * |f+ - eq+| (f+ - eq+ ~ 1e-4 here), above round-off (~1e-16)
      }
    }

    if constexpr (!Force && Var == PsmVariant::Superposition) {
      for (int q = 0; q < L::Q; ++q)
        ASSERT_NEAR(g[q], fluid[q] + B * (feq_shifted<L>(q, rho, V) - feq_shifted<L>(q, rho, u)), kTol) << "q " << q;
    }
    if (!Force && Var == PsmVariant::NEBB && !even) {
      double h[L::Q], rh, uh[3];
      for (int q = 0; q < L::Q; ++q) h[q] = f[q];
      one_particle(1.0, V, M1, M2);
      psm_collide<L, double, Force, Var>(coll, h, 1.0, 0.0, M1, M2, rh, uh);
      for (int q = 0; q < L::Q; ++q) {
        const int qb = L::opp(q);
        const double odd_V = 0.5 * (feq_shifted<L>(q, rh, V) - feq_shifted<L>(qb, rh, V));
        const double odd_u = 0.5 * (feq_shifted<L>(q, rh, uh) - feq_shifted<L>(qb, rh, uh));
        ASSERT_NEAR(h[q], f[qb] + odd_V + odd_u, kTol) << "q " << q;
        ASSERT_NEAR(h[q] + h[qb], f[q] + f[qb], kTol) << "q " << q;
      }
    }

    // Momentum of the solid term = what the PSM step gives beyond (1 - B) times
    // the fluid collision's change; the force on the particle is minus it.
    double solid_mom[3] = {0, 0, 0};
    for (int q = 0; q < L::Q; ++q) {
      const double solid = (g[q] - f[q]) - (1 - B) * (fluid[q] - f[q]);
      for (int a = 0; a < 3; ++a) solid_mom[a] += L::c(q, a) * solid;
    }
    const double G0[3] = {0, 0, 0};
    double Fk[3];
    psm_particle_force<double, Force, Var>(B, rho, V, u, F, G0, coll.omega_m, Fk);
    for (int a = 0; a < 3; ++a) EXPECT_NEAR(Fk[a], -solid_mom[a], 1e-14) << "axis " << a;

    // The cell's whole momentum gain, fluid plus particle: (1 - B) F without
    // the particle's share of the body force, exactly F with it (G = F,
    // PsmOptions::body_force_on_solid), whatever B is.
    double fluid_mom[3] = {0, 0, 0};
    for (int q = 0; q < L::Q; ++q)
      for (int a = 0; a < 3; ++a) fluid_mom[a] += L::c(q, a) * (g[q] - f[q]);
    double Fs[3];
    psm_particle_force<double, Force, Var>(B, rho, V, u, F, F, coll.omega_m, Fs);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(fluid_mom[a] + Fk[a], (1 - B) * F[a], 1e-14) << "axis " << a;
      EXPECT_NEAR(fluid_mom[a] + Fs[a], F[a], 1e-14) << "axis " << a;
      if (Force && F[a] != 0) {
        EXPECT_NE(Fs[a], Fk[a]);  // the share is there
      }
    }
  }
}

template <class L>
void check_all() {
  std::mt19937 rng(12345);
  for (const bool even : {false, true}) {
    check_lattice<L, false, PsmVariant::NEBB>(rng, even);
    check_lattice<L, true, PsmVariant::NEBB>(rng, even);
    check_lattice<L, false, PsmVariant::Superposition>(rng, even);
    check_lattice<L, true, PsmVariant::Superposition>(rng, even);
  }
}

TEST(PsmCollision, IsFluidCollisionPlusSolidTermD3Q19) { check_all<lbm::D3Q19>(); }
TEST(PsmCollision, IsFluidCollisionPlusSolidTermD2Q9) { check_all<lbm::D2Q9>(); }

}  // namespace
}  // namespace lbdem::imb
