#pragma once
// The resolved coupled time step (PSM fluid <-> DEM particles). Its order is
// the shared coupled loop (dem/coupled_loop.hpp); this mode's fluid side
// (CoupledSolver's FluidCoupling members in imb/src/coupled.cpp) is:
//
//   1. fluid: one LBM step with the solid term of every mapped particle
//      (imb/psm.hpp); the hydrodynamic force and torque of each particle, plus
//      its buoyancy and its share of the fluid body force, are gathered
//      straight into the DEM's coupling input
//      (ext_force / ext_torque), in the particles' current storage order;
//   2. particles: N DEM sub-steps (contacts, walls, gravity) with that force
//      held constant;
//   3. remap: particles -> cells at their new positions for the next step;
//   4. every overflow_check_every steps: the cell-slot overflow check.
// With psm.wall_lubrication applied (CoupledParams::wall_lubrication), step 1
// ends by adding the wall gap correction (imb/wall_lubrication.hpp) to the
// force of each particle near a plane wall of the fluid, after the ranks'
// shares are summed: each rank corrects the particles it owns, from their
// positions and velocities at the fluid step.
//
// Units: everything in lattice units (dx = dt_fluid = 1, fluid density 1); the
// DEM runs with dt = 1/N. Scenes convert SI input once (core/units.hpp).
// Gravity acts on the particles (DEM gravity); the fluid feels no gravity,
// so each particle receives the buoyancy -rho_f V_p g explicitly. In a fully
// periodic domain the net weight of the particles must be balanced by a body
// force on the fluid (first paper, Sec. 2), the stand-in for the mean pressure
// gradient that carries the suspension's weight: balancing_body_force(). That
// gradient acts on the particles' volume as well, so the coupled step gives
// each particle the body force on its share B_k of every cell it covers
// (PsmOptions::body_force_on_solid, on here): per step fluid and particles
// together receive the body force F on every cell, F V in all, whatever the
// solid fractions are, and F = -W / V balances the net weight W exactly.
//
// On several ranks (CoupledRanks) the fluid is this rank's piece of the grid,
// stepped with its halo exchange overlapped (PsmCoupling::step with a
// lbm::FluidHalo), and the DEM a decomposed DemSystem (dem/README.md, "Many
// ranks"): a particle belongs to the rank holding its centre, and the ghost
// copies the DEM keeps within 2 r_max + skin of each piece cover every cell
// a particle's solid fraction can reach on a neighbouring piece, ghost layer
// included (the scene checks r + skin / 2 against that reach). Each rank maps
// its owned particles and its ghosts (DemSystem::held_view()) onto its cells,
// after DemSystem::sync_ghosts() has given the ghosts their owners' current
// velocities; its gather leaves each particle its share from the cells this
// rank owns, and DemSystem::return_ghost_coupling() adds the ghosts' shares
// to the owners' in a fixed order (the owner's share, then the other ranks'
// in ascending rank). The buoyancy is added to the owner's share only. The
// sum over ranks is grouped differently from the one-rank gather (imb/psm.hpp,
// "Force gather of the mapped pipeline"), so forces agree with one rank to
// round-off, not bitwise. The overflow check is collective.
//
// Nothing is allocated and nothing is copied to the host per step, except the
// overflow check of the cell slots every `overflow_check_every` steps (a few
// bytes; overflows accumulate in between, none is lost) and whatever the DEM
// itself reads (its rebuild flag, dem/system.hpp).
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/phase_clock.hpp"
#include "dem/coupled_loop.hpp"
#include "dem/particles.hpp"
#include "dem/system.hpp"
#include "halo/comm.hpp"
#include "imb/psm_coupling.hpp"
#include "imb/wall_lubrication.hpp"
#include "lbm/solver.hpp"

namespace lbdem::imb {

// The names the checks and messages of a coupled run give its parameters
// (imb/coupled_checks.hpp, imb/coupled_memory.hpp, the slot overflow): a
// scene's readers fill in the keys its case file sets them with, as the user
// wrote them (Config::full_key: dem.substeps, physics.gravity, psm.slots); the
// defaults are the names of the C++ fields, for library users and tests.
struct CoupledKeys {
  std::string dem_substeps = "coupling.dem_substeps";
  std::string dem_dt = "dem.dt";  // a scene that sets it by dem_substeps names it in words
  std::string gravity = "coupling.gravity";
  std::string dem_gravity = "dem.gravity";
  std::string dem_periodic = "dem.periodic";
  std::string dem_lo = "dem.lo", dem_hi = "dem.hi";
  std::string slots = "coupling.slots";
  std::string stiffness = "material.stiffness";
  std::string body_force = "fluid.body_force";
  std::string cells = "domain.cells";                // the grid's size
  std::string density = "particles.density_ratio";  // the particles' density
};

struct CoupledParams {
  int dem_substeps = 1;                       // DEM steps per fluid step (DEM dt = 1/N)
  std::array<double, 3> gravity{0, 0, 0};     // lattice units; must equal the DEM's gravity
  double fluid_density = 1.0;                 // lattice units
  bool buoyancy = true;                       // add -rho_f V_p g to each particle
  int slots = 4;                              // K: overlap slots per cell
  PsmOptions psm;
  long overflow_check_every = 100;            // steps between slot-overflow reads
  // psm.wall_lubrication (imb/wall_lubrication.hpp): the gap correction added
  // to each owned particle's force after the gather; off unless applied.
  WallLubricationSetting wall_lubrication;
  CoupledKeys keys;                           // what messages call the above
};

// Body force per unit volume on the fluid that balances the particles' net
// weight W = sum_p (m_p - rho_f V_p) g in a fully periodic domain of total
// volume V (lattice units: cells; 2D: area): F = -W / V. The total momentum
// of fluid + particles then stays at its initial value: per step the system
// receives W from gravity and buoyancy and F V from the body force (fluid and
// particles together, PsmOptions::body_force_on_solid). m_p is the DEM's mass,
// the one its gravity acts on and its velocities carry (a sphere's also in
// 2D); V_p the volume the buoyancy uses (sphere; 2D: disk area pi r^2).
std::array<double, 3> balancing_body_force(const dem::HostParticles& p, int dim, const std::array<double, 3>& g,
                                           double fluid_density, double total_volume);

// A coupled run cut over ranks: the fluid piece's halo exchange (bound to the
// solver passed to CoupledSolver) and the ranks. Both null: one rank.
struct CoupledRanks {
  lbm::FluidHalo* halo = nullptr;
  const halo::Comm* comm = nullptr;
  bool distributed() const { return halo != nullptr && comm != nullptr && comm->size() > 1; }
};

class CoupledSolver : private dem::FluidCoupling {
 public:
  // On several ranks `fluid` is this rank's piece, `dem` a decomposed system
  // over the same cut (dem::domain_from_decomposition) and every call below
  // marked collective is made by every rank.
  CoupledSolver(lbm::LbmSolver& fluid, dem::DemSystem& dem, const CoupledParams& params, CoupledRanks ranks = {});
  ~CoupledSolver();

