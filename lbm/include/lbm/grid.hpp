#pragma once
// The lattice's grid is the project-wide lbdem::Grid (core/grid.hpp): global
// extent, this rank's owned box, ghost layers, periodic flags, origin and
// spacing. Kernels see it as a GridView and iterate over CellBoxes of it.
#include "core/grid.hpp"

namespace lbdem::lbm {
using lbdem::CellBox;
using lbdem::Grid;
using lbdem::GridView;
}  // namespace lbdem::lbm
