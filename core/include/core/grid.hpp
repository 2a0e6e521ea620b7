#pragma once
// The one description of the lattice a rank works on, read by every module
// (LBM, PSM, DEM coupling, output, the halo exchange).
//
// The global grid has `global` cells per axis; cell (i, j, k) spans
// [i, i+1) x [j, j+1) x [k, k+1) in lattice units, and in metres
// origin + spacing * (i, j, k) is its lower corner. A rank owns the box of
// `local` cells starting at global index `offset`. Axes cut across ranks
// (`split`) carry `ghost` layers on each side of the owned box, filled by the
// halo exchange; storage is x-fastest over owned plus ghost cells. A single
// rank is the one-piece case: offset 0, local = global, no split axis, so
// storage index and global index coincide.
//
// Non-periodic faces are closed by boundary cells (flag > 0) in the owned
// box's outermost layer, so a fluid cell's neighbours always exist in storage.
//
// Coordinates. A position x in lattice units of the global frame lies in the
// storage cell floor(x - shift), shift = offset - ghost on each axis: kernels
// convert particle centres to storage coordinates through GridView::shift and
// never assume the grid starts at 0.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/hd.hpp"

namespace lbdem {

// Extents and offsets a kernel needs (trivially copyable, passed by value).
// 32-bit extents: a rank's box holds fewer than 2^31 cells (checked where a
// solver is made), and 64-bit division costs several times more on a GPU.
struct GridView {
  int nx = 1, ny = 1, nz = 1;   // storage cells per axis (owned + ghost)
  Index nxy = 1, n = 1;
  double shift[3] = {0, 0, 0};  // global lattice coordinate = storage coordinate + shift
  int global[3] = {1, 1, 1};     // cells of the global grid per axis (the period of a periodic axis)
  // The axis wraps onto itself in storage: periodic and owned whole by this
  // rank. On a split axis images come through the ghost layers instead.
  bool periodic[3] = {true, true, true};
  // The global period on a periodic axis cut across ranks (0 elsewhere): a
  // particle seen by this piece is taken at its image nearest the piece.
  double image[3] = {0, 0, 0};

  // Global coordinate x on axis a moved by one period to the image nearest
  // this piece's storage (unchanged on axes without `image`). x may lie up to
  // one period outside the global box (positions are kept wrapped, or nearly).
  LBDEM_HD double nearest_image(int a, double x) const {
    const double L = image[a];
    if (L <= 0) return x;
    const double d = x - (shift[a] + 0.5 * extent(a));
    return d > 0.5 * L ? x - L : (d < -0.5 * L ? x + L : x);
  }

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
  // Storage extent along axis a.
  LBDEM_HD int extent(int a) const { return a == 0 ? nx : (a == 1 ? ny : nz); }
};

// An x storage coordinate known to lie strictly inside the storage along x
// (0 < x < nx - 1), so that its x neighbours are x - 1 and x + 1 with no wrap.
// The host row loop (core/exec.hpp for_each_cell_host) passes it for the
// inner cells of a row; a kernel that takes its x coordinate as a template
// parameter can then address its neighbours at fixed offsets from the cell,
// unit stride across the row, which is what lets the compiler vectorise the
// row. Converts to int, so a kernel taking `int x` sees no difference.
struct InnerX {
  int v;
  LBDEM_HD constexpr operator int() const { return v; }
};

// A box of storage cells [lo, lo + ext) that a kernel iterates over: the
// owned cells, the inner cells (whose update needs no ghost value), or one
// slab of the outer shell. Thread t of a launch over the box takes the t-th
// cell in x-fastest order.
struct CellBox {
  int lo[3] = {0, 0, 0};
  int ext[3] = {0, 0, 0};
  LBDEM_HD Index size() const { return static_cast<Index>(ext[0]) * ext[1] * ext[2]; }
  LBDEM_HD void coords(Index t, int& x, int& y, int& z) const {
    const auto c = static_cast<unsigned>(t);
    const auto sx = static_cast<unsigned>(ext[0]);
    const auto sxy = sx * static_cast<unsigned>(ext[1]);
    const unsigned zz = c / sxy;
    const unsigned r = c - zz * sxy;
    const unsigned yy = r / sx;
    z = static_cast<int>(zz) + lo[2];
    y = static_cast<int>(yy) + lo[1];
    x = static_cast<int>(r - yy * sx) + lo[0];
  }
  bool empty() const { return ext[0] <= 0 || ext[1] <= 0 || ext[2] <= 0; }
};

struct Grid {
  std::array<long, 3> global{1, 1, 1};            // cells of the whole grid per axis
  std::array<long, 3> offset{0, 0, 0};            // global index of this rank's first owned cell
  std::array<long, 3> local{1, 1, 1};             // owned cells per axis
  int ghost = 0;                                  // ghost layers per side on split axes
  std::array<bool, 3> split{false, false, false};  // axes shared with a neighbour rank
  std::array<bool, 3> periodic{true, true, true};  // of the global grid
  std::array<double, 3> origin{0, 0, 0};          // lower corner of global cell (0, 0, 0) [m]
  double spacing = 1;                             // cell size [m] (1 in lattice-unit scenes)

  // The one-piece grid of a single rank.
  static Grid whole(std::array<long, 3> cells, std::array<bool, 3> periodic = {true, true, true});

  int dim() const { return global[2] == 1 ? 2 : 3; }
  int ghost_on(int axis) const { return split[static_cast<std::size_t>(axis)] ? ghost : 0; }
  std::array<long, 3> storage() const;  // owned + ghost cells per axis
  Index cells() const { return static_cast<Index>(local[0]) * local[1] * local[2]; }  // owned
  Index storage_cells() const;
  Index global_cells() const { return static_cast<Index>(global[0]) * global[1] * global[2]; }
  bool whole_grid() const;  // one piece: owns everything, no ghosts

  GridView view() const;
  // The owned cells, in storage coordinates.
  CellBox owned() const;
  // Owned cells at least `width` cells from every split face: their update
  // reads no ghost value, so it can run while the halo is in flight.
  CellBox inner(int width = 1) const;
  // The owned cells that are not inner, as disjoint slabs (empty on one rank).
  std::vector<CellBox> outer(int width = 1) const;

  // Refuses (std::invalid_argument with the reason) extents that cannot hold
  // a lattice: non-positive sizes, a piece outside the global grid, ghosts
  // without a split axis.
  void validate() const;
  std::string describe() const;  // "256 x 256 x 256 (owned 128 x 256 x 256 at 128, 0, 0; ghost 1)"
};

}  // namespace lbdem
