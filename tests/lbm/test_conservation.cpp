// Mass and momentum bookkeeping in a periodic box, streaming-scheme
// equivalence on every kind of boundary, and CPU/GPU agreement.
#include <gtest/gtest.h>

#include "../common/backends.hpp"
#include "lbm_test_util.hpp"

using namespace lbdem;
using namespace lbdem::lbm;

namespace {

class Conservation : public ::testing::TestWithParam<Backend> {};

void check_periodic_box(LatticeKind lk, long nx, long ny, long nz, Backend b, CollisionKind ck) {
  auto s = test::make_scene(lk, nx, ny, nz);
  s.setup.collision = ck;
  s.setup.tau = 0.7;
  const std::array<double, 3> F{2e-6, -1e-6, lk == LatticeKind::D3Q19 ? 5e-7 : 0.0};
  s.setup.body_force = F;
  test::randomize(s, 1e-3, 1e-3, 42);
  auto solver = test::start(s, b);
  const auto d0 = solver->diagnostics();
  const long steps = 10000;
  solver->step(steps);
  const auto d1 = solver->diagnostics();
  // Mass: the collision conserves it per cell; only round-off remains
  // (~1e-16 per cell-step, random-walk accumulated), far below 1e-13.
  EXPECT_LT(std::abs(d1.mass - d0.mass) / d0.mass, 1e-13);
  // Momentum grows by exactly F per cell per step (Guo forcing, see
  // collision.hpp): relative 1e-12 of the added momentum.
  const double cells = static_cast<double>(nx * ny * nz);
  for (int a = 0; a < 3; ++a) {
    const double added = F[static_cast<std::size_t>(a)] * cells * steps;
    const double got = d1.momentum[static_cast<std::size_t>(a)] - d0.momentum[static_cast<std::size_t>(a)];
    if (added != 0) EXPECT_NEAR(got, added, 1e-12 * std::abs(added)) << "axis " << a;
    else EXPECT_NEAR(got, 0.0, 1e-14);
  }
  EXPECT_TRUE(d1.finite);
}

TEST_P(Conservation, PeriodicBoxD2Q9) { check_periodic_box(LatticeKind::D2Q9, 16, 12, 1, GetParam(), CollisionKind::BGK); }
TEST_P(Conservation, PeriodicBoxD3Q19) { check_periodic_box(LatticeKind::D3Q19, 6, 5, 4, GetParam(), CollisionKind::TRT); }

// Builds each boundary scene used by the equivalence tests.
test::Scene scene_of(const std::string& name, LatticeKind lk) {
  const long nz = lk == LatticeKind::D3Q19 ? 5 : 1;
  if (name == "channel") {
    auto s = test::make_scene(lk, 7, 10, nz);
    s.setup.body_force = {1e-5, 0, 0};
    const int w = test::add_boundary(s, BoundaryKind::Wall);
    test::add_y_walls(s, w, w);
    test::randomize(s, 1e-3, 1e-3, 7);
    return s;
  }
  if (name == "cavity") {  // moving lid on top, walls elsewhere (z periodic in 3D)
    auto s = test::make_scene(lk, 9, 9, nz);
    const int w = test::add_boundary(s, BoundaryKind::Wall);
    const int lid = test::add_boundary(s, BoundaryKind::Velocity, {0.05, 0, 0});
    const auto& d = s.setup.domain.local;
    for (long z = 0; z < d[2]; ++z)
      for (long y = 0; y < d[1]; ++y)
        for (long x = 0; x < d[0]; ++x)
          if (x == 0 || x == d[0] - 1 || y == 0) s.flags[test::cell_index(s, x, y, z)] = static_cast<std::uint8_t>(w);
          else if (y == d[1] - 1) s.flags[test::cell_index(s, x, y, z)] = static_cast<std::uint8_t>(lid);
    return s;
  }
  if (name == "inlet_outlet") {  // velocity inlet at x=0, pressure outlet at x=nx-1, walls at y
    auto s = test::make_scene(lk, 12, 8, nz);
    const int w = test::add_boundary(s, BoundaryKind::Wall);
    const int in = test::add_boundary(s, BoundaryKind::Velocity, {0.02, 0, 0});
    const int out = test::add_boundary(s, BoundaryKind::Pressure, {0, 0, 0}, 1.0);
    test::add_y_walls(s, w, w);
    const auto& d = s.setup.domain.local;
    for (long z = 0; z < d[2]; ++z)
      for (long y = 1; y < d[1] - 1; ++y) {
        s.flags[test::cell_index(s, 0, y, z)] = static_cast<std::uint8_t>(in);
        s.flags[test::cell_index(s, d[0] - 1, y, z)] = static_cast<std::uint8_t>(out);
      }
    return s;
  }
  auto s = test::make_scene(lk, 8, 7, nz);  // periodic
  test::randomize(s, 1e-3, 1e-2, 3);
  return s;
}

class StreamingEquivalence : public ::testing::TestWithParam<std::tuple<Backend, std::string>> {};

TEST_P(StreamingEquivalence, InPlaceEqualsTwoLattice) {
  const auto [b, name] = GetParam();
  for (LatticeKind lk : {LatticeKind::D2Q9, LatticeKind::D3Q19}) {
    for (CollisionKind ck : {CollisionKind::BGK, CollisionKind::TRT}) {
      auto s = scene_of(name, lk);
      s.setup.collision = ck;
      s.setup.tau = 0.66;
      s.setup.streaming = StreamKind::AA;
      auto aa = test::start(s, b);
      s.setup.streaming = StreamKind::TwoLattice;
      auto tl = test::start(s, b);
      for (long steps : {1L, 2L, 37L, 60L}) {  // odd and even step counts
        aa->step(steps);
        tl->step(steps);
        auto pa = aa->populations(), pt = tl->populations();
        // Boundary cells hold no populations of their own: compare fluid cells.
        const std::size_t n = s.flags.size();
        for (std::size_t q = 0; q < pa.size() / n; ++q)
          for (std::size_t i = 0; i < n; ++i)
            if (s.flags[i]) pa[q * n + i] = pt[q * n + i] = 0;
        std::vector<double> ra, ua, rt, ut;
        aa->macroscopic(ra, ua);
        tl->macroscopic(rt, ut);
        // Identical arithmetic except where a moving wall adds its term at a
        // different point of the store (fp64 round-off, ~1e-17 per step).
        EXPECT_LT(test::max_abs_diff(pa, pt), 1e-14) << name << " " << to_string(lk) << " after " << aa->steps_done();
        EXPECT_LT(test::max_abs_diff(ua, ut), 1e-14);
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, StreamingEquivalence,
                         ::testing::Combine(::testing::ValuesIn(test::backends()),
                                            ::testing::Values("periodic", "channel", "cavity", "inlet_outlet")),
                         [](const auto& info) {
                           return std::string(to_string(std::get<0>(info.param))) + "_" + std::get<1>(info.param);
                         });

TEST(CpuGpu, AgreeOnEveryScene) {
  if (!test::gpu_available()) GTEST_SKIP() << "no GPU: " << cuda_unavailable_reason();
  for (const std::string name : {"periodic", "channel", "cavity", "inlet_outlet"})
    for (LatticeKind lk : {LatticeKind::D2Q9, LatticeKind::D3Q19})
      for (StreamKind sk : {StreamKind::AA, StreamKind::TwoLattice}) {
        auto s = scene_of(name, lk);
        s.setup.collision = CollisionKind::TRT;
        s.setup.streaming = sk;
        auto cpu = test::start(s, Backend::Host);
        auto gpu = test::start(s, Backend::Cuda);
        cpu->step(101);
        gpu->step(101);
        // Same arithmetic; the GPU may contract a*b+c into FMA, so allow
        // round-off growth over 101 steps: 1e-12 absolute on populations ~0.1.
        auto pc = cpu->populations(), pg = gpu->populations();
        const std::size_t n = s.flags.size();
        for (std::size_t q = 0; q < pc.size() / n; ++q)
          for (std::size_t i = 0; i < n; ++i)
            if (s.flags[i]) pc[q * n + i] = pg[q * n + i] = 0;
        EXPECT_LT(test::max_abs_diff(pc, pg), 1e-12) << name << to_string(lk);
      }
}

INSTANTIATE_TEST_SUITE_P(Backends, Conservation, ::testing::ValuesIn(test::backends()), test::backend_name);

}  // namespace
