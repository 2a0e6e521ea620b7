#pragma once
// Sub-domain geometry. One rank owns a box of the global lattice; cells are
// stored x-fastest over the local box including `ghost` layers on each side.
// With one rank every axis wraps onto itself (ghost = 0); with several ranks
// the axes split across ranks get ghost layers filled by the halo exchange.
// Non-periodic faces are closed by boundary cells (flag > 0) in the outermost
// layer, so neighbour lookups never need a branch on the domain edge.
#include <array>

#include "core/hd.hpp"

namespace lbdem::lbm {

struct SubDomain {
  std::array<long, 3> global{1, 1, 1};  // global cells per axis
  std::array<long, 3> offset{0, 0, 0};  // global index of this rank's first owned cell
  std::array<long, 3> local{1, 1, 1};   // owned cells per axis
  int ghost = 0;                        // ghost layers per side on split axes (0 on one rank)
  Index cells() const { return static_cast<Index>(local[0]) * local[1] * local[2]; }
};

// What a kernel needs to find neighbours: extents and wrap. Trivially copyable.
struct GridView {
  int nx = 1, ny = 1, nz = 1;
  Index nxy = 1, n = 1;
  // 32-bit arithmetic: a rank's box holds fewer than 2^31 cells (checked when
  // the solver is made), and 64-bit division costs ~5x more on a GPU.
  LBDEM_HD void coords(Index cell, int& x, int& y, int& z) const {
    const auto c = static_cast<unsigned>(cell);
    const auto sxy = static_cast<unsigned>(nxy), sx = static_cast<unsigned>(nx);
    const unsigned zz = c / sxy;
    const unsigned r = c - zz * sxy;
    const unsigned yy = r / sx;
    z = static_cast<int>(zz);
    y = static_cast<int>(yy);
    x = static_cast<int>(r - yy * sx);
  }
  LBDEM_HD Index index(int x, int y, int z) const { return x + static_cast<Index>(nx) * y + nxy * z; }
};

inline GridView make_grid_view(const SubDomain& d) {
  GridView g;
  g.nx = static_cast<int>(d.local[0] + 2 * d.ghost);
  g.ny = static_cast<int>(d.local[1] + 2 * d.ghost);
  g.nz = static_cast<int>(d.local[2] + 2 * d.ghost);
  g.nxy = static_cast<Index>(g.nx) * g.ny;
  g.n = g.nxy * g.nz;
  return g;
}

}  // namespace lbdem::lbm
