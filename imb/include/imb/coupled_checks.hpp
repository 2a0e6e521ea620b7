#pragma once
// Up-front checks of a coupled PSM-DEM set-up (imb/coupled.hpp): a case that
// would blow up, or silently compute something else, is refused before the
// first step with a ConfigError that names the parameter (by the key the
// case file set it with, CoupledParams::keys), its value, the reason and a
// value that would work.
//
// Everything is in lattice units (dx = dt_fluid = 1, fluid density
// CoupledParams::fluid_density), as CoupledSolver expects.
//
// What is checked, in order:
//  1. consistency of the three parameter sets: DEM dt = 1 / dem_substeps,
//     coupling gravity = DEM gravity, periodic axes and box lengths of the DEM
//     = those of the lattice (else particle images wrap differently in the
//     fluid and in the DEM);
//  2. particle density: rho_s / rho_f >= CoupledLimits::min_density_ratio
//     (the explicit coupling diverges for light particles: the step's force
//     on a particle is about rho_f sum(B) (u - v), so v is over-corrected with
//     a gain rho_f sum(B) / m that exceeds 2 when rho_s / rho_f < sum(B) / 2V);
//  3. DEM sub-steps: the shortest contact (dem/contact.hpp t_c) must span at
//     least DemParams::min_steps_per_collision DEM steps; the message names
//     the sub-step count's key and the smallest count that works;
//  4. a velocity scale u_ref of the case (CoupledScales below: fastest
//     initial particle surface speed, largest settling speed under gravity
//     relative to the fluid, fastest boundary velocity) against
//       - the Mach number u_ref sqrt(3) <= CoupledLimits::max_mach, and
//       - the cell Reynolds number u_ref dx / nu <= CoupledLimits::max_cell_reynolds
//         (what makes tau -> 1/2 fail: at tau = 0.501 a sphere at u = 0.04 blows up);
//  5. a fully periodic domain with gravity or a fluid body force: the net
//     force on fluid + particles must vanish (first paper, Sec. 2: the body
//     force balances the particles' weight), else the mean velocity grows
//     without bound; the message gives balancing_body_force().
#include <limits>
#include <string>

#include "dem/particles.hpp"
#include "halo/comm.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "lbm/solver.hpp"

namespace lbdem::imb {

// Limits of the checks, measured with this code (tests/imb/test_psm_hard_cases.cpp,
// a d = 10 sphere moving at u in a 30^3 periodic box, TRT Lambda 3/16 or 1/4, and
// BGK; 10,000 steps each):
//   cell Reynolds u/nu: stable at 90 (tau 0.501, u 0.03; tau 0.505, u 0.15),
//                       blows up at 105 and 120 (tau 0.501, u 0.035 and 0.04);
//   Mach u sqrt(3):     stable at 0.35 (tau 0.51, u 0.2), blows up at 0.43 (u 0.25)
//                       within 200 steps. The fluid next to the particle moves up
//                       to 1.7 u, so the fluid's own Mach number is larger.
// (Lookup-table fractions, NEBB, Noble-Torczynski B, fluid density 1, fp64.)
// The defaults keep a margin of 1.5 below the cell-Reynolds failures and of
// 1.2-1.4 below the Mach failure.
struct CoupledLimits {
  double max_mach = 0.3;
  double max_cell_reynolds = 60.0;
  // Relative imbalance of the net force (fluid body force + particles' net
  // weight) tolerated in a fully periodic domain, as a fraction of the weight.
  double max_force_imbalance = 1e-3;
  // Smallest particle/fluid density ratio: a sphere at 0.01 (30^3, 3000 steps)
  // blows up at 0.3 for tau 0.6, 0.8, 1.5 and at 0.4 for tau 1.5; 0.5 runs.
  // 0.5 is the bound of item 2 with sum(B) = V (B <= eps).
  double min_density_ratio = 0.5;
};

// Velocity and time scales a set-up implies (lattice units).
struct CoupledScales {
  double nu = 0;                 // (tau - 1/2) / 3
  double particle_speed = 0;     // max over particles of |v| + |w| r at t = 0
  std::int64_t fastest_id = -1;  // its global id
  double settling_speed = 0;     // max over particles of the terminal speed relative to the fluid
  std::int64_t settling_id = -1;
  double wall_speed = 0;         // max |u| of Velocity boundary entries
  double u_ref = 0;              // max of the three
  double mach = 0;               // u_ref sqrt(3)
  double cell_reynolds = 0;      // u_ref / nu
  double collision_time = std::numeric_limits<double>::infinity();  // dem::min_collision_time with these particles
  int min_substeps = 1;          // DEM sub-steps per fluid step that resolve it
};

// Terminal settling speed of a sphere of diameter d and mass m in a fluid of
// density rho_f and kinematic viscosity nu under gravity |g| (lattice units):
// the speed at which the drag (Schiller & Naumann 1933, Cd = 24/Re (1 +
// 0.15 Re^0.687), Re < 1000; Cd = 0.44 above) balances (m - rho_f V) |g|.
// An upper bound in a suspension (hindrance only slows it). 0 when it floats.
double terminal_speed(double d, double m, double rho_f, double nu, double g);

CoupledScales coupled_scales(const lbm::LbmSetup& fluid, const dem::DemParams& dem, const dem::HostParticles& p,
                             const CoupledParams& cp);

// Throws ConfigError (see the header comment); returns the scales it checked.
// `comm`: p holds this rank's particles only (each rank its own), and the net
// force of a fully periodic domain sums the weights over the ranks
// (collective); null: p is every particle.
CoupledScales check_coupled_setup(const lbm::LbmSetup& fluid, const dem::DemParams& dem, const dem::HostParticles& p,
                                  const CoupledParams& cp, const CoupledLimits& limits = {},
                                  const halo::Comm* comm = nullptr);

}  // namespace lbdem::imb
