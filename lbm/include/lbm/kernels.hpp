#pragma once
// Per-cell kernel bodies: fused stream-collide with two storage policies,
// initialisation, macroscopic fields and diagnostics. One body serves the CUDA
// and the OpenMP backend (core/exec.hpp).
//
// Storage: structure of arrays, population q of cell i at f[q*stride + i],
// shifted by -w_q (see collision.hpp), in the storage type T (float, double or
// a 16-bit format, lbm/storage.hpp); loads convert to the compute type R and
// stores round back to T (static_cast both ways).
//
// Streaming policies. "Incoming populations at x" are the f_q(x, t) a
// collision starts from.
//  * TwoLattice (pull): arrays hold post-collision values; the step reads
//    src[q][x - c_q] and writes dst[q][x]. Reference scheme, 2x memory.
//  * AA (Bailey et al. 2009), in place, one array:
//      even step: read A[q][x],            write f*_q to A[qbar][x];
//      odd step:  read A[qbar][x - c_q],   write f*_q to A[q][x + c_q].
//    Each step touches only the slots it reads, so no second array is needed.
// Boundaries are applied on the store: if x + c_q is a boundary cell b (flag
// 1..kMaxBoundaries; ghost cells are streamed into like fluid), the
// reflected value goes where x reads its qbar population next step
// (TwoLattice: dst[qbar][b]; AA even: A[q][b]; AA odd: A[qbar][x]); each slot
// has exactly one writer, so loads never branch.
#include <cmath>
#include <cstdint>

#include "core/hd.hpp"
#include "lbm/boundary.hpp"
#include "lbm/collision.hpp"
#include "lbm/grid.hpp"
#include "lbm/lattice.hpp"
#include "lbm/storage.hpp"

