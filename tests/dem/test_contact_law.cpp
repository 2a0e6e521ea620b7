// Contact law: damping from restitution, collision time, binary collisions
// returning the prescribed restitution, refusal of too-large time steps.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "dem_test_util.hpp"

using namespace lbdem;
using namespace lbdem::dem;
using namespace lbdem::dem::test;

// The corrected Eqs. 9-11 of Yu et al. (2024): with eta = 2 beta sqrt(k m),
// exp(-eta t_c / (2 m)) returns e and t_c = pi / sqrt(k/m - eta^2/(4 m^2)).
// Pure arithmetic: tolerance 1e-12 (round-off of log/exp/sqrt).
TEST(DemContactLaw, DampingFormulaReturnsRestitution) {
  const double k = 1e4, m = 0.3;
  for (double e = 0.05; e <= 1.0 + 1e-12; e += 0.05) {
    const double b = damping_ratio_from_restitution(e);
    const double eta = 2 * b * std::sqrt(k * m);
    const double tc = collision_time(k, m, e);
    EXPECT_NEAR(tc, M_PI / std::sqrt(k / m - eta * eta / (4 * m * m)), 1e-12 * tc);
    EXPECT_NEAR(std::exp(-eta * tc / (2 * m)), e, 1e-12);
    // The paper's printed Eq. 11 (sqrt(2 k m)) would not: it misses e by > 1 %
    // for e = 0.5, which is why it is recorded as a typo.
    if (std::fabs(e - 0.5) < 1e-9) {
      const double eta_paper = std::sqrt(2 * k * m) * b;
      const double tcp = M_PI / std::sqrt(k / m - eta_paper * eta_paper / (m * m));
      EXPECT_GT(std::fabs(std::exp(-eta_paper * tcp / (2 * m)) - e), 0.01);
    }
  }
}

class DemBinary : public ::testing::TestWithParam<Backend> {};

// Head-on collision of two equal spheres without gravity: post/pre normal
// relative speed = e. Contact onset and release fall between steps and the
// dashpot sees predicted velocities; with the onset/release quadrature
// (contact.hpp) and the extrapolating velocity predictor (kernels.hpp) the
// remaining error is second order in dt and grows with damping: measured
// worst (e = 0.1, over contact phases) 2.7e-3 at the production step t_c/50
// and 5.6e-4 at t_c/100; e >= 0.5 stay below 3.3e-4. Asserted: the issue's
// 0.5 % at both steps, for every e.
TEST_P(DemBinary, RestitutionCoefficient) {
  const double r = 0.01, rho = 2600, k = 1e4, v0 = 0.5;
  for (double steps_per_tc : {100.0, 50.0}) {
  double worst = 0;
  for (ForcePath path : {ForcePath::Particle, ForcePath::Pair}) {
    for (int ie = 1; ie <= 10; ++ie) {
      const double e = 0.1 * ie;
      HostParticles hp;
      hp.add({-r - 5e-4, 0, 0}, r, rho, {v0, 0, 0});
      hp.add({r + 5e-4, 0, 0}, r, rho, {-v0, 0, 0});
      DemParams p = open_box(0.2);
      p.material = simple_material(k, e);
      const double tc = collision_time(k, 0.5 * hp.mass[0], e);
      p.dt = tc / steps_per_tc;
      p.path = path;
      DemSystem sys(Exec(GetParam()), p, hp);
      const long steps = static_cast<long>((1e-3 / (2 * v0) + 1.5 * tc) / p.dt) + 10;
      sys.advance(steps);
      HostParticles out = sys.download();
      const int a = out.id[0] == 0 ? 0 : 1, b = 1 - a;
      const double e_meas = (out.v[b].x - out.v[a].x) / (2 * v0);
      worst = std::max(worst, std::fabs(e_meas - e) / e);
      EXPECT_NEAR(e_meas, e, 0.005 * e) << "e = " << e << " path " << to_string(path) << " dt = t_c/" << steps_per_tc;
      // Momentum is conserved to round-off by both paths (Newton's third law).
      EXPECT_NEAR(out.v[a].x + out.v[b].x, 0.0, 1e-12);
    }
  }
  std::printf("[ restitution ] dt = t_c/%g: worst relative error over e = 0.1..1 = %.3e\n", steps_per_tc, worst);
  }
}
INSTANTIATE_TEST_SUITE_P(All, DemBinary, ::testing::ValuesIn(lbdem::test::backends()), lbdem::test::backend_name);

// A case whose step exceeds t_c/50 is refused with the numbers.
TEST(DemContactLaw, TooLargeTimeStepIsRefused) {
  HostParticles hp;
  hp.add({0, 0, 0}, 0.1, 2600);
  hp.add({0.3, 0, 0}, 0.1, 2600);
  DemParams p = open_box(1);
  p.material = simple_material(1e4, 0.9);
  const double tc = min_collision_time(p, hp);
  p.dt = tc / 40;
  try {
    DemSystem sys(Exec(Backend::Host), p, hp);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& err) {
    const std::string msg = err.what();
    EXPECT_NE(msg.find("time.dt"), std::string::npos) << msg;
    EXPECT_NE(msg.find("t_c"), std::string::npos) << msg;
  }
  p.dt = tc / 50;
  EXPECT_NO_THROW(DemSystem(Exec(Backend::Host), p, hp));
}
