// DemDomain: pieces of the DEM box, owners of positions, and the choice of
// a decomposition for a pure DEM scene.
#include "dem/domain.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/grid.hpp"
#include "dem/system.hpp"

namespace lbdem::dem {

int DemDomain::part(int a, double x) const {
  const auto& c = cuts[static_cast<std::size_t>(a)];
  const int d = dec.dims[static_cast<std::size_t>(a)];
  if (d <= 1 || c.empty()) return 0;
  // Largest i with c[i] <= x (upper_bound - 1), clamped to [0, d - 1].
  const int i = static_cast<int>(std::upper_bound(c.begin(), c.end(), x) - c.begin()) - 1;
  return std::clamp(i, 0, d - 1);
}

int DemDomain::owner(const Vec3d& x) const {
  return dec.rank_at({part(0, x.x), part(1, x.y), part(2, x.z)});
}

void DemDomain::piece(int r, Vec3d& lo, Vec3d& hi) const {
  const auto c = dec.coords(r);
  for (std::size_t a = 0; a < 3; ++a) {
    lo[static_cast<int>(a)] = cuts[a][static_cast<std::size_t>(c[a])];
    hi[static_cast<int>(a)] = cuts[a][static_cast<std::size_t>(c[a]) + 1];
  }
}

double ghost_width(const DemParams& p, const std::vector<double>& radii) {
  double rmax = 0, rmin = 1e300;
  for (double r : radii) {
    rmax = std::max(rmax, r);
    rmin = std::min(rmin, r);
  }
  if (radii.empty()) rmax = rmin = 1;
  const double skin = p.skin > 0 ? p.skin : 0.2 * rmin;
  return 2 * rmax + skin;
}

DemDomain domain_from_decomposition(const halo::Comm& comm, const halo::Decomposition& dec, const DemParams& p) {
  DemDomain d;
  d.comm = &comm;
  d.dec = dec;
  for (std::size_t a = 0; a < 3; ++a) d.dec.periodic[a] = p.periodic[a];
  for (std::size_t a = 0; a < 3; ++a) {
    auto& c = d.cuts[a];
    const int n = dec.dims[a];
    const Grid whole = Grid::whole(dec.global, dec.periodic);
    c.resize(static_cast<std::size_t>(n) + 1);
    for (int i = 0; i < n; ++i) {
      // Piece i's first cell, from the lattice decomposition itself.
      std::array<int, 3> at{0, 0, 0};
      at[a] = i;
      const long off = dec.piece(whole, dec.rank_at(at), 0).offset[a];
      c[static_cast<std::size_t>(i)] =
          p.lo[a] + (p.hi[a] - p.lo[a]) * static_cast<double>(off) / static_cast<double>(dec.global[a]);
    }
    c[0] = p.lo[a];
    c[static_cast<std::size_t>(n)] = p.hi[a];
  }
  return d;
}

DemDomain decompose_box(const halo::Comm& comm, const DemParams& p, const HostParticles& hp,
                        std::array<int, 3> requested, const std::string& key) {
  const double w = ghost_width(p, hp.r);
  std::array<long, 3> cells{};
  for (std::size_t a = 0; a < 3; ++a)
    cells[a] = std::max(1L, static_cast<long>(std::floor((p.hi[a] - p.lo[a]) / w)));
  // A 2D grid (one cell along z) may not be cut along z: give z at least two
  // cells so that a thin box is still a 3D DEM box to halo::decompose.
  cells[2] = std::max(2L, cells[2]);
  const Grid whole = Grid::whole(cells, p.periodic);
  const halo::Decomposition dec = halo::decompose(whole, comm.size(), requested, key);
  return domain_from_decomposition(comm, dec, p);
}

}  // namespace lbdem::dem
