// Tangential contact: Coulomb sliding on a wall, rolling transition, history
// sign and survival across neighbour-list rebuilds and reordering.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "dem_test_util.hpp"

using namespace lbdem;
using namespace lbdem::dem;
using namespace lbdem::dem::test;

class DemFriction : public ::testing::TestWithParam<Backend> {};

// A sphere put down at its static overlap mg/k with speed v0 and no spin
// slides: the wall's Coulomb force mu*m*g decelerates it at exactly mu*g
// while the friction torque spins it up (omega r = 5/2 mu g t); it rolls
// without slip from t = 2 v0 / (7 mu g) on, at v = 5/7 v0 (rigid-body
// result). The normal force equals mg exactly (no bounce), so the sliding
// deceleration is exact up to round-off and the brief elastic loading of the
// tangential spring at the start (a few t_c); we fit it over the middle of the
// sliding phase: tolerance 0.5 %. The rolling speed carries the tangential
// spring's residual oscillation (~k_t-limited, damped): tolerance 1 %.
TEST_P(DemFriction, SlidingParticleDeceleratesAtMuG) {
  const double r = 0.01, rho = 2600, k = 1e4, mu = 0.3, v0 = 1.0;
  for (ForcePath path : {ForcePath::Particle, ForcePath::Pair}) {
    HostParticles h;
    h.add({0, 0, 0}, r, rho, {v0, 0, 0});
    const double m = h.mass[0];
    h.x[0].y = r - m * kG / k;
    DemParams p;
    p.lo = {-1, -0.1, -0.1};
    p.hi = {1, 0.1, 0.1};
    p.walls = {Wall{{0, 0, 0}, {0, 1, 0}}};
    p.material = simple_material(k, 0.5, mu);
    p.friction = true;
    p.gravity = {0, -kG, 0};
    p.path = path;
    p.dt = min_collision_time(p, h) / 50;
    DemSystem sys(Exec(GetParam()), p, h);
    const double ts = 2 * v0 / (7 * mu * kG);
    const long n1 = static_cast<long>(0.2 * ts / p.dt), n2 = static_cast<long>(0.8 * ts / p.dt);
    sys.advance(n1);
    const HostParticles a = sys.download();
    sys.advance(n2 - n1);
    const HostParticles b = sys.download();
    const double decel = (a.v[0].x - b.v[0].x) / ((n2 - n1) * p.dt);
    EXPECT_NEAR(decel, mu * kG, 0.005 * mu * kG) << to_string(path);
    EXPECT_NEAR(b.w[0].z * r, -2.5 * mu * kG * (n2 * p.dt), 0.01 * 2.5 * mu * kG * n2 * p.dt);
    sys.advance(static_cast<long>(0.5 * ts / p.dt));
    const HostParticles c = sys.download();
    EXPECT_NEAR(c.v[0].x, 5.0 / 7.0 * v0, 0.01 * v0) << to_string(path);
    EXPECT_NEAR(c.v[0].x, -c.w[0].z * r, 0.01 * v0);  // rolling without slip
    if (path == ForcePath::Particle)
      std::printf("[ sliding ] deceleration %.6f m/s^2 vs mu g = %.6f; rolling speed %.5f vs 5/7 v0 = %.5f\n", decel,
                  mu * kG, c.v[0].x, 5.0 / 7.0 * v0);
  }
}

namespace {

// Two spheres in an oblique contact, translating together across several
// cells (so the list is rebuilt several times and their storage order flips
// between rebuilds) while B slides tangentially over A.
struct ObliquePair {
  DemParams p;
  HostParticles h;
  Vec3d n, t;  // contact normal A->B and tangent
  ObliquePair(double skin, ForcePath path) {
    const double r = 0.5, rho = 1000, k = 1e3;
    n = {-0.6, 0.8, 0};
    t = {0.8, 0.6, 0};
    p.lo = {-20, -20, -20};
    p.hi = {20, 20, 20};
    p.material = simple_material(k, 0.9, 0.5);
    p.friction = true;
    p.skin = skin;
    p.path = path;
    h.add({0.3, 0.05, 0}, r, rho, {0, 0, 0});
    const double meff = 0.5 * h.mass[0];
    const double tc = collision_time(k, meff, 0.9);
    const double vy = 2.5 / tc;  // crosses > 2 cells during the contact
    h.v[0] = {0, vy, 0};
    h.add(h.x[0] + n * (2 * r - 0.02), r, rho, Vec3d{0, vy, 0} + t * 0.05 - n * 0.05);
    p.dt = min_collision_time(p, h) / 50;
  }
};

}  // namespace

