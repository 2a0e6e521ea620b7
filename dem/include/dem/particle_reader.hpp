#pragma once
// The reader of a case file's `particles` section in physical units, shared by
// the scenes that build a DEM system from it (dem, fluidized_bed):
//   init: list       list: [{position, radius, velocity, angular_velocity, density}, ...]
//   init: csv | hdf5 file (relative to the case file), as dem/init.hpp reads it
//   init: lattice    count [nx, ny, nz], origin, spacing, radius
//   init: random     radius [r] or [r_min, r_max], solid_fraction or count (of the
//                    region), region_lo / region_hi (default: the DEM box), seed,
//                    mc_sweeps (dem::random_packing)
// with density (kg/m^3) for every particle without its own, and optional
// random initial velocities of zero mean (velocity_rms, velocity_seed).
// Messages name the key as written (Config::fail); the particles' memory is
// checked before they are made (dem/particle_checks.hpp).
#include <optional>

#include "core/config.hpp"
#include "dem/particles.hpp"
#include "dem/system.hpp"

namespace lbdem::dem {

struct ParticleReading {
  std::optional<double> density;  // default of particles.density (none: the key is required)
  bool validate_only = false;     // lbdem check: random packings on lattice sites, no random velocities
};

// The particles of section `pc` in the box of `p` (lo, hi, periodic axes).
HostParticles read_particles(const Config& pc, const DemParams& p, const ParticleReading& o);

}  // namespace lbdem::dem
