// The wall gap correction in the coupled step (psm.wall_lubrication,
// imb/wall_lubrication.hpp; issue 29): the kernel adds the bench's calibrated
// force (wall_lubrication_force) along each wall normal where the gap is
// below the fit's largest gap, nothing outside the fit, and the coupled step
// adds exactly that to each particle's hydrodynamic force (nothing else of
// the step changes). The drag it gives against Brenner is tested through the
// wall benchmark (WallCases.GapCorrectionDl6, long).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "../common/backends.hpp"
#include "core/buffer.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "imb/drag_error.hpp"
#include "imb/wall_lubrication.hpp"
#include "lbm/solver.hpp"

using namespace lbdem;

namespace {

// A box periodic along x and y, closed along z (30 cells with the two wall layers).
Grid z_closed_grid() { return Grid::whole({16, 16, 30}, {true, true, false}); }

imb::WallLubricationSetting rule_setting(bool on, double tau = 0.8, double d = 6) {
  imb::LubricationWall walls[imb::kMaxLubricationWalls];
  const int nw = imb::closed_box_walls(z_closed_grid(), 3, walls);
  return imb::resolve_wall_lubrication(on, 3, tau, true, imb::psm_magic_auto(d, tau),
                                       imb::PsmWeight::NobleTorczynskiWall, imb::PsmVariant::NEBB,
                                       imb::FractionMethod::Exact, 1.0, walls, nw);
}

// The walls of a closed axis are its bounce-back planes, 1 and n - 1, normals into the fluid.
TEST(WallLubrication, WallsOfTheClosedAxes) {
  imb::LubricationWall w[imb::kMaxLubricationWalls];
  ASSERT_EQ(imb::closed_box_walls(z_closed_grid(), 3, w), 2);
  EXPECT_EQ(w[0].point[2], 1.0);
  EXPECT_EQ(w[0].normal[2], 1.0);
  EXPECT_EQ(w[1].point[2], 29.0);
  EXPECT_EQ(w[1].normal[2], -1.0);
  EXPECT_EQ(w[0].normal[0] + w[0].normal[1] + w[1].normal[0] + w[1].normal[1], 0.0);
  EXPECT_EQ(imb::closed_box_walls(Grid::whole({8, 8, 8}, {false, false, false}), 3, w), 6);
  EXPECT_EQ(imb::closed_box_walls(Grid::whole({8, 8, 8}, {true, true, true}), 3, w), 0);
}

// Applied inside the fit only; everywhere else nothing, with the reason.
TEST(WallLubrication, AppliedInsideTheFitOnly) {
  const auto on = rule_setting(true);
  EXPECT_TRUE(on.applied) << on.note;
  EXPECT_EQ(on.k.count, 2);
  EXPECT_EQ(on.k.c, imb::WallLubrication{}.c);
  EXPECT_EQ(on.k.p, imb::WallLubrication{}.p);
  EXPECT_NEAR(on.k.mu, 0.1, 1e-15);  // rho_f (tau - 1/2) / 3 at tau 0.8
  EXPECT_FALSE(rule_setting(false).applied);
  EXPECT_FALSE(rule_setting(false).requested);
  // d/l 10 at tau 0.8 (Lambda 0.17) and d/l 6 at tau 1.0 (0.062): inside.
  EXPECT_TRUE(rule_setting(true, 0.8, 10).applied);
  EXPECT_TRUE(rule_setting(true, 1.0, 6).applied);
  // tau 0.6 (Lambda 0.010 at d/l 6), d/l 4 at tau 0.8 (0.011): outside, said.
  for (const auto& s : {rule_setting(true, 0.6, 6), rule_setting(true, 0.8, 4)}) {
    EXPECT_TRUE(s.requested);
    EXPECT_FALSE(s.applied);
    EXPECT_NE(s.note.find("NOT applied: Lambda"), std::string::npos) << s.note;
  }
  imb::LubricationWall w[imb::kMaxLubricationWalls];
  const int nw = imb::closed_box_walls(z_closed_grid(), 3, w);
  const double m = imb::psm_magic_auto(6, 0.8);
  using imb::FractionMethod;
  using imb::PsmVariant;
  using imb::PsmWeight;
  auto why = [&](int dim, bool trt, PsmWeight we, PsmVariant va, FractionMethod fm, int n) {
    const auto s = imb::resolve_wall_lubrication(true, dim, 0.8, trt, m, we, va, fm, 1.0, w, n);
    EXPECT_FALSE(s.applied);
    return s.note;
  };
  const auto W = PsmWeight::NobleTorczynskiWall;
  const auto V = PsmVariant::NEBB;
  const auto E = FractionMethod::Exact;
  EXPECT_NE(why(2, true, W, V, E, nw).find("2D"), std::string::npos);
  EXPECT_NE(why(3, false, W, V, E, nw).find("bgk"), std::string::npos);
  EXPECT_NE(why(3, true, PsmWeight::NobleTorczynski, V, E, nw).find("psm.weight"), std::string::npos);
  EXPECT_NE(why(3, true, W, PsmVariant::Superposition, E, nw).find("superposition"), std::string::npos);
  EXPECT_NE(why(3, true, W, V, FractionMethod::Table, nw).find("psm.fraction"), std::string::npos);
  EXPECT_NE(why(3, true, W, V, E, 0).find("no wall"), std::string::npos);
}

// The kernel against the bench's form (wall_lubrication_force) on both
// backends: spheres near the lower wall approaching and receding, near the
// upper wall, beyond the largest fitted gap, in contact, and at rest.
class WallLubricationKernel : public ::testing::TestWithParam<Backend> {};

TEST_P(WallLubricationKernel, MatchesTheBenchForm) {
  const Backend b = GetParam();
  const auto s = rule_setting(true);
  ASSERT_TRUE(s.applied);
  const double a = 3, m = s.magic, mu = s.k.mu;
  struct P {
    double x, y, z, vx, vy, vz;
  };
  // gap = z - 1 - a (lower wall) or 29 - z - a (upper wall)
  const std::vector<P> ps = {
      {8, 8, 1 + a + 1.0, 2e-4, -1e-4, -1e-3},   // gap 1, approaching the lower wall
      {8, 8, 1 + a + 1.5, 0, 0, 1e-3},           // gap 1.5, receding: pulled back
      {8, 8, 29 - a - 2.0, 0, 0, 1e-3},          // gap 2 to the upper wall, approaching it
      {8, 8, 1 + a + 7.5, 0, 0, -1e-3},          // gap 7.5 (< 8)
      {8, 8, 1 + a + 8.5, 0, 0, -1e-3},          // gap 8.5: beyond the fit, nothing
      {8, 8, 1 + a + 0.2, 0, 0, -1e-3},          // gap 0.2: held at g_min
      {8, 8, 1 + a - 0.1, 0, 0, -1e-3},          // in contact: held at g_min too
      {8, 8, 1 + a + 1.0, 0, 0, 0},              // at rest
  };
  const auto n = static_cast<Index>(ps.size());
  std::vector<double> h(static_cast<std::size_t>(7 * n));
  for (Index i = 0; i < n; ++i) {
    const auto& q = ps[static_cast<std::size_t>(i)];
    const double v[7] = {q.x, q.y, q.z, a, q.vx, q.vy, q.vz};
    for (int k = 0; k < 7; ++k) h[static_cast<std::size_t>(k * n + i)] = v[k];
  }
  Buffer<double> pd(b, h.size());
  pd.copy_from_host(h);
  imb::SphereView p;
  p.x = pd.data();
  p.y = p.x + n;
  p.z = p.y + n;
  p.r = p.z + n;
  p.vx = p.r + n;
  p.vy = p.vx + n;
  p.vz = p.vy + n;
  p.n = n;
  // Forces already there (a gather's) are added to, stride 4.
  std::vector<double> f0(static_cast<std::size_t>(4 * n));
  for (std::size_t i = 0; i < f0.size(); ++i) f0[i] = 1e-3 * double(i + 1);
  Buffer<double> fd(b, f0.size());
  fd.copy_from_host(f0);
  imb::add_wall_lubrication(Exec(b), s.k, p, n, fd.data(), 4);
  const auto f = fd.to_vector();
  const imb::WallLubrication w;
  auto bench = [&](double g, double un) { return imb::wall_lubrication_force(mu, a, g, un, m); };
  const double expect_z[] = {bench(1.0, 1e-3),  bench(1.5, -1e-3), -bench(2.0, 1e-3), bench(7.5, 1e-3), 0.0,
                             bench(w.g_min, 1e-3), bench(w.g_min, 1e-3), 0.0};
  for (Index i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(4 * i);
    EXPECT_EQ(f[k], f0[k]) << i;  // x, y: no tangential part
    EXPECT_EQ(f[k + 1], f0[k + 1]) << i;
    EXPECT_EQ(f[k + 3], f0[k + 3]) << i;  // w untouched
    const double dz = f[k + 2] - f0[k + 2], ez = expect_z[i];
    EXPECT_NEAR(dz, ez, 1e-12 * std::abs(ez) + 1e-18) << "particle " << i;
  }
  // Signs: pushed away from the wall it approaches, pulled toward the one it leaves.
  EXPECT_GT(expect_z[0], 0.0);
  EXPECT_LT(expect_z[1], 0.0);  // receding from the lower wall: pulled back toward it
  EXPECT_LT(expect_z[2], 0.0);
}

INSTANTIATE_TEST_SUITE_P(Imb, WallLubricationKernel, ::testing::ValuesIn(test::backends()), test::backend_name);

// The coupled step with the correction on adds exactly the correction to the
// hydrodynamic force of each particle (from its position and velocity at the
// fluid step) and changes nothing else of the step: three held spheres of
// d/l 6 (tau 0.8, the rule's Lambda) in the z-closed box, one a cell and a half
// above the floor approaching it, one two cells below the ceiling
// approaching it (with a tangential velocity), one in the middle (no wall
// within 8 cells). Off, the step is the default's bit for bit.
class WallLubricationCoupled : public ::testing::TestWithParam<Backend> {};

struct StepOut {
  std::vector<double> force, torque;
  dem::HostParticles p;
};

StepOut coupled_steps(Backend b, const imb::WallLubricationSetting* wl, int steps) {
  const double r = 3, tau = 0.8;
  dem::HostParticles hp;
  const double held = 1e300 / (4.0 / 3.0 * M_PI * r * r * r);
  hp.add({8, 8, 1 + r + 1.5}, r, held, {0, 0, -1e-3});
  hp.add({4, 4, 29 - r - 2.0}, r, held, {3e-4, 0, 8e-4});
  hp.add({12, 12, 15.0}, r, held, {0, 0, -1e-3});
  lbm::LbmSetup s;
  s.lattice = lbm::LatticeKind::D3Q19;
  s.precision = lbm::Precision::FP64;
  s.collision = lbm::CollisionKind::TRT;
  s.tau = tau;
  s.magic = imb::psm_magic_auto(2 * r, tau);
  s.domain = z_closed_grid();
  s.boundaries.count = 1;
  s.boundaries.kind[0] = lbm::BoundaryKind::Wall;
  dem::DemParams dp;
  dp.lo = {0, 0, 0};
  dp.hi = {16, 16, 30};
  dp.periodic = {true, true, false};
  dp.walls = {{{0, 0, 1}, {0, 0, 1}}, {{0, 0, 29}, {0, 0, -1}}};
  dp.external_forcing = true;
  dp.friction = true;
  dp.dt = 0.5;
  dp.material.stiffness = dp.material.wall_stiffness = 10;
  imb::CoupledParams cp;
  cp.dem_substeps = 2;
  cp.psm.weight = imb::PsmWeight::NobleTorczynskiWall;
  cp.psm.map.method = imb::FractionMethod::Exact;
  cp.psm.map.max_radius = r;
  cp.psm.pipeline = imb::PsmPipeline::Mapped;
  if (wl) cp.wall_lubrication = *wl;
  auto fluid = lbm::make_lbm_solver(s, b);
  const auto N = static_cast<std::size_t>(s.domain.cells());
  std::vector<std::uint8_t> flags(N, 0);
  const GridView gv = s.domain.view();
  for (int z : {0, 29})
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) flags[static_cast<std::size_t>(gv.index(x, y, z))] = 1;
  fluid->initialize(flags, std::vector<double>(N, 1.0), std::vector<double>(3 * N, 0.0));
  dem::DemSystem dem(Exec(b), dp, hp);
  imb::CoupledSolver cs(*fluid, dem, cp);
  cs.advance(steps);
  return {cs.hydro_force_host(), cs.hydro_torque_host(), dem.download()};
}

