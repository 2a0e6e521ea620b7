// The fluid at rest made on each rank for its piece alone
// (DistributedFluid::initialize_uniform, the device-side fill of
// LbmSolver::initialize_at_rest) against the same state from whole-grid host
// fields (initialize): every stored population of every storage cell, ghost
// layers included (those beyond a walled end at density 1), bit for bit, and
// again after two steps; on 1..3 ranks cut along a walled axis and a periodic one.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "../common/backends.hpp"
#include "halo/comm.hpp"
#include "lbm/boundary.hpp"
#include "lbm/distributed_fluid.hpp"
#include "lbm/lbm_test_util.hpp"

namespace lbdem::lbm {
namespace {

std::vector<unsigned char> slots(LbmSolver& s, int Q) {
  const auto n = static_cast<std::size_t>(s.setup().domain.view().n) * static_cast<std::size_t>(s.storage_bytes());
  std::vector<unsigned char> all(n * static_cast<std::size_t>(Q));
  for (int q = 0; q < Q; ++q) s.read_slot(q, all.data() + n * static_cast<std::size_t>(q));
  return all;
}

void compare(Backend be, LatticeKind lk, StreamKind sk, Precision pr, int cut_axis) {
  const halo::Comm& comm = halo::Comm::world();
  const bool d3 = lk == LatticeKind::D3Q19;
  test::Scene s = test::make_scene(lk, 6 * comm.size(), 5 * comm.size(), d3 ? 4 : 1);
  s.setup.tau = 0.8;
  s.setup.streaming = sk;
  s.setup.precision = pr;
  s.setup.body_force = {1e-5, -2e-5, 0};
  // Walls at y = 0 and y = ny - 1 (half-way bounce-back), periodic x and z.
  s.setup.domain.periodic = {true, false, true};
  const int wall = test::add_boundary(s, BoundaryKind::Wall);  // its flag value
  test::add_y_walls(s, wall, wall);
  const double rho = 1.03;
  std::fill(s.rho.begin(), s.rho.end(), rho);
  halo::ParallelOptions po;
  po.decomposition = {1, 1, 1};
  po.decomposition[static_cast<std::size_t>(cut_axis)] = comm.size();
  DistributedFluid a(s.setup, be, po, comm), b(s.setup, be, po, comm);
  a.initialize(s.flags, s.rho, s.u);
  const auto& f = s.flags;
  const auto nx = s.setup.domain.global[0], ny = s.setup.domain.global[1];
  b.initialize_uniform([&](long x, long y, long z) { return f[static_cast<std::size_t>(x + nx * (y + ny * z))]; }, rho);
  const int Q = d3 ? 19 : 9;
  for (int round = 0; round < 2; ++round) {
    if (round == 1) {  // the flags and ghost layers at work: two steps of each
      a.step(2);
      b.step(2);
    }
    const auto sa = slots(a.local(), Q), sb = slots(b.local(), Q);
    ASSERT_EQ(sa.size(), sb.size());
    EXPECT_EQ(std::memcmp(sa.data(), sb.data(), sa.size()), 0)
        << to_string(be) << " rank " << comm.rank() << " after " << 2 * round << " steps, cut along " << cut_axis;
  }
}

TEST(InitializeAtRest, PiecesAtRestEqualTheWholeGridFieldsBitwise) {
  for (Backend be : test::backends())
    for (int axis : {0, 1}) {
      compare(be, LatticeKind::D2Q9, StreamKind::AA, Precision::FP64, axis);
      compare(be, LatticeKind::D2Q9, StreamKind::TwoLattice, Precision::FP32, axis);
      compare(be, LatticeKind::D3Q19, StreamKind::AA, Precision::FP32, axis);
    }
}

}  // namespace
}  // namespace lbdem::lbm
