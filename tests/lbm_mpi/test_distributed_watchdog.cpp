// The fluid watchdog on N ranks (mpiexec -n 1..3): a non-finite cell on one
// rank is seen by every rank in the same diagnostics() call (the ranks stop
// at the same step), named by its whole-grid coordinates and its rank; the
// fastest cell likewise. Reference: the decomposition's own pieces.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "halo/comm.hpp"
#include "lbm/distributed_fluid.hpp"
#include "lbm/lbm_test_util.hpp"

namespace lbdem::lbm {
namespace {

// The rank whose piece owns whole-grid cell (x, y, z).
int owner(const DistributedFluid& f, const Grid& whole, std::array<long, 3> c) {
  const auto& dec = f.decomposition();
  for (int r = 0; r < dec.ranks(); ++r) {
    const Grid p = dec.piece(whole, r);
    bool in = true;
    for (std::size_t a = 0; a < 3; ++a) in = in && c[a] >= p.offset[a] && c[a] < p.offset[a] + p.local[a];
    if (in) return r;
  }
  return -1;
}

// Every rank's value of v, on every rank.
std::vector<long> all_of(const halo::Comm& comm, long v) {
  std::vector<long> out;
  for (int r = 0; r < comm.size(); ++r) {
    // (max of "mine if I am r, else the smallest long": rank r's value, the same on all)
    out.push_back(comm.max(comm.rank() == r ? v : std::numeric_limits<long>::min()));
  }
  return out;
}

TEST(DistributedWatchdog, NonFiniteCellNamedWithItsRankOnEveryRank) {
  const halo::Comm& comm = halo::Comm::world();
  test::Scene s = test::make_scene(LatticeKind::D2Q9, 12, 6 * comm.size(), 1);
  s.setup.tau = 0.8;
  halo::ParallelOptions po;
  po.decomposition = {1, comm.size(), 1};
  // A bad cell in the last rank's piece.
  const std::array<long, 3> bad{7, 6 * comm.size() - 2, 0};
  s.rho[test::cell_index(s, bad[0], bad[1], bad[2])] = std::numeric_limits<double>::quiet_NaN();
  DistributedFluid f(s.setup, Backend::Host, po, comm);
  f.initialize(s.flags, s.rho, s.u);
  const LbmDiagnostics d = f.diagnostics();
  const Grid whole = s.setup.domain;
  EXPECT_FALSE(d.finite);
  EXPECT_EQ(d.nonfinite_cell, bad);
  EXPECT_EQ(f.nonfinite_rank(), owner(f, whole, bad));
  EXPECT_EQ(f.nonfinite_rank(), comm.size() - 1);
  // Every rank holds the same verdict (so every rank stops at this step).
  for (long v : all_of(comm, d.finite ? 1 : 0)) EXPECT_EQ(v, 0);
  for (long v : all_of(comm, f.nonfinite_rank())) EXPECT_EQ(v, comm.size() - 1);
  for (long v : all_of(comm, d.nonfinite_cell[1])) EXPECT_EQ(v, bad[1]);
}

TEST(DistributedWatchdog, FastestCellNamedWithItsRankAndFiniteFieldNamesNoBadRank) {
  const halo::Comm& comm = halo::Comm::world();
  test::Scene s = test::make_scene(LatticeKind::D2Q9, 8, 4 * comm.size(), 1);
  s.setup.tau = 0.8;
  halo::ParallelOptions po;
  po.decomposition = {1, comm.size(), 1};
  // The fastest cell in the last rank's piece (before any step: exactly where it was put).
  const std::array<long, 3> fast{3, 4 * comm.size() - 3, 0};
  s.u[3 * test::cell_index(s, fast[0], fast[1], fast[2])] = 0.05;
  DistributedFluid f(s.setup, Backend::Host, po, comm);
  f.initialize(s.flags, s.rho, s.u);
  const LbmDiagnostics d = f.diagnostics();
  EXPECT_TRUE(d.finite);
  EXPECT_EQ(f.nonfinite_rank(), -1);
  EXPECT_EQ(d.max_speed_cell, fast);
  EXPECT_EQ(f.max_speed_rank(), owner(f, s.setup.domain, fast));
  EXPECT_EQ(f.max_speed_rank(), comm.size() - 1);
  EXPECT_NEAR(d.max_speed, 0.05, 1e-12);
  for (long v : all_of(comm, f.max_speed_rank())) EXPECT_EQ(v, comm.size() - 1);
}

}  // namespace
}  // namespace lbdem::lbm
