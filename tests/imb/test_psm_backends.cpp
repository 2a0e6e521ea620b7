// The PSM coupling across backends and particle orderings, and its slot
// overflow report:
//  - CPU against GPU: the same scene (fixed sphere; moving, rotating spheres
//    remapped every step, two of them sharing cells) gives the same forces,
//    torques, populations and velocities on Host and Cuda (fp64).
//  - A reordered particle array gives the same force on each particle.
//  - PsmCoupling::map with too few slots per cell throws ResourceError naming
//    the cell and the particles; nothing is silently dropped.
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

const imb::FractionTable& table3() {
  static const imb::FractionTable t = imb::build_fraction_table(3);
  return t;
}

// Three spheres in a 24^3 box: 0 and 1 0.13 cells apart (they share interface
// cells: two slots per cell; they move side by side, the gap stays < 0.5 cell
// over 300 steps), 2 alone; all translate and rotate.
std::vector<test::PsmSphere> three_spheres() {
  std::vector<test::PsmSphere> s(3);
  s[0] = {6.3, 7.1, 8.4, 4.0, 0.010, -0.004, 0.003, 0.0, 0.0, 2e-3};
  s[1] = {6.3 + 8.6, 7.6, 8.9, 4.5, 0.010, 0.002, -0.002, 1e-3, -2e-3, 0.0};
  s[2] = {12.2, 18.7, 17.9, 3.5, 0.0, 0.008, -0.012, -1.5e-3, 1e-3, 2.5e-3};
  return s;
}

// Advances every sphere by its velocity (positions only; rotation needs no
// state for a sphere).
std::vector<test::PsmSphere> moved(std::vector<test::PsmSphere> s, long step) {
  for (auto& p : s) {
    p.x += p.vx * double(step);
    p.y += p.vy * double(step);
    p.z += p.vz * double(step);
  }
  return s;
}

struct Snapshot {
  std::vector<double> forces;  // 6 per particle, last step
  std::vector<double> f;       // populations
  std::vector<double> u;       // velocity field
};

// `steps` PSM steps of the three-sphere scene (moving: remapped every step;
// else the spheres are held fixed with their velocities, the fluid driven by
// a body force), particles given in the order `order` (order[i] = which
// sphere of three_spheres() sits at index i).
Snapshot run_scene(Backend b, bool moving, long steps, const std::vector<int>& order,
                   imb::FractionMethod method = imb::FractionMethod::Exact,
                   imb::PsmPipeline pipeline = imb::PsmPipeline::Auto) {
  const auto base = three_spheres();
  auto in_order = [&](const std::vector<test::PsmSphere>& s) {
    std::vector<test::PsmSphere> o;
    for (int i : order) o.push_back(s[static_cast<std::size_t>(i)]);
    return o;
  };
  imb::PsmOptions opt;
  opt.map.method = method;
  opt.map.table = &table3();
  opt.pipeline = pipeline;
  const auto setup = test::psm_box(24, 24, 24, 0.6, 3.0 / 16.0, {2e-6, -1e-6, 5e-7});
  test::PsmScene scene(setup, b, 2, in_order(base), opt, {0.002, 0.001, -0.001});
  scene.map();
  for (long s = 0; s < steps; ++s) {
    if (moving && s > 0) {
      scene.set_particles(in_order(moved(base, s)));
      scene.map();
    }
    scene.step();
  }
  Snapshot r;
  r.forces = scene.forces();
  r.f = scene.solver().populations();
  std::vector<double> rho;
  scene.solver().macroscopic(rho, r.u);
  return r;
}

}  // namespace

// CPU against GPU, fp64, 300 steps from the same initial state (not to steady
// state: the comparison is of arithmetic, and every cell near the spheres has
// been through the solid term hundreds of times). The two backends run the
// same kernel body; they may differ by FMA contraction and by the order of
// the per-particle gather, i.e. by round-off: ~1e-16 per operation, grown by
// a few hundred steps of a stable linear update to ~1e-14. Bounds: forces and
// torques 1e-10 relative to the scene's largest (the force is a sum over
// ~1000 cells of small differences, so it loses a few digits to cancellation),
// populations and velocities 1e-12 relative to their largest value.
// Measured (H200 against its host, fp64, 300 steps): forces <= 2.5e-15,
// torques <= 1.1e-15, populations <= 1.3e-15, velocities <= 7.3e-16.
TEST(PsmCrossBackend, HostMatchesCuda) {
  if (!test::gpu_available()) GTEST_SKIP() << "no usable GPU: " << cuda_unavailable_reason();
  const std::vector<int> order{0, 1, 2};
  using M = imb::FractionMethod;
  using P = imb::PsmPipeline;
  const std::pair<M, P> runs[] = {{M::Exact, P::Mapped}, {M::Table, P::Mapped}, {M::Table, P::Fused}, {M::Linear, P::Fused}};
  for (bool moving : {false, true})
    for (const auto& [method, pipeline] : runs) {
      const auto h = run_scene(Backend::Host, moving, 300, order, method, pipeline);
      const auto d = run_scene(Backend::Cuda, moving, 300, order, method, pipeline);
      const auto ft = force_torque_diff(h.forces, d.forces, order);
      const double df = max_diff(h.f, d.f) / max_abs(h.f), du = max_diff(h.u, d.u) / max_abs(h.u);
      std::printf("%s, %s, %s: force %.1e, torque %.1e, populations %.1e, velocity %.1e (relative)\n",
                  moving ? "moving" : "fixed", imb::to_string(method), imb::to_string(pipeline), ft[0], ft[1], df, du);
      const std::string what = std::string(moving ? "moving " : "fixed ") + imb::to_string(method) + " " +
                               imb::to_string(pipeline);
      EXPECT_LT(ft[0], 1e-10) << what;
      EXPECT_LT(ft[1], 1e-10) << what;
      EXPECT_LT(df, 1e-12) << what;
      EXPECT_LT(du, 1e-12) << what;
    }
}