  void step() { loop_.step(); }  // one coupled step (see the header comment)
  void advance(long n);          // n coupled steps
  long steps() const { return loop_.steps(); }

  // Hydrodynamic force and torque of the last fluid step (buoyancy and the
  // body force's share included), per owned particle in the DEM's current
  // storage order (host copies; not for the time loop).
  std::vector<double> hydro_force_host() const;   // 3 per particle
  std::vector<double> hydro_torque_host() const;  // 3 per particle
  // Total solid fraction per cell at the current positions (host copy, output).
  std::vector<double> solid_fraction_host();
  // Total solid fraction of the cells of `box` (storage coordinates, at most
  // fluid().output_slab_cells() cells) at the current positions, to the host
  // array eps (box x-fastest); allocates nothing (PsmCoupling::solid_fraction_box).
  void solid_fraction_box(const CellBox& box, double* eps);
  // The same into backend memory of box.size() doubles, asynchronous
  // (PsmCoupling::solid_fraction_device): a snapshot's pack on the device.
  void solid_fraction_device(const CellBox& box, double* out);
  // Bytes of the coupling's buffers by component (imb::psm_memory()); the
  // fluid and the DEM report their own.
  MemoryUse memory_use() const { return psm_->memory_use(); }
  // Cell slots at the current positions (imb::PsmCoupling::output_slots): tests,
  // diagnostics (in the fused pipeline it allocates slots for the whole grid).
  const CellSlots& output_slots();
  // Throws ResourceError naming the cell and the particles' global ids if any
  // map since the last check overflowed its K slots. Synchronous; collective
  // (every rank throws when one overflowed, the one that did naming it).
  void check_overflow();

  lbm::LbmSolver& fluid() { return fluid_; }
  dem::DemSystem& dem() { return dem_; }
  PsmCoupling& coupling() { return *psm_; }
  const CoupledParams& params() const { return p_; }

  // The DEM's particles as the PSM sees them (lattice units, current storage
  // order; on several ranks the owned particles, then the ghosts).
  PsmParticles particle_view();
  const CoupledRanks& ranks() const { return ranks_; }

  // Checkpoint state (core/checkpoint.hpp): the coupled step count. The fluid
  // and the DEM save their own state (LbmSolver / DemSystem::save_state); the
  // force and torque of the last fluid step are the DEM's coupling input and
  // travel with it. load_state() comes after theirs: it sets the step count
  // and maps the particles at their loaded positions (the cell map is a
  // function of the positions alone).
  void save_state(ckpt::Sink& out) const { out.put<std::int64_t>(loop_.steps()); }
  void load_state(ckpt::Source& in);

  // Wall time of the phases of the coupled step on this rank
  // (core/phase_clock.hpp; on the device sampled every 16th step): the
  // phases kPhaseNames, in the order a step runs them. DEM includes the
  // particle migration and ghost rebuilds at neighbour-list rebuilds; the
  // exposed halo communication is part of fluid_psm (lbm::FluidHalo::times).
  static constexpr const char* kPhaseNames[] = {"fluid_psm", "force_reduction", "dem", "ghost_sync", "map"};
  PhaseClock& phase_clock() { return *clock_; }

 private:
  // The fluid side of the coupled loop (dem/coupled_loop.hpp).
  void fluid_step(const dem::ParticleView& v) override;
  void particles_moved(const dem::ParticleView& v) override;
  void after_step(long steps_done) override;
  void map();
  void add_wall_lubrication(const dem::ParticleView& v);

  lbm::LbmSolver& fluid_;
  dem::DemSystem& dem_;
  CoupledParams p_;
  CoupledRanks ranks_;
  std::unique_ptr<PsmCoupling> psm_;
  int dim_;
  std::unique_ptr<PhaseClock> clock_;
  dem::CoupledLoop loop_;
};

}  // namespace lbdem::imb
