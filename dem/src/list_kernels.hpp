#pragma once
// Cell-list and Verlet-list kernel bodies (NeighbourList): cell keys, cell
// ranges, the list build with its tangential-history hand-over. Include only
// from kernel translation units (*.cu).
#include <cstdint>

#include "atomics.hpp"
#include "cell_grid.hpp"
#include "state.hpp"

namespace lbdem::dem {

// ------------------------------------------------------------------- cell list
// Ghosts (records from n_owned on) go into a second set of cells, `ghost_off`
// keys up: the sort then keeps the owned records first.
struct CellKey {
  const Real4* pos;
  CellGrid g;
  std::uint32_t* key;
  int* idx;
  Index n_owned;
  std::uint32_t ghost_off;
  LBDEM_HD void operator()(Index i) const {
    key[i] = g.cell(pos[i]) + (i >= n_owned ? ghost_off : 0u);
    idx[i] = static_cast<int>(i);
  }
};

// Empties the cells occupied at the previous build (keys still sorted from
// it): O(N) instead of O(cells), which matters for big, sparse boxes.
struct ClearCells {
  const std::uint32_t* old_key;
  int *start, *end;
  LBDEM_HD void operator()(Index i) const {
    const std::uint32_t c = old_key[i];
    start[c] = 0;
    end[c] = 0;
  }
};

// Sorted keys -> [start, end) of each occupied cell.
struct CellRange {
  const std::uint32_t* key;
  int *start, *end;
  Index n;
  LBDEM_HD void operator()(Index i) const {
    const std::uint32_t k = key[i];
    if (i == 0 || key[i - 1] != k) start[k] = static_cast<int>(i);
    if (i == n - 1 || key[i + 1] != k) end[k] = static_cast<int>(i + 1);
  }
};

// Verlet list: every j with |x_j - x_i| < r_i + r_j + skin, scanning the 27
// (fewer on thin periodic axes) surrounding cells. With friction, each slot's
// history is looked up by partner global id in the previous list: in i's own
// old row, else in the partner's old row (negated, the pair path keeps only
// the i<j copy). `Ghosts` (a decomposed run): each cell's ghosts, in cell +
// ghost_off, are scanned after its owned particles (a template flag, so the
// one-rank kernel is the plain one).
template <bool Friction, bool Ghosts>
struct BuildList {
  State s;
  CellGrid g;
  const int *cstart, *cend;
  // Previous list (friction): indexed by the old order.
  const int* perm;
  const int *nbr_prev, *ncount_prev;
  const Vec3d* hist_prev;
  const std::int64_t* gid_prev;
  int have_prev;
  int prev_full;  // 1: both copies valid (particle path); 0: only partner old index > own
  int ghost_off;  // Ghosts: the ghosts of a cell are in cell + ghost_off

  LBDEM_HD Vec3d lookup(Index i, Index j) const {
    const Index oi = perm[i], oj = perm[j];
    const std::int64_t gi = s.gid[i], gj = s.gid[j];
    const int ci = ncount_prev[oi];
    for (int q = 0; q < ci; ++q) {
      const int o = nbr_prev[q * s.n + oi];
      if ((prev_full || o > oi) && gid_prev[o] == gj) return hist_prev[q * s.n + oi];
    }
    const int cj = ncount_prev[oj];
    for (int q = 0; q < cj; ++q) {
      const int o = nbr_prev[q * s.n + oj];
      if ((prev_full || o > oj) && gid_prev[o] == gi) return -hist_prev[q * s.n + oj];
    }
    return Vec3d{};
  }

  LBDEM_HD void operator()(Index i) const {
    // Members into locals: the list stores are ints and would otherwise force
    // reloads of every int member (aliasing) in the inner loop.
    const Real4 pi = s.pos[i];
    const Vec3d xi = xyz(pi);
    const Real4* pos = s.pos;
    int* nbr = s.nbr;
    const Index n = s.n;
    const int cap = s.cap;
    const double skin = s.skin;
    const Box box = s.box;
    const int nc0 = g.nc[0], nc1 = g.nc[1], nc2 = g.nc[2];
    const int c[3] = {g.coord(pi.x, 0), g.coord(pi.y, 1), g.coord(pi.z, 2)};
    int lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      if (g.periodic[k] && g.nc[k] < 3) { lo[k] = 0; hi[k] = g.nc[k] - 1; }
      else { lo[k] = -1; hi[k] = 1; }
    }
    // Neighbour cell coordinate: wrapped on periodic axes (one compare: the
    // offset is at most one cell), -1 when outside a closed axis.
    auto wrap = [](int x, int nc, int per) {
      if (x < 0) return per ? x + nc : -1;
      if (x >= nc) return per ? x - nc : -1;
      return x;
    };
    int cnt = 0;
    for (int dz = lo[2]; dz <= hi[2]; ++dz) {
      const int cz = wrap(c[2] + dz, nc2, g.periodic[2]);
      if (cz < 0) continue;
      for (int dy = lo[1]; dy <= hi[1]; ++dy) {
        const int cy = wrap(c[1] + dy, nc1, g.periodic[1]);
        if (cy < 0) continue;
        const int row = nc0 * (cy + nc1 * cz);
        for (int dx = lo[0]; dx <= hi[0]; ++dx) {
          const int cx = wrap(c[0] + dx, nc0, g.periodic[0]);
          if (cx < 0) continue;
          // Owned particles of the cell, then (decomposed run) its ghosts.
          for (int cell = cx + row, pass = 0; pass < (Ghosts ? 2 : 1); ++pass, cell += ghost_off) {
            const int e = cend[cell];
            for (int j = cstart[cell]; j < e; ++j) {
              if (j == i) continue;
              const Real4 pj = pos[j];
              const Vec3d d = box.min_image(xyz(pj) - xi);
              const double rc = pi.w + pj.w + skin;
              if (dot(d, d) < rc * rc) {
                if (cnt < cap) {
                  nbr[cnt * n + i] = j;
                  if constexpr (Friction) s.hist[cnt * n + i] = have_prev ? lookup(i, j) : Vec3d{};
                }
                ++cnt;
              }
            }
          }
        }
      }
    }
    s.ncount[i] = cnt < cap ? cnt : cap;
    if (cnt > cap) {
      detail::atomic_set(&s.flags[0], 1);
      detail::atomic_max(&s.flags[1], cnt);
    }
    s.x0[i] = pi;
  }
};

// Sorts each row of the Verlet list by the partners' global ids (insertion
// sort: rows are short), moving the tangential histories along, so that the
// force loop sums a particle's contacts in global-id order whatever the
// storage order and the decomposition (DemParams::contact_order).
template <bool Friction>
struct SortRows {
  State s;
  LBDEM_HD void operator()(Index i) const {
    const Index n = s.n;
    const int cnt = s.ncount[i];
    for (int a = 1; a < cnt; ++a) {
      const int j = s.nbr[a * n + i];
      const std::int64_t g = s.gid[j];
      Vec3d h{};
      if constexpr (Friction) h = s.hist[a * n + i];
      int b = a - 1;
      while (b >= 0 && s.gid[s.nbr[b * n + i]] > g) {
        s.nbr[(b + 1) * n + i] = s.nbr[b * n + i];
        if constexpr (Friction) s.hist[(b + 1) * n + i] = s.hist[b * n + i];
        --b;
      }
      s.nbr[(b + 1) * n + i] = j;
      if constexpr (Friction) s.hist[(b + 1) * n + i] = h;
    }
  }
};

}  // namespace lbdem::dem
