// The fused PSM pipeline (imb/psm_fused.hpp, imb/tile_map.hpp) against the
// mapped one (slot map + PSM kernel + gather), which the drag, Galilean and
// cross-backend tests validate:
//  - moving, rotating spheres (two sharing cells, one crossing periodic faces)
//    on a grid whose sides are not multiples of the tile: the same flow and the
//    same forces and torques, in 3D and 2D, with table and linear fractions;
//  - a cell overlapped by more than K particles is reported (cell, particles);
//    a tile touched by more particles than its list holds is refused at map;
//  - the pipeline choice refuses what the fused kernel cannot do, naming the key.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "../common/backends.hpp"
#include "core/error.hpp"
#include "imb/fraction_table.hpp"
#include "psm_scene.hpp"

using namespace lbdem;
using lbdem::test::force_torque_diff;
using lbdem::test::max_abs;
using lbdem::test::max_diff;

namespace {

const imb::FractionTable& table(int dim) {
  static const imb::FractionTable t3 = imb::build_fraction_table(3);
  static const imb::FractionTable t2 = imb::build_fraction_table(2);
  return dim == 3 ? t3 : t2;
}

// 26 x 22 x 19 cells (no side a multiple of the 32 x 4 x 2 tile): spheres 0
// and 1 share interface cells; 2 sits across the x = 0 and z = 0 faces.
std::vector<test::PsmSphere> spheres3() {
  std::vector<test::PsmSphere> s(3);
  s[0] = {7.3, 7.1, 8.4, 4.0, 0.010, -0.004, 0.003, 0.0, 0.0, 2e-3};
  s[1] = {7.3 + 8.6, 7.6, 8.9, 4.5, 0.010, 0.002, -0.002, 1e-3, -2e-3, 0.0};
  s[2] = {0.7, 15.2, 18.1, 3.5, -0.006, 0.008, 0.012, -1.5e-3, 1e-3, 2.5e-3};
  return s;
}
// 2D: 45 x 37 cells, disks 0 and 1 share cells, 2 crosses the y faces.
std::vector<test::PsmSphere> disks2() {
  std::vector<test::PsmSphere> s(3);
  s[0] = {10.3, 12.1, 0.5, 5.0, 0.010, -0.004, 0, 0, 0, 2e-3};
  s[1] = {10.3 + 10.6, 12.6, 0.5, 5.5, 0.010, 0.002, 0, 0, 0, -1e-3};
  s[2] = {30.2, 36.4, 0.5, 4.5, -0.006, 0.008, 0, 0, 0, 2.5e-3};
  return s;
}

struct Run {
  std::vector<double> forces, f, u;
};

Run run(Backend b, int dim, imb::FractionMethod method, imb::PsmPipeline pipeline, long steps, int K = 2) {
  const auto base = dim == 3 ? spheres3() : disks2();
  imb::PsmOptions opt;
  opt.map.method = method;
  opt.map.table = &table(dim);
  opt.pipeline = pipeline;
  const auto setup = dim == 3 ? test::psm_box(26, 22, 19, 0.6, 1e-3, {2e-6, -1e-6, 5e-7})
                              : test::psm_box(45, 37, 1, 0.6, 1e-3, {2e-6, -1e-6, 0});
  test::PsmScene scene(setup, b, K, base, opt, {0.002, 0.001, dim == 3 ? -0.001 : 0.0});
  scene.map();
  for (long s = 0; s < steps; ++s) {
    if (s > 0) {
      auto moved = base;
      for (auto& p : moved) {
        p.x += p.vx * double(s);
        p.y += p.vy * double(s);
        p.z += dim == 3 ? p.vz * double(s) : 0.0;
      }
      scene.set_particles(moved);
      scene.map();
    }
    scene.step();
  }
  EXPECT_EQ(scene.coupling().pipeline(), pipeline);
  Run r;
  r.forces = scene.forces();
  r.f = scene.solver().populations();
  std::vector<double> rho;
  scene.solver().macroscopic(rho, r.u);
  return r;
}

class PsmFused : public ::testing::TestWithParam<Backend> {};

// Fused against mapped, fp64, 120 steps of moving, rotating particles. The two
// pipelines evaluate the same fraction functions on the same cells and run the
// same collision (psm_collide); they differ in (a) the solid velocity, which
// the map stores as float and the fused kernel keeps in double (relative
// 2^-24 = 6e-8: the velocity inside the spheres, where u follows V, differs by
// that much), (b) the minimum-image offset (x + 0.5 - c - n against
// (x - n) + 0.5 - c: 1e-16), (c) the order of the force sums. The force is a
// sum of B (V - u) over ~1000 cells, and the slip V - u is 10-100 times smaller
// than V, so (a) reaches it as ~1e-6. Measured (host): populations <= 1e-9,
// velocities <= 6.3e-8, forces <= 9e-7, torques <= 3e-7. Bounds: populations
// 1e-8, velocities 2e-7, forces and torques 1e-5, relative to the largest. A
// wrong candidate list, a missed periodic image or tile, a force credited to
// the wrong particle or a slot dropped gives O(1e-2..1) differences.
TEST_P(PsmFused, MatchesMappedPipeline) {
  for (int dim : {3, 2})
    for (auto method : {imb::FractionMethod::Table, imb::FractionMethod::Linear}) {
      const auto m = run(GetParam(), dim, method, imb::PsmPipeline::Mapped, 120);
      const auto f = run(GetParam(), dim, method, imb::PsmPipeline::Fused, 120);
      const auto ft = force_torque_diff(m.forces, f.forces, {0, 1, 2});
      const double df = max_diff(m.f, f.f) / max_abs(m.f), du = max_diff(m.u, f.u) / max_abs(m.u);
      std::printf("%dD %s: fused vs mapped: force %.1e, torque %.1e, populations %.1e, velocity %.1e (relative)\n",
                  dim, imb::to_string(method), ft[0], ft[1], df, du);
      const std::string what = std::to_string(dim) + "D " + imb::to_string(method);
      EXPECT_LT(ft[0], 1e-5) << what;
      EXPECT_LT(ft[1], 1e-5) << what;
      EXPECT_LT(df, 1e-8) << what;
      EXPECT_LT(du, 2e-7) << what;
      // Not trivial: every particle feels a force and a torque.
      for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_GT(std::abs(f.forces[6 * i]) + std::abs(f.forces[6 * i + 1]), 1e-6) << what << " particle " << i;
        EXPECT_GT(std::abs(f.forces[6 * i + 5]), 0.0) << what << " particle " << i;
      }
    }
}

