#pragma once
// One PSM fluid step on an LbmSolver's populations: particle -> cell mapping,
// PSM stream-collide, force and torque gathered per particle. Everything stays
// on the solver's backend; nothing is allocated per step.
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/buffer.hpp"
#include "imb/cell_slots.hpp"
#include "imb/psm.hpp"
#include "imb/tile_map.hpp"
#include "lbm/halo_exchange.hpp"
#include "lbm/solver.hpp"

namespace lbdem::imb {

// Where the gathered force and torque of particle i go: force[i * fstride +
// 0..2], torque[i * tstride + 0..2] (lattice units, per step).
struct ForceOut {
  double* force = nullptr;
  double* torque = nullptr;
  int fstride = 6, tstride = 6;
  // Added to every particle's force times its volume (4/3 pi r^3; 2D: pi r^2):
  // buoyancy -rho_f g when gravity acts on the particles but not on the fluid.
  std::array<double, 3> per_volume{0, 0, 0};
  // Only particles [0, per_volume_count) receive per_volume (< 0: all). A
  // decomposed coupled run holds ghost copies behind its owned particles:
  // their forces are this rank's shares, summed into the owner's, which
  // carries the buoyancy once.
  Index per_volume_count = -1;
  static ForceOut six(double* f6) { return {f6, f6 + 3, 6, 6, {0, 0, 0}, -1}; }
};

// How the solid term reaches the PSM kernel:
//  Mapped: a map writes per-cell slots (particle, eps, solid velocity) that the
//          PSM kernel reads, the kernel writes per-(slot, cell) forces and a
//          gather sums them per particle (imb/cell_slots.hpp, imb/psm.hpp). Any
//          fraction method, any K; the choice for fixed particles (mapped once).
//  Fused:  per-tile candidate lists; the kernel evaluates each cell's fractions
//          itself and sums forces per block (imb/tile_map.hpp,
//          imb/psm_fused.hpp). Table or linear fractions, K <= kFusedMaxSlots,
//          table from global memory; the fast path for moving particles.
//  Auto:   Fused where it applies, else Mapped.
enum class PsmPipeline { Auto, Fused, Mapped };

struct PsmOptions {
  PsmVariant variant = PsmVariant::NEBB;
  PsmWeight weight = PsmWeight::NobleTorczynski;
  MapOptions map;  // fraction method, max radius, table
  PsmPipeline pipeline = PsmPipeline::Auto;
  int tile_capacity = 64;  // fused: candidate particles per tile (overflow is reported)
  // The fluid's body force F stands for a mean pressure gradient, which acts
  // on the particles' volume too: each particle also receives B_k F from
  // every cell it covers (psm_particle_force), the part the (1 - B) weighting
  // withholds from the fluid there. Fluid and particles then receive F on
  // every cell, so the total momentum gain per step is F V, independent of
  // the fractions (what a weight-balanced periodic suspension needs;
  // CoupledSolver turns it on). Off: the particles feel the body force only
  // through the flow (the fixed-sphere drag's convention).
  bool body_force_on_solid = false;
  // NEBB only (psm.even_relaxation = phi in [0, 1]): the solid term also
  // relaxes the even part of the populations toward f^eq(rho, u), by
  // -Be omega+ (f+_q - eq+_q), Be = max(0, B - (1 - phi)): a cell's even
  // populations then relax at max(1 - B, phi) omega+ instead of (1 - B)
  // omega+, so that covered cells keep no density and stress of their own
  // (imb/psm.hpp, "Even relaxation"). Mass, momentum, the force and the
  // torque of a step are unchanged. 0 (the default) is off, the operator every
  // existing case ran with: the option moves a steady drag.
  double even_relaxation = 0;
};

// The pipeline a step with these options and K slots per cell runs; throws
// ConfigError (naming the key; `slots_key` is K's) if Fused is asked for where
// it does not apply.
PsmPipeline resolve_pipeline(const PsmOptions& o, int K, const std::string& slots_key = "coupling.slots");
const char* to_string(PsmPipeline p);

class PsmCoupling {
 public:
  // K: overlap slots per cell. The solver's Grid (LbmSetup::domain) says which
  // axes wrap particle images and where the global frame sits in storage.
  PsmCoupling(lbm::LbmSolver& solver, int K);
  ~PsmCoupling();

  // Maps the particles (lattice units, on the solver's backend) to cells.
  // Throws ResourceError if a cell overflows its K slots (when check_overflow:
  // a small synchronous copy). Fixed particles need it once; moving ones every step.
  void map(const PsmParticles& p, const PsmOptions& opt, bool check_overflow);
  // One fluid step with the solid term on the current mapping; force6 (6 per
  // particle, on the same backend) receives force and torque (lattice units,
  // per step). A null force pointer skips the gather (fixed particles whose
  // force is read only every few steps).
  void step(const PsmParticles& p, const PsmOptions& opt, double* force6) { step(p, opt, ForceOut::six(force6)); }
  void step(const PsmParticles& p, const PsmOptions& opt, const ForceOut& out);

