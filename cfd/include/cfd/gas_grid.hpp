#pragma once
// The coarse gas grid of the unresolved mode, as kernels see it: a box of
// n[0] x n[1] x n[2] cubic cells of size h [m], lower corner `origin` [m],
// x-fastest storage, each axis periodic or closed by boundaries. Built from
// the one grid description (core/grid.hpp: global extent, origin, spacing,
// periodic flags) of a single-rank, ghost-free grid.
#include <stdexcept>

#include "core/grid.hpp"
#include "core/hd.hpp"

namespace lbdem::cfd {

struct GasGridView {
  int n[3] = {1, 1, 1};
  double origin[3] = {0, 0, 0};
  double h = 1;
  bool periodic[3] = {false, false, false};

  LBDEM_HD Index cells() const { return static_cast<Index>(n[0]) * n[1] * n[2]; }
  LBDEM_HD Index index(int i, int j, int k) const { return i + static_cast<Index>(n[0]) * (j + static_cast<Index>(n[1]) * k); }
  LBDEM_HD void coords(Index c, int& i, int& j, int& k) const {
    i = static_cast<int>(c % n[0]);
    const Index r = c / n[0];
    j = static_cast<int>(r % n[1]);
    k = static_cast<int>(r / n[1]);
  }
  LBDEM_HD double volume() const { return h * h * h; }
};

inline GasGridView gas_grid_view(const Grid& g) {
  if (!g.whole_grid())
    throw std::invalid_argument("cfd: the gas grid must be one piece (no decomposition yet): " + g.describe());
  GasGridView v;
  for (int a = 0; a < 3; ++a) {
    v.n[a] = static_cast<int>(g.global[static_cast<std::size_t>(a)]);
    v.origin[a] = g.origin[static_cast<std::size_t>(a)];
    v.periodic[a] = g.periodic[static_cast<std::size_t>(a)];
  }
  v.h = g.spacing;
  return v;
}

}  // namespace lbdem::cfd
