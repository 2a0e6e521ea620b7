#pragma once
// The SI sections of a fluid scene (channel, taylor_green, lid_driven_cavity,
// periodic_box): `collision` (model, magic, tau), `fluid` (density,
// kinematic_viscosity), `domain` (cells, spacing) and `time` (dt, steps or
// end), and from them, with the scene's reference speed, the lattice units
// (core/units.hpp: dx = domain.spacing, dt from collision.tau or time.dt) and
// the run's step count. Messages name the key as the user wrote it.
#include <optional>
#include <vector>

#include "core/config.hpp"
#include "core/exec.hpp"
#include "core/run_length.hpp"
#include "core/units.hpp"
#include "halo/parallel_options.hpp"
#include "lbm/solver.hpp"

namespace lbdem::lbm {

struct SiFluid {
  double rho = 1, nu = 0;          // fluid.density [kg/m^3], kinematic_viscosity [m^2/s]
  double dx = 0;                   // domain.spacing [m]
  std::vector<long> cells;         // domain.cells: fluid cells, one per axis of s.lattice
  std::optional<double> tau, dt;   // collision.tau, time.dt (at most one sets the time step)
  RunLength length;                // time.steps or time.end
};

// Reads the four sections in that order into `f` and s.collision, s.magic
// (s.lattice is set before: it gives the number of cells).
SiFluid read_si_fluid(const Config& root, LbmSetup& s);
// The lattice units with the scene's reference speed `u_ref` [m/s] against
// `max_mach` (derive_units), s.tau set; BGK's tau >= 0.51 refused naming
// collision.tau.
Units si_fluid_units(const Config& root, const SiFluid& f, double u_ref, double max_mach, LbmSetup& s);
// time.steps, or time.end / dt rounded (at least one step).
long si_fluid_steps(const SiFluid& f, const Units& U);

// Refuses (ResourceError naming domain.cells) a grid that cannot fit before
// anything is allocated: each rank's piece on `backend` (the decomposition is
// checked here) and the host staging fields of set-up and output (flags,
// rho, u, pressure: 1 + 5 doubles per cell of the whole grid).
void check_fluid_memory(const LbmSetup& s, const halo::ParallelOptions& po, int ranks, Backend backend);

}  // namespace lbdem::lbm
