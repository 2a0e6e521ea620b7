#pragma once
// The `particles` section of the resolved particle scene (imb/coupled.hpp) in
// lattice units: a list of particles or a random suspension (dem/init.hpp,
// dem/packing.hpp, dem/block_packing.hpp), their density, diameter and
// initial velocities; the DEM box and walls that the fluid grid implies; the
// scene's checks of its particles (memory, fit in the box, overlaps, DEM
// sub-steps, Mach number, the plan). With `units: physical` the SI values go
// through `Units` (imb/physical_units.hpp); in lattice units it is the
// identity. Messages name the key as the user wrote it: Config::fail, and
// CoupledKeys (imb/coupled.hpp) for what another section sets (the grid's
// size is domain.cells or domain.size).
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/config.hpp"
#include "core/exec.hpp"
#include "core/grid.hpp"
#include "core/units.hpp"
#include "dem/block_packing.hpp"
#include "dem/particles.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "lbm/solver.hpp"

namespace lbdem::imb {

// The fluid box of the scene: `cells` fluid cells per axis (dim of them) at
// [lo, hi) of the grid, whose closed axes carry one wall layer either side.
struct FluidBox {
  int dim = 3;
  std::vector<long> cells;
  std::array<long, 3> lo{0, 0, 0}, hi{1, 1, 1};
  std::array<bool, 3> periodic{true, true, true};
};

// What the reader makes of the section, in lattice units.
struct SuspensionParticles {
  double density_ratio = 1;   // solid / fluid density
  double diameter = 1;        // cells
  dem::HostParticles particles;  // every particle; with packing: blocks none yet (dem::suspension_blocks per rank)
  std::optional<dem::BlockPackingSpec> blocks;  // particles.packing: blocks
  double solid_fraction = 0;  // the particles' volume (area in 2D) over the fluid box's
};

// What the reader needs besides the section.
struct SuspensionContext {
  const Units* units = nullptr;  // SI to lattice (the identity in lattice units)
  bool physical = false;         // units: physical (particles.density; positions from the fluid box's corner)
  double diameter = 0;           // physical: particles.cells_per_diameter (read with the grid)
  double max_mach = 0.3;         // fluid.max_mach: random_speed sqrt(3) stays below it
  const lbm::LbmSetup* fluid = nullptr;  // the grid, for the memory checks
  Backend backend = Backend::Host;       // the backend the run will use (memory checks)
  bool validate_only = false;    // `lbdem check`: random particles on their lattice sites
  CoupledKeys keys;              // the keys its messages name
};

// Reads particles.density_ratio (density), diameter, velocity,
// angular_velocity, held, init (list | random), seed, random_speed, list,
// count or solid_fraction, packing; calls pc.finish().
SuspensionParticles read_suspension_particles(const Config& root, const Config& pc, const FluidBox& box,
                                              const SuspensionContext& ctx);

// The DEM's box from the fluid grid (dem::set_box_from_grid), a plane wall
// where the fluid has its wall layer (at 1 and n - 1 on each closed axis), and
// in 2D a closed slab one diameter either side of the disks' plane z = 0.5
// (no contact cutoff fits the fluid's one-cell period).
void coupled_dem_box(dem::DemParams& p, const Grid& grid, int dim, double diameter);

// ----------------------------------------------------------------- checks
// Device and host memory of the grid with about `particles` particles
// (ResourceError, exit 4), before anything is built.
void check_particles_memory(const Config& root, const CoupledKeys& keys, const lbm::LbmSetup& fluid, double particles,
                            Backend backend);
// A random packing of radius r at this fraction of [lo, hi): the particles
// fit the box along every axis (particles.diameter), then the memory of the
// grid with their count.
void check_particles_random(const Config& root, const CoupledKeys& keys, const Config& pc, const lbm::LbmSetup& fluid,
                            const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                            const std::array<bool, 3>& periodic, double solid_fraction, double r, Backend backend);
// With the particles made: box, walls, overlaps, an unbalanced weight in a
// periodic box (`balance`: physics.balance_weight), DEM sub-steps against the
// shortest contact, Mach number, memory and the plan (`force`: --force;
// `steps_key` names the step count).
void check_particles_scene(const Config& root, const lbm::LbmSetup& fluid, const dem::DemParams& dem,
                           const dem::HostParticles& p, const CoupledParams& cp, bool balance, long steps,
                           Backend backend, bool force, const std::string& steps_key);

}  // namespace lbdem::imb
