#pragma once
// Particle → cell mapping for PSM: for every lattice cell, up to K (particle
// index, solid fraction ε) slots. Filled every step on the backend where the
// particles live; nothing is allocated per step and nothing comes back to the
// host unless overflow() is asked.
//
// Grid convention (see solid_fraction.hpp): cell (i, j, k) covers
// [i, i+1)×[j, j+1)×[k, k+1) in lattice units, linear index i + nx (j + ny k).
// Particles may sit anywhere; on periodic axes every image is mapped (a cell
// index wraps, the relative position uses the unwrapped image), on the other
// axes the cells beyond the grid are skipped.
//
// Filling: one thread per (particle, cell of a fixed B^dim box), B =
// ⌊2 R_max⌋ + 2 the widest bounding box in cells. Each thread evaluates ε of
// its cell and, if ε > 0, takes a slot with an atomic increment of the cell's
// count. Chosen over a per-cell gather because it needs no cell list of the
// particles (imb links only core), no host round trip for sizes (B is known
// from R_max), and keeps the expensive exact-ε threads of one particle in the
// same warps; the cost is idle threads in the box corners (1 − π/6 of a cube)
// and, for a polydisperse set, (R_max/R)^dim idle threads per small particle.
// Atomic order makes the slot order non-deterministic, so two passes over the
// (particle, box cell) pairs sort each cell's slots by particle index
// (deterministic layout; default on). The next map clears the counts through
// the same pairs (no scan of the grid, no cell list).
//
// Overflow (more than K particles in one cell): the count keeps incrementing
// past K (so it tells how many wanted in), the surplus (cell, particle) pairs
// are logged, and overflow() returns the cell, its grid coordinates and every
// particle involved. Nothing is silently dropped: check overflow() (or call
// throw_if_overflow()) before using the slots.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/buffer.hpp"
#include "core/grid.hpp"
#include "core/exec.hpp"
#include "core/memory_use.hpp"
#include "imb/fraction_table.hpp"
#include "imb/particle_view.hpp"
#include "imb/solid_fraction.hpp"

namespace lbdem {
struct Scratch;  // core/algorithms.hpp
}

namespace lbdem::imb {


// Slots seen by kernels (structure of arrays: slot k of cell c at k*ncells + c,
// so a warp of consecutive cells reads consecutive words). Only slots
// k < used(cell) are meaningful; the others hold stale values.
struct CellSlotsView {
  int* count = nullptr;      // per cell: overlapping particles (> K means overflow)
  int* particle = nullptr;   // [k * ncells + cell]
  double* eps = nullptr;     // [k * ncells + cell]
  Index ncells = 0;
  int K = 0;
  // Solid velocity of the slot's particle at the cell centre (translation +
  // rotation, first paper Eq. 2), component a at (a * K + k) * ncells + cell:
  // written by the map from SphereView's velocities.
  float* vel = nullptr;
  LBDEM_HD int used(Index cell) const { return count[cell] < K ? count[cell] : K; }
  LBDEM_HD float& vel_at(int a, Index cell, int k) const { return vel[(static_cast<Index>(a) * K + k) * ncells + cell]; }
  LBDEM_HD int& particle_at(Index cell, int k) const { return particle[k * ncells + cell]; }
  LBDEM_HD double& eps_at(Index cell, int k) const { return eps[k * ncells + cell]; }
  // Σ_k ε_k of a cell (the total solid fraction a PSM weighting B(ε) starts from).
  LBDEM_HD double total_eps(Index cell) const {
    double s = 0.0;
    const int m = used(cell);
    for (int k = 0; k < m; ++k) s += eps[k * ncells + cell];
    return s;
  }
};

// Per (particle, cell of its B^dim box) whether the pair took a slot: pair[i *
// box + l] = the cell index, or -1. Box cell l = li + B (lj + B lk) sits at
// floor(x_i - r_i) + (li, lj, lk) (unwrapped). Written by every map.
struct PairView {
  const int* slot = nullptr;  // cells < 2^31 per rank (checked by CellSlots)
  Index box = 0;
  int B = 0;
};

struct MapOptions {
  FractionMethod method = FractionMethod::Exact;
  // Largest radius among the particles (lattice units). It sizes the box each
  // particle scans; <= 0 computes it (synchronous reduction). A particle larger
  // than this is reported by overflow(), not silently clipped.
  double max_radius = 0.0;
  const FractionTable* table = nullptr;  // required for FractionMethod::Table (dim must match)
  // Keep the overflow counters of earlier maps (a time loop maps every step and
  // reads overflow() only every few steps, so no event is lost between reads).
  bool keep_overflow = false;
  bool linear_normalised = true;        // Linear: use R_eff (volume-conserving) instead of R
  bool sort_slots = true;               // deterministic slot order (by particle index)
  // Table on the device: in __constant__ memory (the first paper's choice) or in
  // global memory read through the read-only cache. Constant memory serialises a
  // warp's reads of different addresses, and table lookups of neighbouring cells
  // hit different nodes, so global memory is the default and constant memory
  // the opt-in reproduction of the paper (bench/imb times both).
  bool table_in_constant = false;
  // Exact method: classify in the box pass, do the interface cells in a second
  // dense pass (much better warp use on the GPU; same results).
  bool defer_exact = true;
};

struct OverflowReport {
  bool overflow = false;          // some cell had more than K particles
  bool radius_too_large = false;  // some particle exceeded MapOptions::max_radius
  Index events = 0;               // number of (cell, particle) pairs that found no slot
  Index cell = -1;                // first overflowing cell (lowest index among logged)
  std::array<Index, 3> ijk{-1, -1, -1};
  int count = 0;                  // particles that overlap that cell
  std::vector<int> particles;     // every particle that overlaps it (slots + surplus, as logged)
  int bad_particle = -1;          // a particle with radius > max_radius
  std::string message;            // human-readable summary (empty when all is well)
};

class CellSlots {
 public:
  // K: slots per cell (case parameter, >= 1). overflow_log: surplus pairs kept for the report.
  // Slots for every storage cell of `grid` (core/grid.hpp); particle centres
  // are in the grid's global lattice frame.
  CellSlots(Backend b, const Grid& grid, int K, int overflow_log = 1024);

