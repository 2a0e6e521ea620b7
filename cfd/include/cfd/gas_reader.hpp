#pragma once
// The reader of a case file's `gas` section (the fluidized_bed scene): density,
// viscosity, cubic cells that fill the box, time step, drag law, void-fraction
// deposition, the minimum gas fraction, an initial velocity, the six faces'
// boundaries (periodic, no_slip, free_slip, inlet with an optional patch,
// outlet) and the pressure solver. The gas memory is checked before anything
// is built (core/run_checks.hpp), and the result by cfd::validate. Messages
// name the key as written (Config::fail; cfd::GasKeys for validate's).
#include <array>

#include "cfd/gas_grid.hpp"
#include "cfd/gas_solver.hpp"
#include "core/config.hpp"
#include "core/exec.hpp"
#include "core/vec.hpp"
#include "dem/system.hpp"

namespace lbdem::cfd {

struct GasSection {
  GasGridView grid;
  GasParams gas;
  Vec3d initial_velocity{};
  // gas.force_coupling: false = sequential (the gas step, then the DEM
  // sub-steps with its forces), true = lagged (cfd/lagged_coupling.hpp).
  bool lagged_forces = false;
};

// Section `gs` for the box [lo, hi] on `backend` (its memory).
void read_gas(const Config& gs, const std::array<double, 3>& lo, const std::array<double, 3>& hi, Backend backend,
              GasSection& c);

// The bed's optional `dem` section: the DEM sub-steps per gas step from one
// of dem.substeps, dem.dt (the largest step that divides gas_dt and is not
// above it) or dem.steps_per_collision (of the shortest collision time t_c of
// `particles`, default 50), the neighbour-list skin (default 0.2 rmin) and
// the force path. Sets p's step gas_dt / sub-steps and checks it against t_c;
// returns the sub-steps. Messages name the key and the file (root.source()).
int read_bed_dem(const Config& root, double gas_dt, double rmin, const dem::HostParticles& particles,
                 dem::DemParams& p);

}  // namespace lbdem::cfd
