#pragma once
// Packing populations for the halo exchange (see halo/README.md for the rules
// and lbm/halo_exchange.hpp for who calls this).
//
// A HaloBlock names a box of storage cells and the population slots that cross
// one face (or edge) of the rank's piece; pack copies those slots of the box's
// cells into a contiguous buffer (slot-major, cells x-fastest), unpack copies
// them back into the same slots of another box of the same shape. The buffer
// holds the stored (shifted) values in the storage precision.
#include <cstdint>

#include "core/grid.hpp"
#include "core/hd.hpp"
#include "lbm/grid.hpp"
#include "lbm/kernels.hpp"

namespace lbdem::lbm {

// Most slots one face carries (D3Q19: 5; D2Q9: 3).
inline constexpr int kMaxHaloSlots = 5;

enum class HaloUnpack : std::uint8_t {
  Ghost,      // write a cell only if it is a ghost cell (a copy of another rank's fluid cell)
  WriteBack,  // A-A after an odd step: write slot s of owned fluid cell I only if its writer,
              // I - c_s, is a ghost cell inside the sending rank's region (`from`)
};

struct HaloBlock {
  CellBox box;
  int slots = 0;
  int q[kMaxHaloSlots] = {};
  int c[kMaxHaloSlots][3] = {};   // velocity of each slot (WriteBack mask)
  bool second = false;            // the two-lattice scheme's destination array (else the incoming one)
  HaloUnpack mode = HaloUnpack::Ghost;
  // WriteBack: the receiving rank's region where the sender's cells are ghosts:
  // per axis -1 / +1 (the ghost layer on that side) or 0 (the owned range).
  int from[3] = {0, 0, 0};
  CellBox owned;                  // receiving rank's owned box (storage coordinates)
  Index bytes(int tsize) const { return box.size() * slots * tsize; }
};

template <class T>
struct HaloPackKernel {
  PopView<T> f;
  HaloBlock b;
  GridView g;
  T* buf;
  LBDEM_HD void operator()(Index t) const {
    int x, y, z;
    b.box.coords(t, x, y, z);
    const Index cell = g.index(x, y, z);
    const Index n = b.box.size();
    for (int s = 0; s < b.slots; ++s) buf[s * n + t] = f.f[b.q[s] * f.stride + cell];
  }
};

template <class T>
struct HaloUnpackKernel {
  PopView<T> f;
  HaloBlock b;
  GridView g;
  const std::uint8_t* flags;
  const T* buf;

  // Is storage cell (x, y, z) - c inside the sender's region and a ghost copy of its fluid?
  LBDEM_HD bool written_by_sender(int x, int y, int z, const int* c) const {
    int p[3] = {x - c[0], y - c[1], z - c[2]};
    const int ext[3] = {g.nx, g.ny, g.nz};
    for (int a = 0; a < 3; ++a) {
      // Axes this rank owns whole wrap in storage (periodic) or end in walls.
      if (g.periodic[a]) p[a] = p[a] < 0 ? p[a] + ext[a] : (p[a] >= ext[a] ? p[a] - ext[a] : p[a]);
      if (p[a] < 0 || p[a] >= ext[a]) return false;
      const int lo = b.owned.lo[a], hi = b.owned.lo[a] + b.owned.ext[a];
      const int side = p[a] < lo ? -1 : (p[a] >= hi ? 1 : 0);
      if (side != b.from[a]) return false;
    }
    return flags[g.index(p[0], p[1], p[2])] == kGhostFlag;
  }

  LBDEM_HD void operator()(Index t) const {
    int x, y, z;
    b.box.coords(t, x, y, z);
    const Index cell = g.index(x, y, z);
    const Index n = b.box.size();
    if (b.mode == HaloUnpack::Ghost) {
      if (flags[cell] != kGhostFlag) return;
      for (int s = 0; s < b.slots; ++s) f.f[b.q[s] * f.stride + cell] = buf[s * n + t];
    } else {
      if (flags[cell] != 0) return;
      for (int s = 0; s < b.slots; ++s)
        if (written_by_sender(x, y, z, b.c[s])) f.f[b.q[s] * f.stride + cell] = buf[s * n + t];
    }
  }
};

}  // namespace lbdem::lbm
