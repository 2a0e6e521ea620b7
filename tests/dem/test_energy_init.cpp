// Energy conservation of an elastic frictionless dense gas, and the
// initialisers (random packing, lattice, CSV).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>

#include "dem/init.hpp"
#include "dem_test_util.hpp"

using namespace lbdem;
using namespace lbdem::dem;
using namespace lbdem::dem::test;

namespace {

// Kinetic + elastic energy [J] (frictionless: no rotation, no walls).
double total_energy(const DemSystem& sys, double k) {
  const HostParticles h = sys.download();
  double e = 0;
  std::map<std::int64_t, Index> at;
  for (Index i = 0; i < h.size(); ++i) {
    e += 0.5 * h.mass[i] * dot(h.v[i], h.v[i]);
    at[h.id[i]] = i;
  }
  Box box;
  const DemParams& p = sys.params();
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = p.lo[a];
    box.len[a] = p.hi[a] - p.lo[a];
    box.periodic[a] = p.periodic[a];
  }
  for (auto [ga, gb] : sys.contact_pairs()) {
    const Index i = at[ga], j = at[gb];
    const double d = h.r[i] + h.r[j] - norm(box.min_image(h.x[j] - h.x[i]));
    e += 0.5 * k * d * d;
  }
  return e;
}

}  // namespace

class DemEnergy : public ::testing::TestWithParam<Backend> {};

// e = 1, no friction, 1000 polydisperse spheres at solid fraction 0.4 in a
// periodic box, Maxwellian velocities, dt = t_c/50, 10,000 steps (about 200
// collision times; every particle collides many times). Velocity Verlet is
// symplectic: for smooth forces the energy error stays bounded at
// O((omega dt)^2) ~ (pi/50)^2 ~ 4e-3 of the energy stored in contacts, with
// no drift. The force is only piecewise smooth (switches on at contact); the
// onset/release quadrature (contact.hpp) keeps each collision's energy error
// second order and of random sign, so the total does a random walk of tiny
// steps. Measured: max |E - E0|/E0 ~ 1e-4 over the run; asserted 2e-3 (a
// first-order error at contact switch-on would give ~1e-2 per collision
// generation and fail this), plus a drift bound between the first and last
// tenth.
TEST_P(DemEnergy, ElasticDenseGasConservesEnergy) {
  RandomPackingSpec spec;
  spec.lo = {0, 0, 0};
  spec.hi = {12, 12, 12};
  spec.solid_fraction = 0.4;
  spec.r_min = 0.4;
  spec.r_max = 0.6;
  spec.seed = 5;
  HostParticles h = random_packing(spec);
  ASSERT_GT(h.size(), 900);
  std::mt19937_64 rng(1);
  std::normal_distribution<double> N(0, 1);
  Vec3d mean{};
  for (auto& v : h.v) { v = Vec3d{N(rng), N(rng), N(rng)} * 0.3; mean += v; }
  for (auto& v : h.v) v -= mean * (1.0 / h.size());
  DemParams p;
  p.lo = spec.lo;
  p.hi = spec.hi;
  p.periodic = {true, true, true};
  const double k = 2e4;
  p.material = simple_material(k, 1.0);
  p.dt = min_collision_time(p, h) / 50;
  DemSystem sys(Exec(GetParam()), p, h);
  const double e0 = total_energy(sys, k);
  double worst = 0, first = 0, last = 0;
  for (int block = 1; block <= 20; ++block) {
    sys.advance(500);
    const double e = total_energy(sys, k);
    worst = std::max(worst, std::fabs(e - e0) / e0);
    if (block == 2) first = e;
    if (block == 20) last = e;
  }
  EXPECT_LT(worst, 2e-3);
  EXPECT_LT(std::fabs(last - first) / e0, 1e-3);
  EXPECT_GT(sys.stats().rebuilds, 50);
  std::printf("[ energy ] 10000 steps: max |E-E0|/E0 = %.3e, rebuilds %ld, mean neighbours %.1f\n", worst,
              sys.stats().rebuilds, sys.stats().mean_neighbours);
}
INSTANTIATE_TEST_SUITE_P(All, DemEnergy, ::testing::ValuesIn(lbdem::test::backends()), lbdem::test::backend_name);