namespace lbdem::lbm {

enum class StreamKind { AA, TwoLattice };

// Neighbour offsets of one cell, wrapping at the ends of storage.
// The wrap only ever applies to the outermost storage layer: on a periodic
// axis owned whole by this rank that is the periodic image; on a walled axis
// the outermost layer is boundary cells and on a split axis it is ghost
// cells, neither of which a step updates, so an owned cell never reads or
// writes across a wrap there. 32-bit offsets (fewer than 2^31 cells per rank);
// widened only when added to the 64-bit slab offset q*stride.
struct Neighbours {
  unsigned ox[3], oy[3], oz[3];
  LBDEM_HD Index at(int cx, int cy, int cz) const { return static_cast<Index>(ox[cx + 1] + oy[cy + 1] + oz[cz + 1]); }
};

// From the cell's coordinates (callers that have them skip two divisions).
template <class L>
LBDEM_HD LBDEM_FORCEINLINE Neighbours neighbours_at(const GridView& g, int x, int y, int z) {
  Neighbours nb;
  nb.ox[0] = static_cast<unsigned>(x == 0 ? g.nx - 1 : x - 1);
  nb.ox[1] = static_cast<unsigned>(x);
  nb.ox[2] = static_cast<unsigned>(x == g.nx - 1 ? 0 : x + 1);
  const auto nx = static_cast<unsigned>(g.nx), nxy = static_cast<unsigned>(g.nxy);
  nb.oy[0] = static_cast<unsigned>(y == 0 ? g.ny - 1 : y - 1) * nx;
  nb.oy[1] = static_cast<unsigned>(y) * nx;
  nb.oy[2] = static_cast<unsigned>(y == g.ny - 1 ? 0 : y + 1) * nx;
  if constexpr (L::D == 3) {
    nb.oz[0] = static_cast<unsigned>(z == 0 ? g.nz - 1 : z - 1) * nxy;
    nb.oz[1] = static_cast<unsigned>(z) * nxy;
    nb.oz[2] = static_cast<unsigned>(z == g.nz - 1 ? 0 : z + 1) * nxy;
  } else {
    nb.oz[0] = nb.oz[1] = nb.oz[2] = static_cast<unsigned>(z) * nxy;
  }
  return nb;
}

// Neighbour indices of a cell off the storage's x ends (InnerX, core/grid.hpp,
// from the host row loop): the cell plus fixed offsets, x +- 1 along x and the
// wrapped rows along y and z, in 64-bit signed arithmetic. Across a row these
// are unit-stride addresses, which the vectoriser needs (the 32-bit unsigned
// offsets of Neighbours may wrap, so their addresses do not advance linearly
// in the compiler's analysis). The same indices as Neighbours gives.
struct InnerNeighbours {
  Index cell;
  Index oy[3], oz[3];  // offsets of the neighbour rows along y and z from the cell's row
  LBDEM_HD Index at(int cx, int cy, int cz) const { return cell + cx + oy[cy + 1] + oz[cz + 1]; }
};

template <class L>
LBDEM_HD LBDEM_FORCEINLINE InnerNeighbours neighbours_at(const GridView& g, InnerX x, int y, int z) {
  InnerNeighbours nb;
  nb.cell = g.index(x.v, y, z);
  const Index nx = g.nx;
  nb.oy[0] = (y == 0 ? g.ny - 1 : -1) * nx;
  nb.oy[1] = 0;
  nb.oy[2] = (y == g.ny - 1 ? 1 - g.ny : 1) * nx;
  if constexpr (L::D == 3) {
    nb.oz[0] = (z == 0 ? g.nz - 1 : -1) * g.nxy;
    nb.oz[1] = 0;
    nb.oz[2] = (z == g.nz - 1 ? 1 - g.nz : 1) * g.nxy;
  } else {
    nb.oz[0] = nb.oz[1] = nb.oz[2] = 0;
  }
  return nb;
}

template <class L>
LBDEM_HD LBDEM_FORCEINLINE Neighbours neighbours(const GridView& g, Index cell) {
  int x, y, z;
  g.coords(cell, x, y, z);
  return neighbours_at<L>(g, x, y, z);
}

template <class T>
struct PopView {
  T* f = nullptr;
  Index stride = 0;  // slab size per direction (cells rounded up)
};

// Zeroth and first moments of shifted populations: density deviation
// d = sum f and momentum j = sum c f (no forcing shift).
template <class L, class R>
LBDEM_HD LBDEM_FORCEINLINE void moments(const R (&f)[L::Q], R& d, R (&j)[3]) {
  d = 0;
  j[0] = j[1] = j[2] = 0;
  LBDEM_UNROLL
  for (int q = 0; q < L::Q; ++q) {
    d += f[q];
    // c is a compile-time constant once unrolled: add or subtract, and skip
    // the zero components (IEEE rules forbid the compiler to drop 0 * f).
    LBDEM_UNROLL
    for (int a = 0; a < 3; ++a)
      if (L::c(q, a) != 0) j[a] += L::c(q, a) > 0 ? f[q] : -f[q];
  }
}

// Loads the incoming (pre-collision) shifted populations of cell `cell`.
// NB: Neighbours or InnerNeighbours.
template <class L, class T, class R, StreamKind S, int Parity, class NB>
LBDEM_HD LBDEM_FORCEINLINE void load_incoming(const PopView<T>& src, const NB& nb, Index cell,
                                              R (&f)[L::Q]) {
  LBDEM_UNROLL
  for (int q = 0; q < L::Q; ++q) {
    if constexpr (S == StreamKind::AA && Parity == 0) {
      f[q] = static_cast<R>(src.f[q * src.stride + cell]);
    } else if constexpr (S == StreamKind::AA) {
      f[q] = static_cast<R>(src.f[L::opp(q) * src.stride + nb.at(-L::c(q, 0), -L::c(q, 1), -L::c(q, 2))]);
    } else {
      f[q] = static_cast<R>(src.f[q * src.stride + nb.at(-L::c(q, 0), -L::c(q, 1), -L::c(q, 2))]);
    }
  }
}

// Reflected population for direction qbar at a fluid cell whose outgoing f*_q
// hits boundary entry `id` (shifted storage: g = f - w).
template <class L, class R>
LBDEM_HD LBDEM_FORCEINLINE R reflect(int q, R fq, const BoundaryTable& bt, int id, const R (&u)[3]) {
  const R w = R(L::w(q));
  switch (bt.kind[id]) {
    case BoundaryKind::Velocity: {
      const R cu = R(L::c(q, 0)) * R(bt.u[id][0]) + R(L::c(q, 1)) * R(bt.u[id][1]) + R(L::c(q, 2)) * R(bt.u[id][2]);
      return fq - R(6) * w * R(bt.rho[id]) * cu;
    }
    case BoundaryKind::Pressure: {
      const R cu = R(L::c(q, 0)) * u[0] + R(L::c(q, 1)) * u[1] + R(L::c(q, 2)) * u[2];
      const R usq = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
      return -fq - R(2) * w + R(2) * w * R(bt.rho[id]) * (R(1) + R(4.5) * cu * cu - R(1.5) * usq);
    }
    default:
      return fq;
  }
}

// Stores post-collision populations according to the policy, with boundaries.
template <class L, class T, class R, StreamKind S, int Parity, bool Bnd, class NB>
LBDEM_HD LBDEM_FORCEINLINE void store_outgoing(const PopView<T>& dst, const NB& nb, Index cell,
                                               const R (&f)[L::Q], const std::uint8_t* flags,
                                               const BoundaryTable& bt, const R (&u)[3]) {
  LBDEM_UNROLL
  for (int q = 0; q < L::Q; ++q) {
    const int qb = L::opp(q);
    const Index t = nb.at(L::c(q, 0), L::c(q, 1), L::c(q, 2));
    if constexpr (Bnd) {
      const int fl = flags[t];
      if (reflects(fl)) {
        const T r = static_cast<T>(reflect<L, R>(q, f[q], bt, fl - 1, u));
        if constexpr (S == StreamKind::TwoLattice) dst.f[qb * dst.stride + t] = r;
        else if constexpr (Parity == 0) dst.f[q * dst.stride + t] = r;
        else dst.f[qb * dst.stride + cell] = r;
        continue;
      }
    }
    if constexpr (S == StreamKind::TwoLattice) dst.f[q * dst.stride + cell] = static_cast<T>(f[q]);
    else if constexpr (Parity == 0) dst.f[qb * dst.stride + cell] = static_cast<T>(f[q]);
    else dst.f[q * dst.stride + t] = static_cast<T>(f[q]);
  }
}

// One fused stream-collide step for one cell.
template <class L, class T, StreamKind S, int Parity, bool Bnd, bool Force>
struct StepKernel {
  using R = compute_t<T>;  // fp32/fp64: the storage precision; 16-bit storage: float
  PopView<T> src, dst;  // AA: src == dst
  GridView g;
  const std::uint8_t* flags;
  BoundaryTable bt;
  Collider<L, R, Force> coll;

