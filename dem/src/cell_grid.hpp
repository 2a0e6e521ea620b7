#pragma once
// The neighbour search's cell grid (host and device).
#include <cmath>
#include <cstdint>

#include "core/hd.hpp"
#include "dem/particle_view.hpp"

namespace lbdem::dem {

// Uniform cell grid over the box; cells at least the largest cutoff wide.
struct CellGrid {
  double lo[3];
  double inv_cl[3];
  int nc[3];
  int periodic[3];
  LBDEM_HD int coord(double x, int k) const {
    int c = static_cast<int>(floor((x - lo[k]) * inv_cl[k]));
    return c < 0 ? 0 : (c >= nc[k] ? nc[k] - 1 : c);
  }
  LBDEM_HD std::uint32_t cell(const Real4& p) const {
    return static_cast<std::uint32_t>(coord(p.x, 0) + nc[0] * (coord(p.y, 1) + nc[1] * coord(p.z, 2)));
  }
};

}  // namespace lbdem::dem
