// Lattice identities and equilibrium moments.
#include <gtest/gtest.h>

#include <cmath>

#include "lbm/collision.hpp"
#include "lbm/lattice.hpp"

using namespace lbdem;
using namespace lbdem::lbm;

template <class L>
void check_equilibrium_moments() {
  // Equilibrium of (rho, u) must carry density rho, momentum rho u and the
  // second moment rho cs^2 I + rho u u exactly (second-order equilibrium).
  const double rho = 1.07, u[3] = {0.031, -0.017, L::D == 3 ? 0.022 : 0.0};
  double m0 = 0, m1[3] = {0, 0, 0}, m2[3][3] = {};
  const double usq = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
  for (int q = 0; q < L::Q; ++q) {
    const double cu = L::c(q, 0) * u[0] + L::c(q, 1) * u[1] + L::c(q, 2) * u[2];
    const double feq = L::w(q) * rho * (1 + 3 * cu + 4.5 * cu * cu - 1.5 * usq);
    m0 += feq;
    for (int a = 0; a < 3; ++a) {
      m1[a] += feq * L::c(q, a);
      for (int b = 0; b < 3; ++b) m2[a][b] += feq * L::c(q, a) * L::c(q, b);
    }
  }
  EXPECT_NEAR(m0, rho, 1e-15);
  for (int a = 0; a < L::D; ++a) {
    EXPECT_NEAR(m1[a], rho * u[a], 1e-15);
    for (int b = 0; b < L::D; ++b)
      EXPECT_NEAR(m2[a][b], rho * (a == b ? 1.0 / 3.0 : 0.0) + rho * u[a] * u[b], 1e-15) << a << b;
  }
}

TEST(Lattice, OppositesPairUp) {
  for (int q = 0; q < D3Q19::Q; ++q) {
    EXPECT_EQ(D3Q19::opp(D3Q19::opp(q)), q);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(D3Q19::c(D3Q19::opp(q), a), -D3Q19::c(q, a));
  }
  for (int q = 0; q < D2Q9::Q; ++q)
    for (int a = 0; a < 3; ++a) EXPECT_EQ(D2Q9::c(D2Q9::opp(q), a), -D2Q9::c(q, a));
}

TEST(Lattice, EquilibriumMomentsD2Q9) { check_equilibrium_moments<D2Q9>(); }
TEST(Lattice, EquilibriumMomentsD3Q19) { check_equilibrium_moments<D3Q19>(); }

template <class L>
void check_collision_invariants(bool force) {
  // Collision conserves mass; momentum grows by exactly F (Guo forcing), for
  // BGK and TRT, from a random non-equilibrium state.
  Collider<L, double, true> c;
  const Relaxation r = relaxation(CollisionKind::TRT, 0.73, 0.21);
  c.omega_p = r.omega_p;
  c.omega_m = r.omega_m;
  const double F[3] = {force ? 1e-4 : 0, force ? -2e-4 : 0, (force && L::D == 3) ? 3e-5 : 0};
  for (int a = 0; a < 3; ++a) c.F[a] = F[a];
  double f[L::Q];
  for (int q = 0; q < L::Q; ++q) f[q] = 0.01 * std::sin(1.3 * q + 0.2);
  double m0 = 0, j0[3] = {0, 0, 0};
  for (int q = 0; q < L::Q; ++q) {
    m0 += f[q];
    for (int a = 0; a < 3; ++a) j0[a] += L::c(q, a) * f[q];
  }
  double drho, u[3];
  c(f, drho, u);
  double m1 = 0, j1[3] = {0, 0, 0};
  for (int q = 0; q < L::Q; ++q) {
    m1 += f[q];
    for (int a = 0; a < 3; ++a) j1[a] += L::c(q, a) * f[q];
  }
  EXPECT_NEAR(m1, m0, 1e-16);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(j1[a] - j0[a], F[a], 1e-17);
}

TEST(Collision, ConservesMassMomentumGrowsByForceD2Q9) {
  check_collision_invariants<D2Q9>(false);
  check_collision_invariants<D2Q9>(true);
}
TEST(Collision, ConservesMassMomentumGrowsByForceD3Q19) {
  check_collision_invariants<D3Q19>(false);
  check_collision_invariants<D3Q19>(true);
}