  // Cell `cell` at storage coordinates (x, y, z) (core/exec.hpp for_each_cell);
  // X is int, or InnerX for the inner cells of a host row (unit-stride
  // neighbours). Always inlined: in the host row loop it then vectorises across x.
  template <class X>
  LBDEM_HD LBDEM_FORCEINLINE void operator()(Index cell, X x, int y, int z) const {
    if constexpr (Bnd) {
      if (flags[cell] != 0) return;
    }
    const auto nb = neighbours_at<L>(g, x, y, z);
    R f[L::Q];
    load_incoming<L, T, R, S, Parity>(src, nb, cell, f);
    R drho, u[3];
    coll(f, drho, u);
    store_outgoing<L, T, R, S, Parity, Bnd>(dst, nb, cell, f, flags, bt, u);
  }
};

// Writes equilibrium populations so that the incoming populations at every
// cell are f^eq(rho(x), u(x)) for the first step (any policy, any parity 0).
template <class L, class T, StreamKind S>
struct InitKernel {
  PopView<T> dst;
  GridView g;
  // rho (lattice units) and u (3 per cell) of the cells of `box` (storage
  // coordinates), box x-fastest: a slab of the grid at a time.
  CellBox box;
  const double* rho;
  const double* u;
  LBDEM_HD void operator()(Index cell, int x, int y, int z) const {
    const Neighbours nb = neighbours<L>(g, cell);
    const Index o = (x - box.lo[0]) + static_cast<Index>(box.ext[0]) * ((y - box.lo[1]) + static_cast<Index>(box.ext[1]) * (z - box.lo[2]));
    const double r = rho[o];
    const double ux = u[3 * o], uy = u[3 * o + 1], uz = u[3 * o + 2];
    const double usq = ux * ux + uy * uy + uz * uz;
    LBDEM_UNROLL
    for (int q = 0; q < L::Q; ++q) {
      const double cu = L::c(q, 0) * ux + L::c(q, 1) * uy + L::c(q, 2) * uz;
      const double geq = L::w(q) * ((r - 1.0) + r * (3.0 * cu + 4.5 * cu * cu - 1.5 * usq));
      if constexpr (S == StreamKind::AA) {
        dst.f[q * dst.stride + cell] = static_cast<T>(geq);
      } else {
        dst.f[q * dst.stride + nb.at(-L::c(q, 0), -L::c(q, 1), -L::c(q, 2))] = static_cast<T>(geq);
      }
    }
  }
};

// Density and velocity (lattice units, with the F/2 shift) of every cell from
// its incoming populations; boundary cells get rho = 0, u = 0... unless asked.
template <class L, class T, StreamKind S, int Parity>
struct MacroKernel {
  PopView<T> src;
  GridView g;
  const std::uint8_t* flags;  // may be null
  double F[3];
  // Outputs for the cells of `box` (storage coordinates), box x-fastest: a
  // slab of the grid at a time through a small staging buffer.
  CellBox box;
  double* rho;
  double* u;
  LBDEM_HD void operator()(Index cell, int x, int y, int z) const {
    const Index o = (x - box.lo[0]) + static_cast<Index>(box.ext[0]) * ((y - box.lo[1]) + static_cast<Index>(box.ext[1]) * (z - box.lo[2]));
    if (flags && flags[cell] != 0) {
      rho[o] = 0;
      u[3 * o] = u[3 * o + 1] = u[3 * o + 2] = 0;
      return;
    }
    const Neighbours nb = neighbours_at<L>(g, x, y, z);
    double f[L::Q];
    load_incoming<L, T, double, S, Parity>(src, nb, cell, f);
    double d, j[3];
    moments<L>(f, d, j);
    const double r = 1.0 + d;
    rho[o] = r;
    for (int a = 0; a < 3; ++a) u[3 * o + a] = (j[a] + 0.5 * F[a]) / r;
  }
};

// Sums and extremes over fluid cells, for the watchdog and conservation checks.
struct Diag {
  double mass_dev = 0;   // sum of (rho - 1)
  double mom[3] = {0, 0, 0};  // sum of c f (no F/2 shift)
  double u2max = 0;      // max |u|^2
  Index u2max_cell = -1;
  Index nan_cell = -1;   // first non-finite cell seen (lowest index)
  Index fluid_cells = 0;
};
struct DiagOp {
  LBDEM_HD Diag operator()(const Diag& a, const Diag& b) const {
    Diag r;
    r.mass_dev = a.mass_dev + b.mass_dev;
    for (int k = 0; k < 3; ++k) r.mom[k] = a.mom[k] + b.mom[k];
    if (b.u2max > a.u2max || (b.u2max == a.u2max && b.u2max_cell >= 0 && (a.u2max_cell < 0 || b.u2max_cell < a.u2max_cell))) {
      r.u2max = b.u2max;
      r.u2max_cell = b.u2max_cell;
    } else {
      r.u2max = a.u2max;
      r.u2max_cell = a.u2max_cell;
    }
    if (a.nan_cell < 0) r.nan_cell = b.nan_cell;
    else if (b.nan_cell < 0) r.nan_cell = a.nan_cell;
    else r.nan_cell = a.nan_cell < b.nan_cell ? a.nan_cell : b.nan_cell;
    r.fluid_cells = a.fluid_cells + b.fluid_cells;
    return r;
  }
};
template <class L, class T, StreamKind S, int Parity>
struct DiagKernel {
  PopView<T> src;
  GridView g;
  const std::uint8_t* flags;  // may be null
  double F[3];
  LBDEM_HD Diag operator()(Index cell, int x, int y, int z) const {
    Diag r;
    if (flags && flags[cell] != 0) return r;
    const Neighbours nb = neighbours_at<L>(g, x, y, z);
    double f[L::Q];
    load_incoming<L, T, double, S, Parity>(src, nb, cell, f);
    double d, j[3];
    moments<L>(f, d, j);
    const double rr = 1.0 + d;
    double u2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double ua = (j[a] + 0.5 * F[a]) / rr;
      u2 += ua * ua;
    }
    r.mass_dev = d;
    for (int a = 0; a < 3; ++a) r.mom[a] = j[a];
    r.fluid_cells = 1;
    if (!(u2 == u2) || !(d == d) || u2 > 1e300 || !(rr > 0)) {
      r.nan_cell = cell;
    } else {
      r.u2max = u2;
      r.u2max_cell = cell;
    }
    return r;
  }
};

}  // namespace lbdem::lbm
