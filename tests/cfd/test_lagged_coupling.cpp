// The bed's coupled step with lagged forces (cfd/lagged_coupling.hpp), on
// every backend present, against the sequential step (dem::CoupledLoop):
//  * a first step (no earlier forces) is the sequential step, bit for bit;
//  * the next (lagged) step's gas step sees the same particles as the
//    sequential one, so the forces it hands over must be the sequential step's, bit for
//    bit, particle by particle (by id): the hand-over through the id table
//    across the neighbour-list rebuilds (reorders) of the sub-steps;
//  * on the GPU the gas step on its own queue beside the sub-steps gives the
//    bits of the same lagged steps with the gas on the DEM's queue (a missing
//    dependency between the queues would show as a difference somewhere in
//    60 steps of a bubbling column).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <vector>

#include "cfd/coupling.hpp"
#include "cfd/lagged_coupling.hpp"
#include "common/backends.hpp"
#include "core/buffer.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"

using namespace lbdem;
using namespace lbdem::cfd;

namespace {

constexpr double kG = 9.80665;

// A column of 3 x 1 x 12 gas cells of 4 mm blown at 0.5 m/s from below, ~300
// particles of 1.2 mm falling onto the distributor from a loose packing: they
// move by more than the (thin) neighbour-list skin within a few sub-steps,
// so the sub-steps of every gas step rebuild (and reorder) the list.
struct Bed {
  std::unique_ptr<dem::DemSystem> dem;
  std::unique_ptr<Lanes> lanes;
  std::unique_ptr<GasSolver> gas;
  std::unique_ptr<GasDemCoupling> coupling;
  std::unique_ptr<dem::CoupledLoop> loop;
  std::unique_ptr<LaggedCoupling> lagged;
  Exec ex;
  int substeps = 0;

  // gas_queue: 0 = the DEM's queue, 1 = a second queue (lanes.edge).
  Bed(Backend be, bool lag, int gas_queue) : ex(be) {
    const double h = 4e-3, L = 3 * h, W = h, H = 12 * h;
    dem::RandomPackingSpec spec;
    spec.lo = {0, 0, 0};
    spec.hi = {L, W, 0.03};
    spec.periodic = {false, true, false};
    spec.solid_fraction = 0.19;  // ~300 particles
    spec.r_min = spec.r_max = 0.6e-3;
    spec.density = 1000;
    spec.seed = 5;
    const dem::HostParticles init = dem::random_packing(spec);
    dem::DemParams dp;
    dp.lo = {0, 0, 0};
    dp.hi = {L, W, H};
    dp.periodic = {false, true, false};
    dp.walls = {dem::Wall{{0, 0, 0}, {0, 0, 1}}, dem::Wall{{0, 0, H}, {0, 0, -1}}, dem::Wall{{0, 0, 0}, {1, 0, 0}},
                dem::Wall{{L, 0, 0}, {-1, 0, 0}}};
    dp.material.stiffness = dp.material.wall_stiffness = 100;
    dp.material.restitution = dp.material.wall_restitution = 0.9;
    dp.material.friction = dp.material.wall_friction = 0.1;
    dp.friction = true;
    dp.gravity = {0, 0, -kG};
    dp.external_forcing = true;
    dp.skin = 1e-5;  // a thin skin: the falling particles rebuild the list within every gas step
    const double gas_dt = 2e-4;
    substeps = static_cast<int>(std::ceil(gas_dt / (dem::min_collision_time(dp, init) / 50)));
    dp.dt = gas_dt / substeps;
    dem = std::make_unique<dem::DemSystem>(ex, dp, init);
    GasGridView g;
    g.n[0] = 3;
    g.n[1] = 1;
    g.n[2] = 12;
    g.h = h;
    g.periodic[1] = true;
    GasParams gp;
    gp.rho = 1.225;
    gp.mu = 1.8e-5;
    gp.dt = gas_dt;
    gp.gravity = {0, 0, -kG};
    gp.faces[2].kind = gp.faces[3].kind = FaceKind::Periodic;
    gp.faces[4].kind = FaceKind::Inlet;
    gp.faces[4].inflow = 0.5;
    gp.faces[5].kind = FaceKind::Outlet;
    gp.drag = DragLaw::Gidaspow;
    gp.deposition = Deposition::Linear;
    gp.pressure_solver = PressureSolverKind::Multigrid;
    lanes = std::make_unique<Lanes>();
    gas = std::make_unique<GasSolver>(gas_queue ? lanes->edge(ex) : ex, g, gp);
    coupling = std::make_unique<GasDemCoupling>(*gas);
    loop = std::make_unique<dem::CoupledLoop>(*dem, *coupling, substeps);
    if (lag) {
      std::int64_t limit = 0;
      for (std::int64_t id : init.id) limit = std::max(limit, id + 1);
      lagged = std::make_unique<LaggedCoupling>(ex, *lanes, *dem, *gas, substeps, limit);
    }
    lanes->fork(ex);
    gas->initialise(dem->view());
    lanes->join(ex);
  }
  void step(long k) {
    if (lagged)
      lagged->step(k == 0);
    else
      loop->step();
  }
  // Coupling input (the forces the sub-steps take), position and velocity by id.
  std::map<std::int64_t, std::array<dem::Real4, 3>> by_id() {
    dem->synchronize();
    const dem::HostParticles hp = dem->download();
    const Index n = dem->size();
    std::vector<dem::Real4> f(static_cast<std::size_t>(n));
    backend_copy_to_host(ex.backend(), f.data(), dem->view().ext_force, sizeof(dem::Real4) * f.size());
    std::map<std::int64_t, std::array<dem::Real4, 3>> m;
    for (Index i = 0; i < n; ++i) {
      const auto u = static_cast<std::size_t>(i);
      m[hp.id[u]] = {f[u], dem::Real4{hp.x[u].x, hp.x[u].y, hp.x[u].z, 0}, dem::Real4{hp.v[u].x, hp.v[u].y, hp.v[u].z, 0}};
    }
    return m;
  }
};

bool same(const dem::Real4& a, const dem::Real4& b) {
  return std::memcmp(&a.x, &b.x, sizeof(double)) == 0 && std::memcmp(&a.y, &b.y, sizeof(double)) == 0 &&
         std::memcmp(&a.z, &b.z, sizeof(double)) == 0;
}

}  // namespace

