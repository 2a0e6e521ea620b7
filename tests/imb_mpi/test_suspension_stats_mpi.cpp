// The coarse-grained solid-fraction statistics of a suspension on several CPU
// ranks (imb/suspension.hpp): each rank holds only the coarse cells near its
// own piece (never the whole domain's), the counts of cells that straddle a
// cut reach their owners, and the variances are those of one rank holding
// every particle, bit for bit (exact integer moments), with particles exactly
// on cuts, on coarse-cell edges and on the periodic faces, and the pieces cut
// along one or two axes.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "core/grid.hpp"
#include "dem/domain.hpp"
#include "dem/system.hpp"
#include "halo/comm.hpp"
#include "halo/decomposition.hpp"
#include "imb/suspension.hpp"

namespace lbdem::imb {
namespace {

const halo::Comm& world() { return halo::Comm::world(); }

constexpr long kCells[3] = {96, 64, 32};
constexpr double kRadius = 2;  // d = 4 cells: coarse cells of 8, 16 and 32 cells

std::array<int, 3> cut_for(int ranks) {
  switch (ranks) {
    case 1: return {1, 1, 1};
    case 2: return {2, 1, 1};
    case 4: return {2, 2, 1};  // two axes
    default: return {ranks, 1, 1};
  }
}

dem::DemParams params() {
  dem::DemParams p;
  p.lo = {0, 0, 0};
  p.hi = {double(kCells[0]), double(kCells[1]), double(kCells[2])};
  p.periodic = {true, true, true};
  p.material.stiffness = p.material.wall_stiffness = 1e3;
  p.dt = 0.01;
  p.external_forcing = true;
  return p;
}

// Scattered particles (a fixed seed), clustered in one corner (so that the
// variance is well above its random value), and particles exactly on the cuts
// x = 48 and y = 32, on coarse-cell edges and on the periodic faces.
dem::HostParticles particles() {
  dem::HostParticles hp;
  std::mt19937_64 rng(20261128);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 300; ++i)
    hp.add({u(rng) * kCells[0], u(rng) * kCells[1], u(rng) * kCells[2]}, kRadius, 10.0, {0, 0, 0});
  for (int i = 0; i < 60; ++i) hp.add({2 + 12 * u(rng), 2 + 10 * u(rng), 2 + 8 * u(rng)}, kRadius, 10.0, {0, 0, 0});
  for (double x : {0.0, 8.0, 47.5, 48.0, 88.0})
    for (double y : {0.0, 16.0, 32.0, 63.5}) hp.add({x, y, 16.0}, kRadius, 10.0, {0, 0, 0});
  hp.add({48.0, 32.0, 0.0}, kRadius, 10.0, {0, 0, 0});
  return hp;
}

SuspensionStatsSpec spec_of() {
  SuspensionStatsSpec s;
  s.fluid_lo = {0, 0, 0};
  s.fluid_hi = {kCells[0], kCells[1], kCells[2]};
  s.diameter = 2 * kRadius;
  s.filter_widths = {2, 4, 8};
  return s;
}

TEST(SuspensionStatsMpi, OwnerBasedCoarseCellsEqualOneRank) {
  const halo::Comm& comm = world();
  const dem::DemParams p = params();
  const dem::HostParticles hp = particles();
  const Grid whole = Grid::whole({kCells[0], kCells[1], kCells[2]});
  const halo::Decomposition dec = halo::decompose(whole, comm.size(), cut_for(comm.size()));
  dem::DemSystem many(Exec(Backend::Host), p, hp, dem::domain_from_decomposition(comm, dec, p));
  SuspensionStatsSpec spec = spec_of();
  spec.comm = &comm;
  for (int r = 0; r < comm.size(); ++r) {
    const Grid q = dec.piece(whole, r);
    spec.piece_offset.push_back(q.offset);
    spec.piece_cells.push_back(q.local);
  }
  SuspensionStatistics stats(Exec(Backend::Host), spec);
  const lbm::LbmDiagnostics d;
  const SuspensionSample s = stats.sample(many, d);
  // Every rank, the one-rank statistics of every particle.
  dem::DemSystem one(Exec(Backend::Host), p, hp);
  SuspensionStatistics stats1(Exec(Backend::Host), spec_of());
  const SuspensionSample s1 = stats1.sample(one, d);
  ASSERT_EQ(s.phi_variance.size(), 3u);
  ASSERT_EQ(s1.phi_variance.size(), 3u);
  for (std::size_t w = 0; w < 3; ++w) {
    EXPECT_EQ(std::memcmp(&s.phi_variance[w], &s1.phi_variance[w], sizeof(double)), 0)
        << "width " << w << ": " << s.phi_variance[w] << " against " << s1.phi_variance[w];
    EXPECT_EQ(s.bins[w], s1.bins[w]);
    EXPECT_GT(s1.phi_variance[w], 0.0);
  }
  EXPECT_GT(s1.phi_variance_rel[0], 1.0);  // the clustered corner
  // The random-value ratio divides by the mean volume, a double sum over ranks: round-off apart.
  for (std::size_t w = 0; w < 3; ++w)
    EXPECT_NEAR(s.phi_variance_rel[w], s1.phi_variance_rel[w], 1e-12 * s1.phi_variance_rel[w]);
  // Memory scales with the piece: per width and axis at most the coarse cells
  // that the piece widened by a diameter on each side touches (its own plus
  // two partial ones), never the whole axis unless that is all there is.
  const Grid mine = dec.piece(whole, comm.rank());
  Index bound = 0;
  const double margin = 2 * kRadius;
  for (std::size_t w = 0; w < 3; ++w) {
    Index cells = 1;
    for (int a = 0; a < 3; ++a) {
      const long n = s.bins[w][static_cast<std::size_t>(a)];
      const double width = double(kCells[a]) / double(n);
      const long touched = static_cast<long>(std::floor((double(mine.local[static_cast<std::size_t>(a)]) + 2 * margin) / width)) + 2;
      cells *= std::min(n, touched);
    }
    bound += cells;
  }
  EXPECT_LE(stats.bins_held(), bound) << "rank " << comm.rank();
  EXPECT_EQ(stats1.bins_held(), 12 * 8 * 4 + 6 * 4 * 2 + 3 * 2 * 1);
  if (comm.size() >= 2) EXPECT_LT(stats.bins_held(), stats1.bins_held()) << "rank " << comm.rank();
}

}  // namespace
}  // namespace lbdem::imb