// The tangential history survives rebuilds and reordering on both paths
// (the pair path keeps one copy per pair, in the lower storage index's row,
// which flips here): runs rebuilt every few steps agree with one that never
// rebuilds (skin wider than the whole motion) to round-off (1e-10 of the
// force; a lost or sign-flipped history would change the tangential force by
// its full size). Sign convention: while B sticks, the tangential force on B
// opposes B's tangential displacement relative to A.
TEST_P(DemFriction, HistorySurvivesRebuildsAndReordering) {
  ObliquePair ref_setup(8.0, ForcePath::Particle);
  DemSystem ref(Exec(GetParam()), ref_setup.p, ref_setup.h);
  ObliquePair s1(0.05, ForcePath::Particle), s2(0.05, ForcePath::Pair);
  DemSystem a(Exec(GetParam()), s1.p, s1.h), b(Exec(GetParam()), s2.p, s2.h);
  const long steps = 36;  // the contact lasts ~40 steps
  bool flipped_seen[2] = {false, false};
  double worst = 0;
  for (long s = 0; s < steps; ++s) {
    ref.advance(1);
    a.advance(1);
    b.advance(1);
    const HostParticles hr = ref.download(), ha = a.download(), hb = b.download();
    auto f_of = [](const HostParticles& h, std::int64_t id) { return h.id[0] == id ? h.f[0] : h.f[1]; };
    const double scale = norm(f_of(hr, 1));
    ASSERT_GT(scale, 0) << "contact lost at step " << s;
    worst = std::max({worst, norm(f_of(ha, 1) - f_of(hr, 1)) / scale, norm(f_of(hb, 1) - f_of(hr, 1)) / scale});
    flipped_seen[hb.id[0] == 1 ? 1 : 0] = true;
    if (s == 10) {
      // Sticking early on: the tangential force on B points against t.
      const Vec3d fb = f_of(hr, 1);
      const Vec3d nn = hr.id[0] == 0 ? (hr.x[1] - hr.x[0]) : (hr.x[0] - hr.x[1]);
      const Vec3d nu = nn * (1.0 / norm(nn));
      const Vec3d ft = fb - nu * dot(fb, nu);
      EXPECT_LT(dot(ft, s1.t), 0.0);
      EXPECT_GT(norm(ft), 1e-3 * norm(fb));
    }
  }
  EXPECT_LT(worst, 1e-10);
  EXPECT_EQ(ref.stats().rebuilds, 0);
  EXPECT_GE(a.stats().rebuilds, 3);
  EXPECT_GE(b.stats().rebuilds, 3);
  EXPECT_TRUE(flipped_seen[0] && flipped_seen[1]) << "storage order of the pair never flipped";
  std::printf("[ history ] rebuilds %ld, worst force difference vs never-rebuilt %.2e\n", b.stats().rebuilds, worst);
}

INSTANTIATE_TEST_SUITE_P(All, DemFriction, ::testing::ValuesIn(lbdem::test::backends()), lbdem::test::backend_name);

// An inclined plane (normal not along an axis), sphere released at rest at
// its static overlap: frictionless it slides down at g sin(theta); with
// friction mu = 0.5 > 2/7 tan(theta) it rolls without slip at 5/7 g sin(theta)
// (rigid-body results). Start-up transients of the normal and tangential
// springs last a few t_c and average out over the 2000-step fit window:
// tolerance 0.5 %.
TEST_P(DemFriction, InclinedWallSlidesAndRolls) {
  const double th = 25.0 * M_PI / 180.0, r = 0.01, k = 1e4;
  const Vec3d nrm{-std::sin(th), std::cos(th), 0};  // wall normal, tilted about z
  const Vec3d down{-std::cos(th), -std::sin(th), 0};  // down-slope direction
  for (bool friction : {false, true}) {
    HostParticles h;
    h.add({0, 0, 0}, r, 2600);
    const double m = h.mass[0];
    const double delta = m * kG * std::cos(th) / k;
    h.x[0] = nrm * (r - delta);
    DemParams p;
    p.lo = {-2, -2, -0.1};
    p.hi = {2, 2, 0.1};
    p.walls = {Wall{{0, 0, 0}, nrm * 3.0}};  // any length: normalised by the engine
    p.material = simple_material(k, 0.5, friction ? 0.5 : 0.0);
    p.friction = friction;
    p.gravity = {0, -kG, 0};
    p.dt = min_collision_time(p, h) / 50;
    DemSystem sys(Exec(GetParam()), p, h);
    sys.advance(200);
    const HostParticles a = sys.download();
    sys.advance(2000);
    const HostParticles b = sys.download();
    const double acc = (dot(b.v[0], down) - dot(a.v[0], down)) / (2000 * p.dt);
    const double expect = (friction ? 5.0 / 7.0 : 1.0) * kG * std::sin(th);
    EXPECT_NEAR(acc, expect, 0.005 * expect) << "friction " << friction;
    EXPECT_NEAR(dot(b.v[0], nrm), 0.0, 1e-3 * dot(b.v[0], down));  // stays on the plane
  }
}