class LaggedForces : public ::testing::TestWithParam<Backend> {};

TEST_P(LaggedForces, HandOverByIdMatchesSequentialGasStep) {
  Bed seq(GetParam(), false, 0), lag(GetParam(), true, 1);
  // 50 first (sequential) steps: the particles fall fast enough to rebuild
  // the list within each gas step's sub-steps. The same state, bit for bit.
  for (long k = 0; k < 50; ++k) {
    seq.step(k);
    lag.lagged->step(true);
  }
  const auto s0 = seq.by_id(), l0 = lag.by_id();
  ASSERT_GT(s0.size(), 200u);
  ASSERT_EQ(s0.size(), l0.size());
  for (const auto& [id, v] : s0)
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(same(v[k], l0.at(id)[k])) << "step 49, particle " << id << ", field " << k;
  const long rebuilds = lag.dem->stats().rebuilds;
  seq.step(50);
  lag.step(50);
  // The lagged step's sub-steps rebuilt the list (so its forces went through
  // a reorder) and moved the particles differently (the forces of step 0).
  EXPECT_GT(lag.dem->stats().rebuilds, rebuilds);
  const auto s1 = seq.by_id(), l1 = lag.by_id();
  int moved_differently = 0, nonzero = 0;
  for (const auto& [id, v] : s1) {
    const auto& w = l1.at(id);
    EXPECT_TRUE(same(v[0], w[0])) << "step 50, particle " << id << ": force " << v[0].z << " (sequential) vs "
                                  << w[0].z << " (lagged)";
    if (!same(v[1], w[1])) ++moved_differently;
    if (v[0].z != 0) ++nonzero;
  }
  EXPECT_GT(moved_differently, static_cast<int>(s1.size() / 3));
  EXPECT_GT(nonzero, static_cast<int>(s1.size() * 8 / 10));
}

TEST_P(LaggedForces, SecondQueueGivesTheBitsOfOneQueue) {
  Bed one(GetParam(), true, 0), two(GetParam(), true, 1);
  for (long k = 0; k < 60; ++k) {
    one.step(k);
    two.step(k);
  }
  const auto a = one.by_id(), b = two.by_id();
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [id, v] : a)
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(same(v[k], b.at(id)[k])) << "particle " << id << ", field " << k;
  // And the gas fields.
  one.dem->synchronize();
  two.dem->synchronize();
  EXPECT_EQ(one.gas->pressure().to_vector(), two.gas->pressure().to_vector());
}

INSTANTIATE_TEST_SUITE_P(All, LaggedForces, ::testing::ValuesIn(test::backends()), test::backend_name);
