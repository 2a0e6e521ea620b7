#pragma once
// Particle → tile candidate lists for the fused PSM pipeline (imb/psm_fused.hpp).
//
// The grid is cut into tiles of TX × TY × TZ cells (3D 32 × 4 × 2, 2D 32 × 8:
// 256 cells, one CUDA block each; the x extent of 32 keeps every warp on one
// row, so population loads stay coalesced). Every step, each particle enters
// the tiles its bounding box [floor(c − R), floor(c + R)] touches (the cells
// the slot map would visit), with an atomic slot in the tile's list of
// `capacity` candidates. The fused kernel reads its tile's list once into
// shared memory, evaluates the solid fraction of each of its cells against the
// candidates (the K-slot limit applied per cell, in particle-index order), and
// sums the force on each candidate over the block in a fixed order into the
// particle's entry for that tile. finish() adds each particle's entries in a
// fixed order: the result does not depend on atomic order, so it is
// deterministic, and host and device add in the same order.
//
// Why: the slot map of the mapped pipeline writes (particle, ε, velocity) for
// every overlapped cell and its PSM kernel reads them back through a count →
// slot chain, a pass over memory comparable to a fluid step; a tile list holds
// a few entries per tile.
//
// Periodic axes: a cell takes the minimum image of each candidate; a particle
// spans less than half a period (checked), so no cell sees two images.
// Non-periodic axes: tiles beyond the grid are skipped.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/buffer.hpp"
#include "core/exec.hpp"
#include "core/memory_use.hpp"
#include "imb/cell_slots.hpp"
#include "imb/particle_view.hpp"

namespace lbdem::imb {

// Slots per cell the fused kernel keeps in registers (a case may ask for fewer).
inline constexpr int kFusedMaxSlots = 4;
// Cells of a 3D tile along z (32 x 4 x kFusedTileZ cells, one CUDA block of
// 256 threads each). The tile map and the fused kernel both take the shape
// from TileShape::for_dim.
inline constexpr int kFusedTileZ = 2;
// Largest candidate list per tile the fused kernel's shared memory holds.
inline constexpr int kFusedMaxCapacity = 128;

struct TileShape {
  int tx = 32, ty = 4, tz = 2;
  LBDEM_HD static constexpr TileShape for_dim(int dim) {
    return dim == 3 ? TileShape{32, 4, kFusedTileZ} : TileShape{32, 8, 1};
  }
  LBDEM_HD constexpr int cells() const { return tx * ty * tz; }
};

// What the fused kernel and finish() read (trivially copyable).
struct TileView {
  GridView g;                     // the lattice's storage (core/grid.hpp): extents, wrap, shift
  TileShape t;
  int ntx = 1, nty = 1, ntz = 1;  // tiles per axis
  int capacity = 0;
  int max_tiles = 0;              // entries per particle (tiles its box can touch)
  const int* count = nullptr;     // per tile: candidates that wanted in (> capacity: overflow)
  const int* particle = nullptr;  // [tile * capacity + i]
  const int* entry = nullptr;     // [tile * capacity + i]: particle * max_tiles + its tile number
  double* partial = nullptr;      // [entry * 6 + a]: force (0..2) and torque (3..5) from that tile
  // Overflow of the K slots of a cell (written by the fused kernel):
  // flags[0] surplus (cell, particle) pairs, flags[1] tile list overflows.
  int* flags = nullptr;
  Index* log_cell = nullptr;
  int* log_particle = nullptr;
  int log_cap = 0;
  LBDEM_HD Index tiles() const { return static_cast<Index>(ntx) * nty * ntz; }
};

struct ForceOut;  // imb/psm_coupling.hpp

class TileMap {
 public:
  // capacity: candidates per tile (<= kFusedMaxCapacity); K: slots per cell (<= kFusedMaxSlots).
  // Tiles over the storage cells of `grid` (core/grid.hpp); particle centres
  // are in the grid's global lattice frame.
  TileMap(Backend b, const Grid& grid, int K, int capacity = 64, int overflow_log = 1024);

  // Rebuilds the candidate lists from the particles (asynchronous on the device).
  // max_radius <= 0 computes it (a synchronous reduction).
  void build(const Exec& ex, const SphereView& p, double max_radius);
  // Sums each particle's tile entries (fixed order) into out (plus buoyancy).
  void finish(const Exec& ex, const SphereView& p, const ForceOut& out) const;

  TileView view() const;
  int K() const { return K_; }
  int capacity() const { return capacity_; }
  const Grid& grid() const { return grid_; }
  Backend backend() const { return backend_; }

  // Total solid fraction Σ ε of the cells of `box` (storage coordinates) at
  // the positions of the last build(), into `out` (backend memory, box.size()
  // values, box x-fastest): the values the slot map's total_eps gives
  // (particle-index order, first K), for output without per-cell slots.
  // table_values: the table on the backend (method table). Asynchronous.
  void total_eps(const Exec& ex, const SphereView& p, FractionMethod method, const FractionTable* table,
                 const float* table_values, bool linear_normalised, const CellBox& box, double* out) const;
  // Bytes of each buffer held, by component (psm_memory()).
  MemoryUse memory_use() const;

  // Synchronises and reads the overflow counters: K slots of a cell (found by
  // the fused kernel) or a tile's candidate list (found by build).
  OverflowReport overflow() const;
  void clear_overflow(const Exec& ex);

 private:
  Backend backend_;
  Grid grid_;
  GridView gv_;
  TileShape shape_;
  int K_, capacity_, log_cap_;
  int ntx_ = 1, nty_ = 1, ntz_ = 1;
  int max_tiles_ = 0;
  int axis_max_[3] = {1, 1, 1};
  Buffer<int> count_, particle_, entry_;
  Buffer<double> partial_;
  Buffer<int> flags_;  // [0] cell slot surplus, [1] tile surplus, [2] radius too large, [3] its particle
  Buffer<Index> log_cell_;
  Buffer<int> log_particle_;
  Buffer<Index> log_tile_;
  Buffer<int> log_tile_particle_;
  std::shared_ptr<Scratch> scratch_;
  Index built_particles_ = 0;
};

}  // namespace lbdem::imb