// K = 1 where spheres 0 and 1 share cells: the fused kernel finds the surplus
// overlaps during the step and the report names the first such cell (the same
// one the mapped pipeline names) and the surplus particle; a map with the check
// on does not throw (the slots are filled in the step), the step's report does.
TEST_P(PsmFused, CellSlotOverflowIsReported) {
  const auto s = spheres3();
  imb::PsmOptions opt;
  opt.map.method = imb::FractionMethod::Table;
  opt.map.table = &table(3);
  const auto setup = test::psm_box(26, 22, 19, 0.6, 1e-3);
  opt.pipeline = imb::PsmPipeline::Mapped;
  test::PsmScene mapped(setup, GetParam(), 1, s, opt);
  mapped.map(false);
  const auto want = mapped.coupling().overflow();
  ASSERT_TRUE(want.overflow);
  opt.pipeline = imb::PsmPipeline::Fused;
  test::PsmScene fused(setup, GetParam(), 1, s, opt);
  EXPECT_NO_THROW(fused.map(true));
  fused.step();
  const auto rep = fused.coupling().overflow();
  EXPECT_TRUE(rep.overflow);
  EXPECT_EQ(rep.events, want.events);  // every surplus (cell, particle) pair, none lost
  EXPECT_EQ(rep.cell, want.cell);
  EXPECT_EQ(rep.particles, std::vector<int>{1});  // the slot goes to the lower index, 0
  EXPECT_NE(rep.message.find("K = 1"), std::string::npos) << rep.message;
  EXPECT_NE(rep.message.find("(" + std::to_string(rep.ijk[0]) + ", "), std::string::npos) << rep.message;
  fused.coupling().clear_overflow();
  EXPECT_FALSE(fused.coupling().overflow().overflow);
}

