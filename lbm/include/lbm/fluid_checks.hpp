#pragma once
// Checks of a fluid grid while a case is parsed: the lattice Mach number of
// an SI fluid scene, naming the key that set the speed and every way out, and
// the bytes of the grid one rank holds (core/run_checks.hpp).
#include <string>

#include "core/config.hpp"
#include "lbm/solver.hpp"

namespace lbdem::lbm {

// The lattice Mach number sqrt(3) u dt / dx of a fluid scene in SI units,
// before derive_units(): refuses with the key that set the speed and the
// ways out (a lower speed, a smaller time step, a finer grid). Does nothing
// when tau/dt are missing or invalid (derive_units reports those).
struct MachInput {
  double dx = 0, nu = 0, u_ref = 0, max_mach = 0.3;
  double tau = 0, dt = 0;      // one of them > 0
  std::string speed_key;       // the key that set u_ref, as written in the file
  std::string speed_what;      // how u_ref follows from it
  double speed_scale = 1;      // u_ref per unit of the key's value (u_ref is linear in it)
  std::string max_mach_key = "diagnostics.max_mach";
};
void check_fluid_mach(const Config& root, const MachInput& in);

// Bytes of a lattice Boltzmann grid of `cells` cells (lbm_memory per
// cell, in double so that absurd sizes do not wrap).
double lbm_grid_bytes(const LbmSetup& s, double cells);
// The fluid one rank holds: under mpirun on N ranks the largest piece of
// the decomposition the run will use (ghost layers included), else the whole
// grid. (`lbdem check` runs as one process: the whole grid.)
LbmSetup rank_fluid(const Config& root, const LbmSetup& whole);
// Device bytes of the grid on one rank (rank_fluid).
double rank_grid_bytes(const Config& root, const LbmSetup& fluid);
// The way out of a memory refusal by precision (", or precision: fp32" where it is not already so).
std::string or_fp32(const LbmSetup& fluid);

}  // namespace lbdem::lbm