TEST_P(WallLubricationCoupled, AddsTheCorrectionAndNothingElse) {
  const Backend b = GetParam();
  const auto on = rule_setting(true);
  const auto off = rule_setting(false);
  ASSERT_TRUE(on.applied);
  for (int steps : {1, 3}) {
    const StepOut base = coupled_steps(b, nullptr, steps);
    const StepOut o0 = coupled_steps(b, &off, steps);
    const StepOut o1 = coupled_steps(b, &on, steps);
    EXPECT_EQ(o0.force, base.force);  // off: the default's bits
    EXPECT_EQ(o0.torque, base.torque);
    EXPECT_EQ(o1.torque, base.torque);  // no torque
    ASSERT_EQ(o1.force.size(), 9u);
    int corrected = 0;
    for (std::size_t i = 0; i < 3; ++i) {
      ASSERT_EQ(o1.p.id[i], base.p.id[i]);
      // Held spheres: their velocity is the initial one, the position at the
      // last fluid step one step back.
      const Vec3d v = o1.p.v[i];
      const Vec3d x = o1.p.x[i] - v;
      const double a = o1.p.r[i];
      const double g_lo = x.z - 1 - a, g_hi = 29 - x.z - a;
      double ez = 0;
      if (g_lo < 8) ez += imb::wall_lubrication_force(on.k.mu, a, g_lo, -v.z, on.magic);
      if (g_hi < 8) ez -= imb::wall_lubrication_force(on.k.mu, a, g_hi, v.z, on.magic);
      corrected += ez != 0;
      EXPECT_EQ(o1.force[3 * i], base.force[3 * i]) << i;
      EXPECT_EQ(o1.force[3 * i + 1], base.force[3 * i + 1]) << i;
      const double dz = o1.force[3 * i + 2] - base.force[3 * i + 2];
      EXPECT_NEAR(dz, ez, 1e-12 * (std::abs(o1.force[3 * i + 2]) + std::abs(base.force[3 * i + 2])) + 1e-20)
          << "particle id " << o1.p.id[i] << " after " << steps << " steps";
    }
    EXPECT_EQ(corrected, 2);
  }
}

INSTANTIATE_TEST_SUITE_P(Imb, WallLubricationCoupled, ::testing::ValuesIn(test::backends()), test::backend_name);

}  // namespace
