// The Grid's boxes: owned = inner + outer slabs, disjoint, for every
// combination of split axes; one piece has no outer shell; positions map to
// storage cells through the shift.
#include <gtest/gtest.h>

#include <vector>

#include "core/grid.hpp"

namespace lbdem {
namespace {

TEST(Grid, WholeGridIsOnePiece) {
  const Grid g = Grid::whole({12, 10, 8});
  EXPECT_TRUE(g.whole_grid());
  EXPECT_EQ(g.storage_cells(), 12 * 10 * 8);
  EXPECT_TRUE(g.outer().empty());
  const CellBox in = g.inner(), own = g.owned();
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(in.lo[a], own.lo[a]);
    EXPECT_EQ(in.ext[a], own.ext[a]);
  }
  const GridView v = g.view();
  EXPECT_EQ(v.n, 12 * 10 * 8);
  EXPECT_EQ(v.shift[0], 0.0);
}

TEST(Grid, InnerAndOuterPartitionTheOwnedCells) {
  for (int mask = 0; mask < 8; ++mask)
    for (int width : {1, 2}) {
      Grid g;
      g.global = {40, 30, 20};
      g.local = {9, 7, 5};
      g.ghost = 2;
      for (int a = 0; a < 3; ++a) g.split[static_cast<std::size_t>(a)] = (mask >> a) & 1;
      for (int a = 0; a < 3; ++a)
        if (!g.split[static_cast<std::size_t>(a)]) g.local[static_cast<std::size_t>(a)] = g.global[static_cast<std::size_t>(a)];
      g.offset = {g.split[0] ? 11L : 0L, g.split[1] ? 3L : 0L, g.split[2] ? 15L : 0L};
      ASSERT_NO_THROW(g.validate());
      const GridView v = g.view();
      std::vector<int> hits(static_cast<std::size_t>(v.n), 0);
      auto mark = [&](const CellBox& b) {
        for (Index t = 0; t < b.size(); ++t) {
          int x, y, z;
          b.coords(t, x, y, z);
          ++hits[static_cast<std::size_t>(v.index(x, y, z))];
        }
      };
      const CellBox in = g.inner(width);
      mark(in);
      for (const CellBox& b : g.outer(width)) mark(b);
      const CellBox own = g.owned();
      for (int z = 0; z < v.nz; ++z)
        for (int y = 0; y < v.ny; ++y)
          for (int x = 0; x < v.nx; ++x) {
            const bool owned = x >= own.lo[0] && x < own.lo[0] + own.ext[0] && y >= own.lo[1] &&
                               y < own.lo[1] + own.ext[1] && z >= own.lo[2] && z < own.lo[2] + own.ext[2];
            ASSERT_EQ(hits[static_cast<std::size_t>(v.index(x, y, z))], owned ? 1 : 0)
                << "mask " << mask << " width " << width << " at " << x << "," << y << "," << z;
          }
      // Inner cells are at least `width` from every split face.
      for (int a = 0; a < 3; ++a)
        if (g.split[static_cast<std::size_t>(a)] && in.ext[a] > 0) {
          EXPECT_GE(in.lo[a], own.lo[a] + width);
          EXPECT_LE(in.lo[a] + in.ext[a], own.lo[a] + own.ext[a] - width);
        }
    }
}

TEST(Grid, PositionsMapThroughTheShift) {
  Grid g;
  g.global = {64, 64, 64};
  g.local = {64, 16, 64};
  g.offset = {0, 32, 0};
  g.split = {false, true, false};
  g.ghost = 1;
  g.periodic = {true, true, true};
  const GridView v = g.view();
  // Global position y = 32.5 (first owned layer) is storage cell 1 (after one ghost layer).
  EXPECT_EQ(static_cast<int>(32.5 - v.shift[1]), 1);
  EXPECT_EQ(v.global[1], 64);
  EXPECT_EQ(v.ny, 18);
}

TEST(Grid, ValidateRefusesInconsistentPieces) {
  Grid g = Grid::whole({8, 8, 8});
  g.local[0] = 4;  // not split, not whole
  EXPECT_THROW(g.validate(), std::invalid_argument);
  g.split[0] = true;
  g.offset[0] = 6;  // 6 + 4 > 8
  EXPECT_THROW(g.validate(), std::invalid_argument);
  g.offset[0] = 4;
  EXPECT_NO_THROW(g.validate());
  g.spacing = 0;
  EXPECT_THROW(g.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace lbdem
