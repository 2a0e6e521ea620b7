// Poiseuille flow with half-way bounce-back walls and Guo forcing.
// Reference (derived for TRT with half-way bounce-back, Ginzburg & d'Humieres 2003): with the wall half a cell
// outside the first/last fluid node and y measured from the wall,
//   u(y) = F y (H - y) / (2 nu) + F (16 Lambda - 3) / (24 nu),
// Lambda = (tau+ - 1/2)(tau- - 1/2) (TRT), (tau - 1/2)^2 (BGK).
#include <gtest/gtest.h>

#include "../common/backends.hpp"
#include "lbm_test_util.hpp"

using namespace lbdem;
using namespace lbdem::lbm;

namespace {

struct Case {
  LatticeKind lattice;
  CollisionKind coll;
  double tau;
  double magic;  // TRT only
};

// Returns max over fluid nodes of |u - u_ref| / u_max, and the expected
// uniform offset F(16 Lambda - 3)/(24 nu) / u_max.
std::pair<double, double> run_channel(const Case& c, Backend b, StreamKind sk, long H, long steps) {
  const long nx = 3, nz = c.lattice == LatticeKind::D3Q19 ? 3 : 1;
  auto s = test::make_scene(c.lattice, nx, H + 2, nz);
  s.setup.collision = c.coll;
  s.setup.streaming = sk;
  s.setup.tau = c.tau;
  s.setup.magic = c.magic;
  const double F = 1e-6;
  s.setup.body_force = {F, 0, 0};
  const int wall = test::add_boundary(s, BoundaryKind::Wall);
  test::add_y_walls(s, wall, wall);
  auto solver = test::start(s, b);
  solver->step(steps);
  std::vector<double> rho, u;
  solver->macroscopic(rho, u);
  const double nu = (c.tau - 0.5) / 3.0;
  const double lambda = c.coll == CollisionKind::BGK ? (c.tau - 0.5) * (c.tau - 0.5) : c.magic;
  const double umax = F * H * H / (8 * nu);
  const double offset = F * (16 * lambda - 3) / (24 * nu);
  double err = 0;
  for (long j = 1; j <= H; ++j) {
    const double y = j - 0.5;
    const double parabola = F * y * (H - y) / (2 * nu);
    for (long z = 0; z < nz; ++z)
      for (long x = 0; x < nx; ++x) {
        const double ux = u[3 * test::cell_index(s, x, j, z)];
        err = std::max(err, std::abs(ux - parabola - offset) / umax);
        EXPECT_NEAR(u[3 * test::cell_index(s, x, j, z) + 1], 0.0, 1e-12 * umax);
      }
  }
  return {err, offset / umax};
}

class Poiseuille : public ::testing::TestWithParam<Backend> {};

// Steps: the slowest mode decays like exp(-nu (pi/H)^2 t); 1e-13 needs
// t = 30 H^2 / (pi^2 nu).
long steps_for(long H, double tau) { return static_cast<long>(30.0 * H * H / (9.8696 * (tau - 0.5) / 3.0)); }

TEST_P(Poiseuille, TrtMagic316IsExactD2Q9) {
  for (double tau : {0.6, 0.9, 1.5}) {
    auto [err, off] = run_channel({LatticeKind::D2Q9, CollisionKind::TRT, tau, 3.0 / 16}, GetParam(), StreamKind::AA,
                                  16, steps_for(16, tau));
    EXPECT_LT(err, 1e-10) << "tau " << tau;
    EXPECT_EQ(off, 0.0);
  }
}

TEST_P(Poiseuille, TrtMagic316IsExactD3Q19) {
  auto [err, off] = run_channel({LatticeKind::D3Q19, CollisionKind::TRT, 0.8, 3.0 / 16}, GetParam(), StreamKind::AA,
                                12, steps_for(12, 0.8));
  EXPECT_LT(err, 1e-10);
}

TEST_P(Poiseuille, TrtOtherLambdaHasPredictedSlip) {
  // Lambda = 1/4: the profile is the parabola shifted by F(16L-3)/(24nu).
  auto [err, off] = run_channel({LatticeKind::D2Q9, CollisionKind::TRT, 0.8, 0.25}, GetParam(), StreamKind::TwoLattice,
                                16, steps_for(16, 0.8));
  EXPECT_GT(off, 1e-3);
  EXPECT_LT(err, 1e-10);
}

TEST_P(Poiseuille, BgkErrorMatchesPrediction) {
  // BGK: Lambda = (tau-1/2)^2, relative centreline error (16L-3)/(3H^2).
  for (double tau : {0.6, 1.0, 1.4}) {
    auto [err, off] = run_channel({LatticeKind::D2Q9, CollisionKind::BGK, tau, 0}, GetParam(), StreamKind::AA, 16,
                                  steps_for(16, tau));
    const double L = (tau - 0.5) * (tau - 0.5);
    EXPECT_NEAR(off, (16 * L - 3) / (3.0 * 16 * 16), 1e-15);
    EXPECT_LT(err, 1e-10) << "tau " << tau;  // profile = parabola + predicted offset
  }
  auto [err3, off3] = run_channel({LatticeKind::D3Q19, CollisionKind::BGK, 1.2, 0}, GetParam(), StreamKind::AA, 10,
                                  steps_for(10, 1.2));
  EXPECT_LT(err3, 1e-10);
}

INSTANTIATE_TEST_SUITE_P(Backends, Poiseuille, ::testing::ValuesIn(test::backends()), test::backend_name);

}  // namespace
