#pragma once
// The lattice Boltzmann solver: runtime choices (lattice, precision,
// collision, streaming, boundaries on/off, forcing on/off) become template
// parameters here, once. Each (lattice, precision) pair is instantiated in its
// own translation unit so builds stay parallel.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/checkpoint.hpp"
#include "core/exec.hpp"
#include "core/memory_use.hpp"
#include "lbm/boundary.hpp"
#include "lbm/collision.hpp"
#include "lbm/grid.hpp"
#include "lbm/halo_block.hpp"
#include "lbm/kernels.hpp"

namespace lbdem::lbm {

enum class LatticeKind { D2Q9, D3Q19 };
// Storage precision of the populations. FP16S (IEEE half) and FP16C (a
// 1-4-11 float for values below 1) store 16 bits and compute in fp32
// (core/half.hpp, lbm/storage.hpp).
enum class Precision { FP32, FP64, FP16S, FP16C };

struct LbmSetup {
  LatticeKind lattice = LatticeKind::D2Q9;
  Precision precision = Precision::FP64;
  CollisionKind collision = CollisionKind::TRT;
  StreamKind streaming = StreamKind::AA;
  double tau = 0.8;                   // tau+ (viscosity nu = (tau - 1/2)/3)
  double magic = 3.0 / 16.0;          // TRT Lambda
  Grid domain;                        // this rank's piece of the lattice (core/grid.hpp)
  std::array<double, 3> body_force{0, 0, 0};  // per unit volume, lattice units
  BoundaryTable boundaries;           // entries for flag values 1..count
};

// Field sums over fluid cells (lattice units).
struct LbmDiagnostics {
  double mass = 0;                    // sum of rho
  std::array<double, 3> momentum{};   // sum of c f (without the F/2 shift)
  double max_speed = 0;               // max |u|
  std::array<long, 3> max_speed_cell{-1, -1, -1};
  bool finite = true;
  std::array<long, 3> nonfinite_cell{-1, -1, -1};
  long fluid_cells = 0;
};

// What a coupling module (imb/) needs to run its own stream-collide kernel on
// a solver's populations: storage, grid, boundaries, relaxation, step parity.
struct LbmRaw {
  void* src = nullptr;   // populations read this step (AA: also written)
  void* dst = nullptr;   // populations written this step (two-lattice), == src for AA
  Index stride = 0;
  GridView grid;
  CellBox owned;         // the cells a step updates (storage coordinates)
  const std::uint8_t* flags = nullptr;
  bool has_boundaries = false;  // boundary entries exist: kernels read the flags (ghost cells never reflect)
  long step = 0;         // steps done; AA parity = step & 1
  double omega_p = 1, omega_m = 1;
  std::array<double, 3> body_force{0, 0, 0};
  BoundaryTable boundaries;
};

// Two queues of work, so that the cells next to a cut can be updated and
// their halo sent while the inner cells are updated: Main (the solver's
// stream) and Edge (a stream of higher priority on the device; the same
// queue on the host).
enum class Lane { Main, Edge };

Index lbm_stage_cells(const LbmSetup& s);

class LbmSolver {
 public:
  virtual ~LbmSolver() = default;
  // flags: one byte per storage cell (0 fluid, k>0 boundary entry k,
  // kGhostFlag ghost); rho, u (3 per
  // cell) in lattice units: the incoming populations become f^eq(rho, u).
  virtual void initialize(const std::vector<std::uint8_t>& flags, const std::vector<double>& rho,
                          const std::vector<double>& u) = 0;
  virtual void step(long n) = 0;                     // asynchronous on the device
  // One step in parts, so that a halo exchange can overlap it: step_box()
  // for boxes that together hold every owned cell once (e.g. the outer slabs,
  // then the inner box: Grid::outer / Grid::inner), then end_step(). step(1)
  // is step_box(owned) + end_step(). Asynchronous on the device.
  virtual void step_box(const CellBox& box, Lane lane = Lane::Main) = 0;
  virtual void end_step() = 0;
  // Orders the lanes: after fork(), work queued on Edge starts after the work
  // queued on Main so far; after join(), work queued on Main starts after
  // the work queued on Edge so far.
  virtual void fork() = 0;
  virtual void join() = 0;
  virtual const Exec& exec(Lane lane) const = 0;
  // Halo packing on the Edge lane (lbm/halo_block.hpp): pack copies the
  // block's slots of its cells into buf, unpack copies them back under the
  // block's mask. buf is backend memory of HaloBlock::bytes(storage_bytes()).
  virtual void pack_halo(const HaloBlock& b, void* buf) = 0;
  virtual void unpack_halo(const HaloBlock& b, const void* buf) = 0;
  virtual int storage_bytes() const = 0;  // bytes of one stored population
  // rho and u (3 per cell) of every storage cell, to host (ghost cells 0);
  // computed slab by slab through the output staging buffer.
  virtual void macroscopic(std::vector<double>& rho, std::vector<double>& u) = 0;
  // rho and u of the cells of `box` (storage coordinates, at most
  // output_slab_cells() cells) into host arrays of box.size() and
  // 3 box.size() values, box x-fastest. Synchronous; allocates nothing.
  virtual void macroscopic_box(const CellBox& box, double* rho, double* u) = 0;
  Index output_slab_cells() const { return lbm_stage_cells(setup()); }
  virtual LbmDiagnostics diagnostics() = 0;          // synchronous
  virtual std::vector<double> populations() = 0;     // incoming f (not shifted), [q*cells + cell]
  virtual void synchronize() = 0;
  virtual long steps_done() const = 0;
  virtual std::size_t memory_bytes() const = 0;      // memory_use().total()
  // Bytes of each buffer the solver holds, by component (lbm_memory()).
  virtual MemoryUse memory_use() const = 0;
  virtual const LbmSetup& setup() const = 0;
  virtual Backend backend() const = 0;
  // Bytes a step must move per fluid cell (populations read + written), for
  // bandwidth figures.
  virtual double bytes_per_cell_step() const = 0;
  // Coupling hook: raw() describes the next step; after an external kernel
  // has performed it, commit_external_step() advances the step (and swaps the
  // two lattices of the two-lattice scheme).
  virtual LbmRaw raw() = 0;
  virtual void commit_external_step() = 0;
  // Checkpoint state (core/checkpoint.hpp): the stored populations of every
  // lattice, raw, in their storage precision and layout (A-A: as the parity
  // of the step count left them), the cell flags and the step count. Load
  // into a solver of the same set-up after initialize(); a stored lattice,
  // precision, scheme or grid of another set-up is refused (ConfigError).
  // Synchronous.
  virtual void save_state(ckpt::Sink& out) = 0;
  virtual void load_state(ckpt::Source& in) = 0;
  // The canonical form of the state that a checkpoint of several ranks holds
  // (lbm/checkpoint.hpp): after a whole step, every population a
  // cell's next step needs lies in an owned cell's own slot of the incoming
  // array (A-A: the write-back after an odd step puts them there; two-lattice:
  // the array the next step pulls from), so that the owned slots of all pieces
  // together are the one-rank storage, whatever the cut. These copy slot q of
  // every storage cell (ghosts included, storage order) in the storage
  // precision (storage_bytes() per value), and the cell flags. Synchronous.
  virtual void read_slot(int q, void* host) = 0;
  virtual void write_slot(int q, const void* host) = 0;
  virtual void read_flags(std::uint8_t* host) = 0;
  // The step count after write_slot() restored the state of step `t`.
  virtual void set_steps_done(long t) = 0;
};

// What the solver allocates for this setup, by component, before anything is
// allocated: "populations" (Q per cell, one lattice for A-A streaming, two
// for the two-lattice scheme, rows padded to 64 cells), "flags" (one byte per
// storage cell), "output staging" (rho + u of lbm_stage_cells() cells, in
// double). LbmSolver::memory_use() reports the same list from its buffers.
MemoryUse lbm_memory(const LbmSetup& s);
// lbm_memory(s).total(), to refuse cases that cannot fit.
std::size_t lbm_memory_estimate(const LbmSetup& s);
// Cells of one output slab of this setup: kOutputSlabCells, or every storage
// cell of a smaller grid.
Index lbm_stage_cells(const LbmSetup& s);

std::unique_ptr<LbmSolver> make_lbm_solver(const LbmSetup& setup, Backend backend);

int lattice_q(LatticeKind k);
int storage_bytes(Precision p);  // bytes of one stored population
// "fp32", "fp64", "fp16s", "fp16c" (the case key `precision`); throws ConfigError otherwise.
Precision precision_from_string(const std::string& name);
const char* to_string(LatticeKind k);
const char* to_string(Precision p);
const char* to_string(CollisionKind k);
const char* to_string(StreamKind k);

}  // namespace lbdem::lbm
