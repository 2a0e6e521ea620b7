// The suspension statistics (imb/suspension.hpp): the device reductions
// against host sums on known particles, and the references a suspension run
// reports (mean net weight, the Sangani-Acrivos settling slip, the slip along
// gravity) against their closed forms.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "dem/system.hpp"
#include "imb/fixed_sphere.hpp"
#include "imb/suspension.hpp"

namespace lbdem::test {
namespace {

using imb::SuspensionSample;
using imb::SuspensionStatsSpec;

// The device statistics against sums done here, on known particles.
TEST(SuspensionStatistics, ReductionsMatchHostSums) {
  dem::HostParticles hp;
  // Eight particles in one corner (2 d = 8 cells) of a 32^3 box, one far away.
  const double r = 2;
  int k = 0;
  for (double x : {1.5, 5.5})
    for (double y : {1.5, 5.5})
      for (double z : {1.5, 5.5}) hp.add({x, y, z}, r, 10.0, {0.01 * k, -0.02 + 0.001 * k, 0.003 * (k % 2)}), ++k;
  hp.add({20, 20, 20}, r, 10.0, {0, 0.05, 0});
  dem::DemParams p;
  p.lo = {0, 0, 0};
  p.hi = {32, 32, 32};
  p.periodic = {true, true, true};
  p.material.stiffness = p.material.wall_stiffness = 1e3;
  p.dt = 0.01;
  p.external_forcing = true;
  p.gravity = {0, -1e-5, 0};
  dem::DemSystem dem(Exec(Backend::Host), p, hp);
  const dem::ParticleView v = dem.view();
  for (Index i = 0; i < v.n; ++i) v.ext_force[i] = {0.1 * double(i), 2.0 + double(i), -0.5, 0};
  imb::SuspensionStatsSpec spec;
  spec.fluid_lo = {0, 0, 0};
  spec.fluid_hi = {32, 32, 32};
  spec.gravity = {0, -1e-5, 0};
  spec.body_force = {0, 3e-6, 0};
  spec.diameter = 2 * r;
  spec.filter_widths = {2, 4};
  imb::SuspensionStatistics stats(Exec(Backend::Host), spec);
  lbm::LbmDiagnostics d;
  d.momentum = {1.0, -2.0, 0.5};
  const auto s = stats.sample(dem, d);
  // Host sums in the DEM's storage order.
  const auto h = dem.download();
  const double n = double(h.size()), vp = 4.0 / 3.0 * M_PI * r * r * r;
  double mv[3] = {0, 0, 0}, vv[3] = {0, 0, 0}, f[3] = {0, 0, 0};
  for (std::size_t i = 0; i < h.x.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      mv[a] += h.v[i][a] / n;
      vv[a] += h.v[i][a] * h.v[i][a] / n;
      f[a] += dem::xyz(v.ext_force[i])[a] + vp * spec.gravity[static_cast<std::size_t>(a)];
    }
  const double vf = 32.0 * 32 * 32 - n * vp;
  for (int a = 0; a < 3; ++a) {
    const auto k3 = static_cast<std::size_t>(a);
    EXPECT_NEAR(s.particle_velocity[k3], mv[a], 1e-15);
    EXPECT_NEAR(s.velocity_variance[k3], vv[a] - mv[a] * mv[a], 1e-15);
    EXPECT_NEAR(s.drag[k3], f[a], 1e-12);
    EXPECT_NEAR(s.drag_per_particle[k3], f[a] / n, 1e-12);
    const double uf = (d.momentum[k3] + 0.5 * spec.body_force[k3] * vf - n * vp * mv[a]) / vf;
    EXPECT_NEAR(s.fluid_velocity[k3], uf, 1e-15);
    EXPECT_NEAR(s.slip[k3], uf - mv[a], 1e-15);
  }
  EXPECT_NEAR(s.granular_temperature, (vv[0] - mv[0] * mv[0] + vv[1] - mv[1] * mv[1] + vv[2] - mv[2] * mv[2]) / 3, 1e-15);
  EXPECT_NEAR(s.drag_over_weight, f[1] / (n * (10.0 - 1.0) * vp * 1e-5), 1e-12);
  // Width 2 d = 8 cells: 4^3 coarse cells; the eight corner particles share one
  // (fraction 8 vp / 512), the ninth another (vp / 512), the other 62 are empty.
  ASSERT_EQ(s.bins.size(), 2u);
  EXPECT_EQ(s.bins[0], (std::array<long, 3>{4, 4, 4}));
  EXPECT_EQ(s.bins[1], (std::array<long, 3>{2, 2, 2}));
  const double a8 = 8 * vp / 512, a1 = vp / 512, mean = (a8 + a1) / 64;
  // (volumes are binned in fixed point, 2^-20 cells: relative error ~1e-9)
  const double var = (a8 * a8 + a1 * a1) / 64 - mean * mean;
  EXPECT_NEAR(s.phi_variance[0], var, 1e-7 * var);
  EXPECT_NEAR(s.phi_variance_rel[0], var / (mean * vp / 512), 1e-7 * var / (mean * vp / 512));
  EXPECT_GT(s.phi_variance_rel[0], 1.0);  // clustered
  // The columns and the row agree in length.
  EXPECT_EQ(stats.columns().size(), stats.row(s).size());
}

// The mean net weight (m - rho_f V_p) |g| per particle: spheres in 3D; in 2D
// disks one cell deep (mass rho_s pi r^2), or with `sphere` the sphere of the
// disk's diameter and density. A held particle adds nothing but counts.
TEST(SuspensionReferences, MeanNetWeight) {
  SuspensionStatsSpec spec;
  spec.gravity = {0, -3e-5, 4e-5};  // |g| = 5e-5
  spec.fluid_density = 1;
  const double r = 2, vs = 4.0 / 3.0 * M_PI * r * r * r, g = 5e-5;
  dem::HostParticles p;
  p.add({4, 4, 4}, r, 3.0);
  p.add({12, 4, 4}, r, 5.0);
  EXPECT_NEAR(imb::mean_net_weight(spec, p), ((3 - 1) + (5 - 1)) * vs * g / 2, 1e-15);
  p.add({20, 4, 4}, r, 1e300 / vs);  // held
  EXPECT_NEAR(imb::mean_net_weight(spec, p), ((3 - 1) + (5 - 1)) * vs * g / 3, 1e-15);
  spec.dim = 2;
  dem::HostParticles d;
  d.add({4, 4, 0.5}, r, 3.0);
  d.mass[0] *= 0.75 / r;  // a disk one cell deep: 3 pi r^2
  EXPECT_NEAR(imb::mean_net_weight(spec, d), (3 - 1) * M_PI * r * r * g, 1e-15);
  EXPECT_NEAR(imb::mean_net_weight(spec, d, true), (3 - 1) * vs * g, 1e-15);
  spec.gravity = {0, 0, 0};
  EXPECT_EQ(imb::mean_net_weight(spec, p), 0.0);
}

// One sphere settling in a periodic cube: the terminal slip of the Stokes
// drag of a simple cubic array, W / ((1 - phi)^2 3 pi mu d K(d/L)), with K
// within a percent of Hasimoto's dilute limit at d/L = 1/4; 0 for any other
// kind of scene.
TEST(SuspensionReferences, PeriodicSettlingSlip) {
  SuspensionStatsSpec spec;
  spec.gravity = {0, -1e-5, 0};
  spec.diameter = 8;
  const double r = 4, vs = 4.0 / 3.0 * M_PI * r * r * r, tau = 0.8, mu = 0.1;
  const std::array<long, 3> cube{32, 32, 32};
  const double phi = vs / (32.0 * 32 * 32), W = (2.0 - 1.0) * vs * 1e-5;
  dem::HostParticles p;
  p.add({16, 16, 16}, r, 2.0);
  const double w = imb::periodic_settling_reference(spec, p, cube, tau, phi);
  const double K = W / (w * (1 - phi) * (1 - phi) * 3 * M_PI * mu * 8);
  EXPECT_NEAR(K, imb::sangani_acrivos_K(0.25), 1e-12 * K);
  const double hasimoto = 1 / (1 - 1.7601 * std::cbrt(phi) + phi - 1.5593 * phi * phi);
  EXPECT_NEAR(K, hasimoto, 0.01 * hasimoto);
  EXPECT_EQ(imb::periodic_settling_reference(spec, p, {32, 32, 48}, tau, phi), 0.0);  // not a cube
  spec.periodic = {true, false, true};
  EXPECT_EQ(imb::periodic_settling_reference(spec, p, cube, tau, phi), 0.0);  // a wall
  spec.periodic = {true, true, true};
  dem::HostParticles two = p;
  two.add({4, 4, 4}, r, 2.0);
  EXPECT_EQ(imb::periodic_settling_reference(spec, two, cube, tau, phi), 0.0);  // two spheres
  dem::HostParticles held;
  held.add({16, 16, 16}, r, 1e300 / vs);
  EXPECT_EQ(imb::periodic_settling_reference(spec, held, cube, tau, phi), 0.0);
  spec.gravity = {0, 0, 0};
  EXPECT_EQ(imb::periodic_settling_reference(spec, p, cube, tau, phi), 0.0);  // no weight
}

// The slip along -g: the projection on the unit vector opposite gravity;
// along y without gravity.
TEST(SuspensionReferences, SlipAlongGravity) {
  SuspensionStatsSpec spec;
  SuspensionSample s;
  s.slip = {1, 2, 3};
  spec.gravity = {3e-6, 0, -4e-6};
  EXPECT_NEAR(imb::slip_along_gravity(spec, s), -(3 - 12) / 5.0, 1e-15);
  spec.gravity = {0, 0, 0};
  EXPECT_EQ(imb::slip_along_gravity(spec, s), 2.0);
}

}  // namespace
}  // namespace lbdem::test
