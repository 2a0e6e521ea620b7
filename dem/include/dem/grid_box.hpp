#pragma once
// The DEM box of a coupled scene from the fluid's grid (core/grid.hpp): the
// particles live in the same global frame as the lattice, [origin, origin +
// global * spacing) per axis, and wrap on the same axes.
#include "core/grid.hpp"
#include "dem/system.hpp"

namespace lbdem::dem {

inline void set_box_from_grid(DemParams& p, const Grid& g) {
  for (std::size_t a = 0; a < 3; ++a) {
    p.lo[a] = g.origin[a];
    p.hi[a] = g.origin[a] + static_cast<double>(g.global[a]) * g.spacing;
    p.periodic[a] = g.periodic[a];
  }
}

}  // namespace lbdem::dem