// A tile list too short for the particles touching it: refused at map, naming
// the key; nothing is silently dropped.
TEST_P(PsmFused, TileCapacityOverflowIsRefused) {
  const auto s = spheres3();
  imb::PsmOptions opt;
  opt.map.method = imb::FractionMethod::Linear;
  opt.pipeline = imb::PsmPipeline::Fused;
  opt.tile_capacity = 1;
  test::PsmScene scene(test::psm_box(26, 22, 19, 0.6, 1e-3), GetParam(), 2, s, opt);
  try {
    scene.map(true);
    FAIL() << "a tile list of capacity 1 for two spheres did not throw";
  } catch (const ResourceError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("psm.tile_capacity = 1"), std::string::npos) << msg;
  }
}

// Twelve small spheres in one row of tiles: a tile with many candidates (the
// rank order, the slot choice and the force sums over a long list). Fused
// against mapped as above (same bounds and reasons).
TEST_P(PsmFused, CrowdedTileMatchesMapped) {
  std::vector<test::PsmSphere> s;
  for (int i = 0; i < 12; ++i)
    s.push_back({2.0 + 2.6 * i, 2.1 + 0.1 * (i % 3), 1.3, 1.2, 0.004, -0.002 * (i % 2), 0.001, 0, 0, 1e-3});
  auto go = [&](imb::PsmPipeline pl) {
    imb::PsmOptions opt;
    opt.map.method = imb::FractionMethod::Table;
    opt.map.table = &table(3);
    opt.pipeline = pl;
    test::PsmScene scene(test::psm_box(40, 12, 10, 0.6, 1e-3, {1e-6, 0, 0}), GetParam(), 2, s, opt);
    for (int step = 0; step < 20; ++step) {
      auto m = s;
      for (auto& p : m) p.x += p.vx * step;
      scene.set_particles(m);
      scene.map();
      scene.step();
    }
    return std::pair{scene.forces(), scene.solver().populations()};
  };
  const auto [fm, pm] = go(imb::PsmPipeline::Mapped);
  const auto [ff, pf] = go(imb::PsmPipeline::Fused);
  const auto ft = force_torque_diff(fm, ff, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11});
  const double df = max_diff(pm, pf) / max_abs(pm);
  std::printf("crowded tile: force %.1e, torque %.1e, populations %.1e (relative)\n", ft[0], ft[1], df);
  EXPECT_LT(ft[0], 1e-5);
  EXPECT_LT(ft[1], 1e-5);
  EXPECT_LT(df, 1e-8);
  for (std::size_t i = 0; i < 12; ++i) EXPECT_GT(std::abs(ff[6 * i]), 0.0) << "particle " << i;
}

INSTANTIATE_TEST_SUITE_P(Backends, PsmFused, ::testing::ValuesIn(lbdem::test::backends()), lbdem::test::backend_name);

TEST(PsmPipeline, ResolvesAndRefuses) {
  imb::PsmOptions o;
  o.map.method = imb::FractionMethod::Table;
  EXPECT_EQ(imb::resolve_pipeline(o, 4), imb::PsmPipeline::Fused);
  EXPECT_EQ(imb::resolve_pipeline(o, 5), imb::PsmPipeline::Mapped);  // K above the fused kernel's slots
  o.map.method = imb::FractionMethod::Exact;
  EXPECT_EQ(imb::resolve_pipeline(o, 4), imb::PsmPipeline::Mapped);
  o.pipeline = imb::PsmPipeline::Fused;
  try {
    (void)imb::resolve_pipeline(o, 4);
    FAIL() << "fused with exact fractions did not throw";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("psm.fraction = exact"), std::string::npos) << e.what();
  }
  o.map.method = imb::FractionMethod::Linear;
  o.map.table_in_constant = true;
  EXPECT_THROW((void)imb::resolve_pipeline(o, 4), ConfigError);
  o.pipeline = imb::PsmPipeline::Auto;
  EXPECT_EQ(imb::resolve_pipeline(o, 4), imb::PsmPipeline::Mapped);
}

}  // namespace