  // Clears and refills the slots from the particles (asynchronous on the device).
  void map(const Exec& ex, const SphereView& particles, const MapOptions& opt);

  // Synchronises and reads the overflow counters (small copies); empty report if fine.
  OverflowReport overflow() const;
  // Throws ResourceError with the report's message if overflow() finds a problem.
  void throw_if_overflow() const;
  // Resets the overflow counters (maps with MapOptions::keep_overflow accumulate them).
  void clear_overflow(const Exec& ex);

  CellSlotsView view() const {
    return {count_.data(), particle_.data(), eps_.data(), gv_.n, K_, vel_.data()};
  }
  PairView pairs() const { return {pair_.data(), pair_box_, pair_B_}; }
  const Grid& grid() const { return grid_; }
  int K() const { return K_; }
  // Largest particle radius of the last map (given or reduced): sizes the force gather.
  double max_radius() const { return max_radius_; }
  Backend backend() const { return backend_; }

  // Host copies (tests, output).
  std::vector<int> counts_host() const { return count_.to_vector(); }
  std::vector<int> particles_host() const { return particle_.to_vector(); }
  std::vector<double> eps_host() const { return eps_.to_vector(); }
  // Solid-fraction field Σ_k ε_k per cell (host copy), e.g. for output.
  std::vector<double> total_eps_host() const;
  // The same for the cells of `box` (storage coordinates) into `out` (backend
  // memory, box.size() values, box x-fastest). Asynchronous.
  void total_eps_box(const Exec& ex, const CellBox& box, double* out) const;
  // Bytes of each buffer held, by component (psm_memory()).
  MemoryUse memory_use() const;

 private:
  Backend backend_;
  Grid grid_;
  GridView gv_;  // storage extents, wrap flags and the global-frame shift
  int K_;
  int log_cap_;
  Buffer<int> count_, particle_;
  Buffer<double> eps_;
  Buffer<float> vel_;  // CellSlotsView::vel
  // [0] surplus events, [1] radius errors, [2] a particle with too large a radius, [3] deferred cells
  Buffer<int> flags_;
  Buffer<Index> log_cell_;
  Buffer<int> log_particle_;
  Index particles_mapped_ = 0;
  double max_radius_ = 0;
  Buffer<float> global_table_;       // device copy of the table when !table_in_constant
  Buffer<Index> queue_;              // deferred interface cells of the exact method
  std::uint64_t global_table_id_ = 0;
  std::shared_ptr<Scratch> scratch_;  // reduction storage (max radius), reused across steps
  Buffer<int> pair_;                 // PairView
  Index paired_ = 0;                 // entries of pair_ the last map wrote (the next map clears through them)
  Index pair_box_ = 0;
  int pair_B_ = 0;
};

// Evaluates ε for n cells given by their centres relative to the particle
// centre (rel: dim*n interleaved) and radii (n values) with one method, on a
// backend (pointers live there). For tests, CPU/GPU comparison and benchmarks.
// Synchronous.
void evaluate_fractions(const Exec& ex, FractionMethod method, int dim, const FractionTable* table, const double* rel,
                        const double* radius, double* out, Index n, bool table_in_constant = true);

}  // namespace lbdem::imb
