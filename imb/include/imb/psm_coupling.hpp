#pragma once
// One PSM fluid step on an LbmSolver's populations: particle -> cell mapping,
// PSM stream-collide, force and torque gathered per particle. Everything stays
// on the solver's backend; nothing is allocated per step.
#include <array>
#include <memory>

#include "core/buffer.hpp"
#include "imb/cell_slots.hpp"
#include "imb/psm.hpp"
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
  static ForceOut six(double* f6) { return {f6, f6 + 3, 6, 6, {0, 0, 0}}; }
};

struct PsmOptions {
  PsmVariant variant = PsmVariant::NEBB;
  PsmWeight weight = PsmWeight::NobleTorczynski;
  MapOptions map;  // fraction method, max radius, table
};

class PsmCoupling {
 public:
  // K: overlap slots per cell. periodic: which axes wrap particle images.
  PsmCoupling(lbm::LbmSolver& solver, int K, std::array<bool, 3> periodic);
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

  const CellSlots& slots() const { return *slots_; }

 private:
  lbm::LbmSolver& solver_;
  std::array<bool, 3> periodic_;
  std::unique_ptr<CellSlots> slots_;
  Buffer<double> slot_forces_;
  Exec ex_;
};

// Per-(lattice, precision) kernels (psm_*.cu).
void psm_fluid_step(const Exec& ex, const lbm::LbmSetup& s, const lbm::LbmRaw& raw, const CellSlotsView& slots,
                    const SlotForceView& sf, const PsmOptions& opt, const std::array<bool, 3>& periodic);
void psm_gather(const Exec& ex, const CellSlotsView& slots, const SlotForceView& sf, const PairView& pairs,
                const PsmParticles& p, int dim, const ForceOut& out);

}  // namespace lbdem::imb