class PsmBackend : public ::testing::TestWithParam<Backend> {};

// Reordered particle array: the same spheres listed as (1, 2, 0) give each
// sphere the same force and torque, and the same flow. Slots are sorted by
// particle index, so in the cells that spheres 0 and 1 share, the solid terms
// are added in the other order: round-off only (measured: forces 9.8e-16,
// torques 5.8e-16, populations 1.7e-16 relative on the host; 4.3e-16,
// 6.9e-16, 1.7e-16 on an H200; bound 1e-12). A mix-up of indices (a force credited to the wrong
// particle, a slot read for the wrong particle) gives O(1) differences.
TEST_P(PsmBackend, ReorderedParticlesGiveSameForces) {
  const std::vector<int> a_order{0, 1, 2}, b_order{1, 2, 0};
  // Mapped pipeline (exact fractions) and fused pipeline (table): the fused
  // kernel ranks each tile's candidates by particle index, as the map sorts slots.
  for (auto [method, pipeline] : {std::pair{imb::FractionMethod::Exact, imb::PsmPipeline::Mapped},
                                  std::pair{imb::FractionMethod::Table, imb::PsmPipeline::Fused}}) {
    const auto a = run_scene(GetParam(), true, 60, a_order, method, pipeline);
    const auto b = run_scene(GetParam(), true, 60, b_order, method, pipeline);
    const auto ft = force_torque_diff(a.forces, b.forces, b_order);
    const double df = max_diff(a.f, b.f) / max_abs(a.f);
    std::printf("reordered (%s): force %.1e, torque %.1e, populations %.1e (relative)\n", imb::to_string(pipeline),
                ft[0], ft[1], df);
    EXPECT_LT(ft[0], 1e-12) << imb::to_string(pipeline);
    EXPECT_LT(ft[1], 1e-12) << imb::to_string(pipeline);
    EXPECT_LT(df, 1e-12) << imb::to_string(pipeline);
    // The scene is not trivial: spheres 0 and 1 share cells, and all feel a force.
    for (int i = 0; i < 3; ++i) EXPECT_GT(std::abs(a.forces[6 * i]) + std::abs(a.forces[6 * i + 1]), 0.0);
  }
}

// PsmCoupling::map with K too small. Spheres 0 and 1 (0.13 cells apart) share
// interface cells; with one slot per cell the coupling must refuse (check on)
// with a ResourceError naming the first such cell and both particles, and with
// the check off the overflow must still be on record: every (cell, particle)
// pair that found no slot is counted, none is silently lost.
TEST_P(PsmBackend, MapOverflowNamesCellAndParticles) {
  const auto s = three_spheres();
  imb::PsmOptions opt;
  const auto setup = test::psm_box(24, 24, 24, 0.6, 3.0 / 16.0);
  // Ground truth from a mapping with room for everyone (K = 3).
  test::PsmScene roomy(setup, GetParam(), 3, s, opt);
  roomy.map(true);
  const auto counts = roomy.coupling().slots().counts_host();
  long shared = 0;
  long first = -1;
  for (std::size_t c = 0; c < counts.size(); ++c) {
    EXPECT_LE(counts[c], 2);
    if (counts[c] == 2) {
      ++shared;
      if (first < 0) first = static_cast<long>(c);
    }
  }
  ASSERT_GT(shared, 0) << "the scene must have cells shared by two spheres";
  const long i = first % 24, j = (first / 24) % 24, k = first / (24 * 24);

  test::PsmScene tight(setup, GetParam(), 1, s, opt);
  try {
    tight.map(true);
    FAIL() << "map with K = 1 did not throw";
  } catch (const ResourceError& e) {
    const std::string msg = e.what();
    const std::string cell = "(" + std::to_string(i) + ", " + std::to_string(j) + ", " + std::to_string(k) + ")";
    EXPECT_NE(msg.find(cell), std::string::npos) << msg << "\nexpected cell " << cell;
    EXPECT_NE(msg.find("(0, 1)"), std::string::npos) << msg;  // the particles involved
    EXPECT_NE(msg.find("K = 1"), std::string::npos) << msg;
  }
  // Check off: no throw, but the report has every surplus pair and the counts
  // still say how many particles wanted each cell.
  test::PsmScene quiet(setup, GetParam(), 1, s, opt);
  EXPECT_NO_THROW(quiet.map(false));
  const auto rep = quiet.coupling().slots().overflow();
  EXPECT_TRUE(rep.overflow);
  EXPECT_EQ(rep.events, shared);
  EXPECT_EQ(rep.cell, first);
  EXPECT_EQ(rep.particles, (std::vector<int>{0, 1}));
  EXPECT_EQ(quiet.coupling().slots().counts_host(), counts);
}

INSTANTIATE_TEST_SUITE_P(Backends, PsmBackend, ::testing::ValuesIn(lbdem::test::backends()),
                         lbdem::test::backend_name);
