#pragma once
// Checks of a coupled particle scene while its case is parsed: its memory by
// component before anything is allocated, and the Mach number of its
// velocity scale with the key that set it (core/run_checks.hpp).
#include <array>

#include "core/config.hpp"
#include "core/exec.hpp"
#include "core/memory_use.hpp"
#include "dem/particles.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "lbm/solver.hpp"

namespace lbdem::imb {

// The resolved particle scene (lattice units): the Mach number of its
// velocity scale (coupled_scales) with the key that set it and every
// way out; refuses before check_coupled_setup() would. Messages name
// cp.keys.
void check_particles_mach(const Config& root, const lbm::LbmSetup& fluid, const dem::DemParams& dem,
                          const dem::HostParticles& p, const CoupledParams& cp, double max_mach);

// Device memory of a coupled run by component, before anything is allocated:
// the fluid's (lbm::lbm_memory), the PSM coupling's (psm_memory, for
// `particles` particles of the largest radius cp.psm.map.max_radius) and the
// DEM's ("DEM particles and lists": an upper bound per particle from the
// DEM's layout; its neighbour-list capacity is fitted at the first build).
MemoryUse coupled_memory(const lbm::LbmSetup& fluid, const CoupledParams& cp, double particles, Backend b);
// Refuses (ResourceError, exit 4) a coupled run whose coupled_memory() does
// not fit the backend's free memory, naming the biggest components and
// cp.keys.cells.
void check_coupled_memory(const Config& root, const lbm::LbmSetup& fluid, const CoupledParams& cp,
                          double particles, Backend b);

}  // namespace lbdem::imb
