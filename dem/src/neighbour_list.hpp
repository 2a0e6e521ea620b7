#pragma once
// Neighbour search of a DemSystem: the cell list (particles sorted by cell),
// the Verlet list built from it with the tangential histories carried over by
// partner id, and the buffers of the pair path's count -> scan -> fill.
#include <cstdint>
#include <vector>

#include "core/buffer.hpp"
#include "core/checkpoint.hpp"
#include "core/exec.hpp"
#include "dem/geometry.hpp"
#include "cell_grid.hpp"
#include "state.hpp"

namespace lbdem {
struct Scratch;  // core/algorithms.hpp
}

namespace lbdem::dem {

class ParticleStore;

class NeighbourList {
 public:
  // The cell grid for particles of radii r in the box: cells at least the
  // largest cutoff 2 r_max + skin wide, their count bounded for big sparse
  // boxes. Sets the skin (0: 0.2 r_min). Throws ConfigError for a radius <= 0
  // or a periodic length below twice the cutoff.
  void set_geometry(const Box& box, const std::vector<double>& r, double skin_param);
  // Allocates the cell list and the counters for n particles; `history`:
  // tangential histories carried across builds; `pair_path`: keep the
  // compacted pair array of the pair path. `capacity`: list slots per particle.
  // `ghost_cells`: a decomposed run's store holds ghosts behind the owned
  // records; they are sorted into a second set of cells (keys offset by the
  // cell count) so that the cell sort keeps the owned records first. The
  // counters are zeroed on ex's queue, before the builds that use them.
  void allocate(const Exec& ex, Index n, bool history, bool pair_path, int capacity, bool ghost_cells = false);
  // A decomposed run: the arrays for a store of n records (owned and ghosts),
  // grown where needed before a build.
  void resize(Backend be, Index n);
  // A decomposed run: the previous list in the store's current order, from
  // rows that travelled with migrating particles (count[i] slots of particle
  // i at [q * n + i]: partner index and tangential history). The next build
  // looks the histories up in it as in its own previous list.
  void load_previous(Backend be, const std::vector<int>& count, const std::vector<int>& nbr,
                     const std::vector<Vec3d>& hist, int cap_prev);
  // The list of the last build is in place (fit_capacity drops it).
  bool has_list() const { return have_list; }
  // Sorts the particles by cell, reorders the store into cell order, and
  // builds the Verlet list, growing the capacity on overflow (the one
  // blocking read of a build). `physics`: the set-up constants of the kernel
  // view (the particle and list arrays are bound here, after the reorder).
  // Rows are built for the owned particles only (ghosts are partners).
  void rebuild(const Exec& ex, ParticleStore& store, const State& physics, Scratch& scratch);
  // Lowers the capacity to what the last build needed (x1.5 + 8, rounded to
  // 8) if that is smaller, releasing the list storage: returns true when it
  // did (the caller rebuilds).
  bool fit_capacity(const Exec& ex, Scratch& scratch);
  // The list arrays of the kernel view.
  void bind(State& s) const;
  // Checkpoint state: the list of the last build (rows, capacity, partners,
  // tangential histories) and its flags (dem/src/system_state.cpp).
  void save_state(ckpt::Sink& out) const;
  void load_state(ckpt::Source& in, Backend be);

  CellGrid grid{};
  double skin = 0;  // Verlet skin [m]: the list holds pairs closer than r_i + r_j + skin
  double cutoff = 0;  // the largest of those distances, 2 r_max + skin [m]
  int cap = 0;      // list slots per particle
  Index n = 0;     // records (owned and ghosts): the column stride of the list
  Index rows = 0;  // particles with a list row (the owned ones at the last build)
  bool history = false, pair_path = false;
  // Each row sorted by the partners' global ids after the build, so that a
  // particle sums its contacts in an order independent of storage order (and
  // of the decomposition): DemParams::contact_order.
  bool gid_order = false;
  int ghost_off = 0;  // cell-key offset of ghosts (0: no ghosts)

  // Verlet list, column-major: slot s of particle i at [s * n + i].
  Buffer<int> nbr, ncount;
  Buffer<Vec3d> hist;  // tangential history per slot (friction)
  // Pair path: contacts per particle -> exclusive scan -> compacted pairs.
  Buffer<int> ccount, coffs;
  Buffer<PairIJ> pairs;

 private:
  void allocate_lists(Backend be);
  // Cell list.
  Buffer<std::uint32_t> key, key_sorted;
  Buffer<int> idx, perm;  // perm[new] = old index of the last build
  Buffer<int> cell_start, cell_end;
  bool have_cells = false;  // key_sorted holds the previous build's keys
  // The previous list (friction), for the history hand-over.
  Buffer<int> nbr_prev, ncount_prev;
  Buffer<Vec3d> hist_prev;
  bool have_prev = false;
  bool prev_loaded = false;  // load_previous() filled the previous list for the next build
  bool have_list = false;
  // flags[0] list overflow, [1] largest neighbour count seen (read at each build).
  Buffer<int> flags;
};

}  // namespace lbdem::dem
