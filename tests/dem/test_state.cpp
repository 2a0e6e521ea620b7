// DemSystem::save_state / load_state through a checkpoint file
// (core/checkpoint.hpp): a frictional granular gas between two walls, with
// gravity, in calls of 10 steps like the coupled solver's sub-steps. N steps
// straight equal N/2 + save + a fresh system loaded + N/2, bit for bit
// (positions, velocities, angular velocities, forces, tangential histories
// through the contact forces, rebuild counts and decisions), with
// neighbour-list rebuilds on both sides; a mismatching system is refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <random>
#include <string>

#include "core/checkpoint.hpp"
#include "core/error.hpp"
#include "dem/init.hpp"
#include "dem_test_util.hpp"

namespace lbdem::dem::test {
namespace {

namespace fs = std::filesystem;

struct Gas {
  DemParams p;
  HostParticles h;
};

Gas make_gas(ForcePath path, ContactOrder order) {
  RandomPackingSpec spec;
  spec.hi = {8, 8, 8};
  spec.periodic = {true, false, true};
  spec.solid_fraction = 0.2;
  spec.r_min = 0.3;
  spec.r_max = 0.5;
  spec.seed = 7;
  Gas g;
  g.h = random_packing(spec);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> N(0, 1);
  for (auto& v : g.h.v) v = Vec3d{N(rng), N(rng), N(rng)} * 0.05;
  g.p.lo = spec.lo;
  g.p.hi = spec.hi;
  g.p.periodic = spec.periodic;
  g.p.walls = {Wall{{0, 0, 0}, {0, 1, 0}}, Wall{{0, 8, 0}, {0, -1, 0}}};
  g.p.material = simple_material(2e4, 0.7, 0.4);
  g.p.friction = true;
  g.p.gravity = {0, -0.5, 0};
  g.p.path = path;
  g.p.contact_order = order;
  g.p.dt = min_collision_time(g.p, g.h) / 50;
  return g;
}

void run(DemSystem& s, long steps) {
  for (long k = 0; k < steps; k += 10) s.advance(std::min(10L, steps - k));
}

// Particles sorted by id, every per-particle value bit for bit.
void expect_same(const DemSystem& a, const DemSystem& b) {
  const HostParticles x = a.gather(), y = b.gather();
  ASSERT_EQ(x.size(), y.size());
  ASSERT_GT(x.size(), 0);
  EXPECT_EQ(x.id, y.id);
  auto same = [](const std::vector<Vec3d>& u, const std::vector<Vec3d>& v) {
    return u.size() == v.size() && std::memcmp(u.data(), v.data(), u.size() * sizeof(Vec3d)) == 0;
  };
  EXPECT_TRUE(same(x.x, y.x)) << "positions";
  EXPECT_TRUE(same(x.v, y.v)) << "velocities";
  EXPECT_TRUE(same(x.w, y.w)) << "angular velocities";
  EXPECT_TRUE(same(x.f, y.f)) << "forces";
  EXPECT_EQ(a.time(), b.time());
  EXPECT_EQ(a.stats().steps, b.stats().steps);
  EXPECT_EQ(a.stats().rebuilds, b.stats().rebuilds);
  EXPECT_EQ(a.contact_pairs(), b.contact_pairs());
}

struct StateCase {
  Backend backend;
  ForcePath path;
};

class DemState : public ::testing::TestWithParam<StateCase> {
 protected:
  std::string file(const std::string& tag) {
    return (fs::temp_directory_path() / ("lbdem_dem_state_" + std::to_string(::getpid()) + "_" + tag)).string();
  }
};

TEST_P(DemState, StraightEqualsSaveLoadContinueBitwise) {
  const StateCase sc = GetParam();
  // The pair path sums contact forces with atomics: on the GPU two straight
  // runs already differ in the last bits (ForcePath::Pair), so a restart can
  // be bitwise only on the particle path there (and on either path on the host).
  if (sc.backend == Backend::Cuda && sc.path == ForcePath::Pair)
    GTEST_SKIP() << "pair path on the GPU: atomic sums, not bitwise reproducible run to run";
  const Gas g = make_gas(sc.path, ContactOrder::Storage);
  const long N = 600, half = 300;
  DemSystem straight(Exec(sc.backend), g.p, g.h);
  run(straight, N);

  DemSystem first(Exec(sc.backend), g.p, g.h);
  run(first, half);
  const long rebuilds_half = first.stats().rebuilds;
  const std::string path = file(std::string(to_string(sc.backend)) + to_string(sc.path));
  {
    ckpt::Writer w(path, ckpt::Identity{}.add("test", "dem"), half, first.time());
    w.section("dem");
    first.save_state(w);
    w.commit();
  }
  DemSystem second(Exec(sc.backend), g.p, g.h);  // a fresh system, as a restarted process builds it
  {
    ckpt::Reader r(path);
    r.check_identity(ckpt::Identity{}.add("test", "dem"));
    r.section("dem");
    second.load_state(r);
    r.finish();
  }
  fs::remove(path);
  expect_same(first, second);
  run(second, N - half);
  expect_same(straight, second);
  EXPECT_GT(rebuilds_half, 1) << "no rebuild before the save";
  EXPECT_GT(straight.stats().rebuilds, rebuilds_half + 1) << "no rebuild after the save";
  EXPECT_GT(straight.contact_pairs().size(), 0u) << "no contacts: the tangential histories are not exercised";
}

TEST_P(DemState, OtherParticleSetOrLayoutIsRefused) {
  const StateCase sc = GetParam();
  const Gas g = make_gas(sc.path, ContactOrder::Storage);
  DemSystem a(Exec(sc.backend), g.p, g.h);
  run(a, 20);
  const std::string path = file("refuse");
  {
    ckpt::Writer w(path, {}, 20, a.time());
    a.save_state(w);
    w.commit();
  }
  HostParticles fewer = g.h;
  fewer.x.pop_back(); fewer.v.pop_back(); fewer.w.pop_back(); fewer.r.pop_back(); fewer.mass.pop_back();
  fewer.id.pop_back();
  if (!fewer.type.empty()) fewer.type.pop_back();
  if (!fewer.f.empty()) fewer.f.pop_back();
  if (!fewer.t.empty()) fewer.t.pop_back();
  DemSystem b(Exec(sc.backend), g.p, fewer);
  {
    ckpt::Reader r(path);
    EXPECT_THROW(b.load_state(r), ConfigError);
  }
  DemParams nofric = g.p;
  nofric.friction = false;
  nofric.material.friction = nofric.material.wall_friction = 0;
  DemSystem c(Exec(sc.backend), nofric, g.h);
  {
    ckpt::Reader r(path);
    try {
      c.load_state(r);
      ADD_FAILURE() << "a frictional state loaded into a frictionless system";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("friction"), std::string::npos) << e.what();
    }
  }
  fs::remove(path);
}

std::vector<StateCase> state_cases() {
  std::vector<StateCase> v;
  for (Backend b : lbdem::test::backends())
    for (ForcePath p : {ForcePath::Particle, ForcePath::Pair}) v.push_back({b, p});
  return v;
}

INSTANTIATE_TEST_SUITE_P(All, DemState, ::testing::ValuesIn(state_cases()), [](const auto& info) {
  return std::string(to_string(info.param.backend)) + "_" + to_string(info.param.path);
});

}  // namespace
}  // namespace lbdem::dem::test