// Random packing: no overlaps (checked by the engine's own contact search,
// itself checked against brute force), the requested solid fraction to
// within one particle volume, radii in range, all inside closed axes.
TEST(DemInit, RandomPackingIsDenseAndNonOverlapping) {
  for (bool closed_y : {false, true}) {
    RandomPackingSpec s;
    s.lo = {0, 0, 0};
    s.hi = {20, 24, 20};
    s.periodic = {true, !closed_y, true};
    s.solid_fraction = 0.5;
    s.r_min = s.r_max = 0.5;
    if (closed_y) { s.r_min = 0.4; s.solid_fraction = 0.45; s.mc_sweeps = 3; }
    const HostParticles h = random_packing(s);
    EXPECT_TRUE(h.apart_by_construction);
    double vol = 0;
    for (Index i = 0; i < h.size(); ++i) {
      vol += 4.0 / 3.0 * M_PI * std::pow(h.r[i], 3);
      EXPECT_GE(h.r[i], s.r_min);
      EXPECT_LE(h.r[i], s.r_max);
      if (closed_y) {
        EXPECT_GE(h.x[i].y, h.r[i]);
        EXPECT_LE(h.x[i].y, 24 - h.r[i]);
      }
    }
    // Radii are drawn at random: allow 3 % for the polydisperse sample.
    EXPECT_NEAR(vol / (20 * 24 * 20), s.solid_fraction, closed_y ? 0.03 * s.solid_fraction : 1e-3);
    DemParams p;
    p.lo = s.lo;
    p.hi = s.hi;
    p.periodic = s.periodic;
    p.material = simple_material(1e3, 0.5);
    p.dt = min_collision_time(p, h) / 50;
    DemSystem sys(Exec(Backend::Host), p, h);
    EXPECT_EQ(sys.contact_pairs().size(), 0u);
  }
  RandomPackingSpec bad;
  bad.solid_fraction = 0.6;  // radii 0.3..0.6: the lattice must space for 0.6
  bad.r_min = 0.3;
  bad.r_max = 0.6;
  bad.hi = {10, 10, 10};
  EXPECT_THROW(random_packing(bad), ConfigError);
}

TEST(DemInit, LatticeAndCsv) {
  const HostParticles l = lattice_particles({0, 0, 0}, {3, 4, 5}, {1, 1, 1}, 0.4, 1000);
  ASSERT_EQ(l.size(), 60);
  EXPECT_DOUBLE_EQ(l.x[59].z, 4.0);
  EXPECT_NEAR(l.mass[0], 1000 * 4.0 / 3.0 * M_PI * 0.064, 1e-12);
  const auto path = std::filesystem::temp_directory_path() / "lbdem_dem_particles.csv";
  {
    std::ofstream o(path);
    o << "x, y, z, r, vx, density, id\n1,2,3,0.5,-1,2000,42\n4,5,6,0.25,0,1000,7\n";
  }
  const HostParticles c = read_particles_csv(path.string(), 2600);
  ASSERT_EQ(c.size(), 2);
  EXPECT_EQ(c.id[0], 42);
  EXPECT_DOUBLE_EQ(c.v[0].x, -1);
  EXPECT_NEAR(c.mass[1], 1000 * 4.0 / 3.0 * M_PI * std::pow(0.25, 3), 1e-12);
  {
    std::ofstream o(path);
    o << "x,y,z\n1,2,3\n";
  }
  EXPECT_THROW(read_particles_csv(path.string(), 2600), ConfigError);
  std::filesystem::remove(path);
}
