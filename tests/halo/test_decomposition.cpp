// Cartesian decomposition: pieces tile the global grid exactly, the chosen cut
// moves the fewest halo cells, neighbours wrap only on periodic axes, and
// impossible requests are refused before anything is allocated.
#include <gtest/gtest.h>

#include <vector>

#include "core/error.hpp"
#include "halo/decomposition.hpp"

namespace lbdem::halo {
namespace {

// Every global cell is owned by exactly one rank.
void expect_partition(const Grid& whole, const Decomposition& d) {
  const auto n = whole.global;
  std::vector<int> owner(static_cast<std::size_t>(n[0] * n[1] * n[2]), -1);
  for (int r = 0; r < d.ranks(); ++r) {
    const Grid p = d.piece(whole, r);
    ASSERT_NO_THROW(p.validate());
    for (long k = 0; k < p.local[2]; ++k)
      for (long j = 0; j < p.local[1]; ++j)
        for (long i = 0; i < p.local[0]; ++i) {
          const long g = (i + p.offset[0]) + n[0] * ((j + p.offset[1]) + n[1] * (k + p.offset[2]));
          ASSERT_EQ(owner[static_cast<std::size_t>(g)], -1) << "cell owned twice";
          owner[static_cast<std::size_t>(g)] = r;
        }
  }
  for (int o : owner) ASSERT_GE(o, 0) << "cell owned by no rank";
}

TEST(Decomposition, PiecesTileTheGridUnevenly) {
  const Grid whole = Grid::whole({13, 7, 11});
  for (int ranks : {1, 2, 3, 4, 5, 6, 8, 12}) {
    const Decomposition d = decompose(whole, ranks);
    EXPECT_EQ(d.ranks(), ranks);
    expect_partition(whole, d);
  }
  expect_partition(whole, decompose(whole, 6, {3, 1, 2}));
}

TEST(Decomposition, FewestHaloCells) {
  // A tall box is cut across its long axis.
  const Grid tall = Grid::whole({64, 252, 64});
  EXPECT_EQ(decompose(tall, 2).dims, (std::array<int, 3>{1, 2, 1}));
  // A cube on 4 ranks: one axis cut 4 times moves as much as 2 x 2; fewer
  // split axes (fewer messages) win, and z before y before x.
  const Grid cube = Grid::whole({256, 256, 256});
  EXPECT_EQ(decompose(cube, 4).dims, (std::array<int, 3>{1, 1, 4}));
  EXPECT_DOUBLE_EQ(decompose(cube, 4).halo_cells(), 4.0 * 256 * 256);
  // 8 ranks: 2 x 2 x 2 and 1 x 2 x 4 both move 6 faces; 1 x 2 x 4 has fewer axes.
  const Decomposition d8 = decompose(cube, 8);
  EXPECT_DOUBLE_EQ(d8.halo_cells(), 6.0 * 256 * 256);
  EXPECT_EQ(d8.dims, (std::array<int, 3>{1, 2, 4}));
  // A walled axis has one cut face fewer than a periodic one.
  Grid walled = Grid::whole({64, 64, 64}, {true, false, true});
  EXPECT_EQ(decompose(walled, 2).dims, (std::array<int, 3>{1, 2, 1}));
  // 2D grids are never cut along z.
  EXPECT_EQ(decompose(Grid::whole({100, 400, 1}), 4).dims[2], 1);
}

TEST(Decomposition, NeighboursWrapOnlyWherePeriodic) {
  const Grid whole = Grid::whole({16, 16, 16}, {true, false, true});
  const Decomposition d = decompose(whole, 8, {2, 2, 2});
  const int r = d.rank_at({0, 0, 0});
  EXPECT_EQ(d.neighbour(r, 0, -1), d.rank_at({1, 0, 0}));  // periodic x wraps
  EXPECT_EQ(d.neighbour(r, 1, -1), -1);                    // walled y ends
  EXPECT_EQ(d.neighbour(r, 1, +1), d.rank_at({0, 1, 0}));
  EXPECT_EQ(d.neighbour(r, 2, +1), d.rank_at({0, 0, 1}));
  const Grid p = d.piece(whole, d.rank_at({1, 1, 0}), 1);
  EXPECT_EQ(p.offset, (std::array<long, 3>{8, 8, 0}));
  EXPECT_EQ(p.storage(), (std::array<long, 3>{10, 10, 10}));
  EXPECT_EQ(p.view().shift[0], 7.0);  // storage x 0 is the ghost at global 7
}

TEST(Decomposition, RefusesWhatCannotWork) {
  const Grid small = Grid::whole({4, 4, 4});
  try {
    decompose(small, 64);
    FAIL() << "64 ranks on 4^3 accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("at most 8 ranks"), std::string::npos) << e.what();
  }
  EXPECT_THROW(decompose(small, 4, {2, 2, 2}), ConfigError);  // product != ranks
  EXPECT_THROW(decompose(small, 4, {4, 1, 1}), ConfigError);  // 1 cell per rank along x
  EXPECT_THROW(decompose(Grid::whole({32, 32, 1}), 2, {1, 1, 2}), ConfigError);  // 2D cut along z
  EXPECT_THROW(decompose(small, 0), ConfigError);
}

}  // namespace
}  // namespace lbdem::halo
