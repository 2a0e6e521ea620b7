#pragma once
// Domain box with per-axis periodicity, and plane walls. Host/device.
#include <cmath>

#include "core/hd.hpp"
#include "core/vec.hpp"

namespace lbdem::dem {

// Axis-aligned domain [lo, lo+len). Periodic axes wrap positions and use the
// minimum-image convention (valid while every cutoff is < len/2, checked at
// set-up); non-periodic axes only bound the cell grid (particles outside are
// clamped into the edge cells, which keeps the neighbour search exact).
struct Box {
  double lo[3] = {0, 0, 0};
  double len[3] = {1, 1, 1};
  int periodic[3] = {0, 0, 0};

  // Positions are kept wrapped, so |d| < len on periodic axes and one
  // compare-and-shift gives the nearest image (cheaper than rint(d/len)).
  LBDEM_HD Vec3d min_image(Vec3d d) const {
    for (int k = 0; k < 3; ++k) {
      if (!periodic[k]) continue;
      const double h = 0.5 * len[k];
      if (d[k] > h) d[k] -= len[k];
      else if (d[k] < -h) d[k] += len[k];
    }
    return d;
  }
  // Maps a position back into [lo, lo+len) on periodic axes (a particle moves
  // far less than a box length per step).
  LBDEM_HD Vec3d wrap(Vec3d x) const {
    for (int k = 0; k < 3; ++k) {
      if (!periodic[k]) continue;
      const double hi = lo[k] + len[k];
      if (x[k] >= hi) x[k] -= len[k];
      if (x[k] < lo[k]) x[k] += len[k];
      if (x[k] >= hi) x[k] = lo[k];  // -tiny + len rounded up to hi
    }
    return x;
  }
};

// Plane wall through `point` with unit `normal` pointing into the domain.
struct Wall {
  Vec3d point;
  Vec3d normal;
};
constexpr int kMaxWalls = 8;
struct Walls {
  Wall w[kMaxWalls];
  int count = 0;
};

}  // namespace lbdem::dem