  // The same step in parts, so that a halo exchange can overlap it (as
  // LbmSolver::step_box): step_part() for each outer part (together they hold
  // every owned cell next to a cut), then the inner part, then finish_step().
  // A part is a box of cells (mapped pipeline) or of whole tiles (fused: a
  // tile's forces are written once, so no tile is in two parts). On one rank
  // there is one part, the whole grid. Valid after map().
  struct Parts {
    std::vector<CellBox> outer;
    CellBox inner;
  };
  const Parts& parts() const { return parts_; }
  // One step on a piece of a cut grid: the parts above, overlapped with the
  // halo exchange of the populations (lbm/halo_exchange.hpp). The forces are
  // this rank's share (its owned cells); the caller sums them over ranks.
  void step(const PsmParticles& p, const PsmOptions& opt, const ForceOut& out, lbm::FluidHalo& halo);
  void step_part(const CellBox& part, const PsmParticles& p, const PsmOptions& opt, lbm::Lane lane = lbm::Lane::Main);
  void finish_step(const PsmParticles& p, const ForceOut& out);

  // The per-cell slots of the mapped pipeline (valid after a mapped map()).
  const CellSlots& slots() const;
  // Total solid fraction per cell (host copy, for output and diagnostics): the
  // mapped pipeline's slots, or, in the fused pipeline, a map made for it.
  std::vector<double> solid_fraction_host(const PsmParticles& p, const PsmOptions& opt);
  // Slots at the particles' current positions for output and diagnostics: the
  // mapped pipeline's own, or (fused pipeline) a mapped-pipeline map made now.
  const CellSlots& output_slots(const PsmParticles& p, const PsmOptions& opt);
  // Total solid fraction of the cells of `box` (storage coordinates, at most
  // solver.output_slab_cells() cells) at the particles' current positions, to
  // the host array eps (box.size() values, box x-fastest): the mapped
  // pipeline's slots, or the fused pipeline's tile lists (TileMap::total_eps,
  // the same values). Through a staging buffer reserved at construction:
  // allocates nothing. Synchronous. Valid after map().
  void solid_fraction_box(const PsmParticles& p, const PsmOptions& opt, const CellBox& box, double* eps);
  // The same values written to `out`, backend memory of box.size() doubles
  // (box x-fastest; any box within the storage cells): asynchronous on the
  // coupling's queue, no staging, no allocation. What solid_fraction_box
  // stages, and what a snapshot packs on the device (imb/snapshot_pack.hpp).
  void solid_fraction_device(const PsmParticles& p, const PsmOptions& opt, const CellBox& box, double* out);
  // Bytes of each buffer held, by component (psm_memory()).
  MemoryUse memory_use() const;
  // Overflow of the pipeline in use (cell slots, tile lists, radius); synchronous.
  OverflowReport overflow() const;
  void clear_overflow();
  // The pipeline of the last map().
  PsmPipeline pipeline() const { return pipeline_; }

 private:
  CellSlots& mapped_slots();

  lbm::LbmSolver& solver_;
  int K_;
  const Grid& grid() const { return solver_.setup().domain; }
  std::unique_ptr<CellSlots> slots_;
  Buffer<double> slot_forces_;
  std::unique_ptr<TileMap> tiles_;
  Buffer<float> table_;  // fused pipeline: the fraction table on the backend
  std::uint64_t table_id_ = 0;
  PsmPipeline pipeline_ = PsmPipeline::Auto;  // of the last map()
  Parts parts_;                               // of the last map()'s pipeline
  bool parts_ready_ = false;
  Parts compute_parts() const;
  Exec ex_;
  Buffer<double> stage_;  // output staging (solid_fraction_box)
};

// What a PsmCoupling on a solver of setup `s` allocates, by component, before
// anything is allocated, for `particles` particles of largest radius
// opt.map.max_radius (lattice units) and K slots per cell; `device`: the run
// is on the GPU (the fraction table gets a device copy there).
//   fused:  "tile lists" (count + candidates + entries per tile), "tile
//           partial forces" (6 doubles per particle and tile its box can touch),
//           "overflow logs", "fraction table";
//   mapped: "cell slots" (count, K particle indices, K ε in double, K solid
//           velocities in float per cell), "slot forces" (3 K doubles per cell),
//           "slot pairs" (one int per particle and cell of its box), "overflow
//           logs", "fraction table", "exact queue" (exact method);
//   both:   "output staging" (one double per cell of an output slab).
// PsmCoupling::memory_use() reports the same list from its buffers once the
// particles have been mapped and stepped.
MemoryUse psm_memory(const lbm::LbmSetup& s, int K, const PsmOptions& opt, Index particles, bool device);

// Per-(lattice, precision) kernels (psm_*.cu).
void psm_fluid_step(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                    const SlotForceView& sf, const PsmOptions& opt);
void psm_gather(const Exec& ex, const CellSlotsView& slots, const SlotForceView& sf, const PairView& pairs,
                const PsmParticles& p, int dim, const ForceOut& out);

}  // namespace lbdem::imb
