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
// DEM's layout; its neighbour-list capacity is fitted at the first build),
// and with background snapshots (output.background) the device pack of the
// owned box ("snapshot pack (output.background)", imb/snapshot_pack.hpp; 20 or
// 40 B per owned cell as the files store float32 or float64).
struct SnapshotMemory {
  bool background = false;  // output.background
  bool fp32 = false;        // fields written as float32
};
MemoryUse coupled_memory(const lbm::LbmSetup& fluid, const CoupledParams& cp, double particles, Backend b,
                         SnapshotMemory snapshots = {});
// Refuses (ResourceError, exit 4) a coupled run whose coupled_memory() does
// not fit the backend's free memory, naming the biggest components and
// cp.keys.cells; the host side counts the background snapshots' page-locked
// host array.
void check_coupled_memory(const Config& root, const lbm::LbmSetup& fluid, const CoupledParams& cp,
                          double particles, Backend b, SnapshotMemory snapshots = {});

}  // namespace lbdem::imb
