#include "core/grid.hpp"

#include <sstream>
#include <stdexcept>

namespace lbdem {

Grid Grid::whole(std::array<long, 3> cells, std::array<bool, 3> periodic) {
  Grid g;
  g.global = g.local = cells;
  g.periodic = periodic;
  return g;
}

std::array<long, 3> Grid::storage() const {
  std::array<long, 3> s{};
  for (int a = 0; a < 3; ++a) s[static_cast<std::size_t>(a)] = local[static_cast<std::size_t>(a)] + 2L * ghost_on(a);
  return s;
}

Index Grid::storage_cells() const {
  const auto s = storage();
  return static_cast<Index>(s[0]) * s[1] * s[2];
}

bool Grid::whole_grid() const {
  for (std::size_t a = 0; a < 3; ++a)
    if (offset[a] != 0 || local[a] != global[a] || (split[a] && ghost > 0)) return false;
  return true;
}

GridView Grid::view() const {
  GridView v;
  const auto s = storage();
  v.nx = static_cast<int>(s[0]);
  v.ny = static_cast<int>(s[1]);
  v.nz = static_cast<int>(s[2]);
  v.nxy = static_cast<Index>(v.nx) * v.ny;
  v.n = v.nxy * v.nz;
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    v.shift[a] = static_cast<double>(offset[k] - ghost_on(a));
    v.global[a] = static_cast<int>(global[k]);
    v.periodic[a] = periodic[k] && !split[k];
    v.image[a] = periodic[k] && split[k] ? static_cast<double>(global[k]) : 0.0;
  }
  return v;
}

CellBox Grid::owned() const {
  CellBox b;
  for (int a = 0; a < 3; ++a) {
    b.lo[a] = ghost_on(a);
    b.ext[a] = static_cast<int>(local[static_cast<std::size_t>(a)]);
  }
  return b;
}

CellBox Grid::inner(int width) const {
  CellBox b = owned();
  for (int a = 0; a < 3; ++a) {
    if (!split[static_cast<std::size_t>(a)]) continue;
    b.lo[a] += width;
    b.ext[a] -= 2 * width;
    if (b.ext[a] < 0) b.ext[a] = 0;
  }
  return b;
}

std::vector<CellBox> Grid::outer(int width) const {
  // Peel the owned box axis by axis: on each split axis, the low and high
  // slabs of `width` layers over what is left of the other axes.
  std::vector<CellBox> out;
  CellBox rest = owned();
  for (int a = 0; a < 3; ++a) {
    if (!split[static_cast<std::size_t>(a)]) continue;
    const int w = rest.ext[a] < 2 * width ? (rest.ext[a] + 1) / 2 : width;
    CellBox lo = rest, hi = rest;
    lo.ext[a] = w;
    hi.ext[a] = rest.ext[a] - w < w ? rest.ext[a] - w : w;
    hi.lo[a] = rest.lo[a] + rest.ext[a] - hi.ext[a];
    if (!lo.empty()) out.push_back(lo);
    if (!hi.empty()) out.push_back(hi);
    rest.lo[a] += w;
    rest.ext[a] -= w + hi.ext[a];
    if (rest.ext[a] < 0) rest.ext[a] = 0;
  }
  return out;
}

void Grid::validate() const {
  auto fail = [&](const std::string& why) { throw std::invalid_argument("grid " + describe() + ": " + why); };
  for (std::size_t a = 0; a < 3; ++a) {
    if (global[a] < 1) fail("every axis needs at least one cell");
    if (local[a] < 1) fail("a rank must own at least one cell per axis");
    if (offset[a] < 0 || offset[a] + local[a] > global[a]) fail("the owned box lies outside the global grid");
    if (!split[a] && (offset[a] != 0 || local[a] != global[a]))
      fail("an axis not split across ranks must be owned whole");
  }
  if (ghost < 0) fail("ghost layers must be >= 0");
  if (!(spacing > 0)) fail("cell spacing must be > 0");
  const auto s = storage();
  if (static_cast<double>(s[0]) * static_cast<double>(s[1]) * static_cast<double>(s[2]) >= 2147483648.0)
    fail("one rank holds fewer than 2^31 cells; split the domain across more ranks");
}

std::string Grid::describe() const {
  std::ostringstream o;
  o << global[0] << " x " << global[1] << " x " << global[2];
  if (!whole_grid())
    o << " (owned " << local[0] << " x " << local[1] << " x " << local[2] << " at " << offset[0] << ", " << offset[1]
      << ", " << offset[2] << "; ghost " << ghost << ")";
  return o.str();
}

}  // namespace lbdem
