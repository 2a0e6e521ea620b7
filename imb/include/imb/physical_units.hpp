#pragma once
// `units: physical` in a resolved (PSM) scene: the SI keys of the fluid,
// particles, domain and time sections turned into lattice units once, at parse
// time. The cell size dx follows from the particle diameter and the resolution
// d/l (particles.cells_per_diameter), the time step from fluid.tau or time.dt
// with the viscosity (core/units.hpp). Messages name the key as written.
#include <vector>

#include "core/config.hpp"
#include "core/units.hpp"

namespace lbdem::imb {

struct PhysicalGrid {
  Units units;
  double cells_per_diameter = 0;  // d/l: the particle diameter in cells, exactly
  std::vector<long> cells;        // domain.size / dx along each axis
};

// Reads particles.diameter and cells_per_diameter, fluid.density,
// kinematic_viscosity and tau, time.dt and domain.size (a whole number of
// cells along each axis, 1 to 2^20); refuses tau above 5.
PhysicalGrid read_physical_grid(const Config& root, const Config& d, const Config& f, const Config& pc,
                                const Config& t);

// time.steps, or (physical units) time.end in seconds, as a step count.
long read_coupled_steps(const Config& t, const Units& U, bool physical);

}  // namespace lbdem::imb
