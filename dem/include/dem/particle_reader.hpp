#pragma once
// The readers of a case file's `particles` and `material` sections in physical
// units, shared by the scenes that build a DEM system from them (dem,
// fluidized_bed). `particles`:
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
#include "core/units.hpp"
#include "dem/particles.hpp"
#include "dem/system.hpp"

namespace lbdem::dem {

struct ParticleReading {
  std::optional<double> density;  // default of particles.density (none: the key is required)
  bool validate_only = false;     // lbdem check: random packings on lattice sites, no random velocities
};

// The particles of section `pc` in the box of `p` (lo, hi, periodic axes).
HostParticles read_particles(const Config& pc, const DemParams& p, const ParticleReading& o);

// Where a scene's contacts get their friction: Physics: the scene's own
// switch (DemParams::friction, physics.friction) is already set; the friction
// keys are required with it and refused without it. Values: friction is on
// where material.friction or material.wall_friction is above 0 (default 0).
enum class FrictionFrom { Physics, Values };

// The `material` section (SI units): stiffness, restitution, their wall
// values (default: the particles'), friction and the tangential spring and
// damping ratios (Yu et al. 2024 contact law, dem/contact.hpp).
void read_material(const Config& m, DemParams& p, FrictionFrom friction);

// The `dem` section of a resolved (PSM) scene, in the units `U` converts the
// file's values from (the identity in lattice units): stiffness [N/m],
// restitution, their wall values (default: the particles'), friction,
// wall_friction and substeps (DEM steps per fluid step, default 10). Sets p's
// contact material and its step 1/substeps (fluid steps); returns substeps.
int read_coupled_dem(const Config& dm, const Units& U, DemParams& p);

}  // namespace lbdem::dem
