#pragma once

#include <limits>
// Checks that make a scene meaningless or impossible, run while a case file is
// parsed (before any output folder, grid or particle array is made):
//
//  - particles against the box: a centre outside the domain, a centre behind
//    a wall (below a floor), a particle wider than the box, particles that
//    overlap each other or a wall (such contacts give forces that blow the
//    run up within a few steps);
//  - grids too small to mean anything (a 1 x 1 cavity);
//  - the Mach number of a fluid scene, naming the key that set the speed and
//    every way out;
//  - memory of the grid and the particles, estimated from the sizes in the
//    file before either is built (ResourceError, exit code 4);
//  - the planned run: longer than a year of wall time even at the fastest
//    speed this code reaches needs --force;
//  - the key names of messages: the coupled and fixed-sphere code below the
//    scenes names its parameters by their C++ names (coupling.dem_substeps);
//    with_user_keys() rewrites them to the keys of the case file
//    (dem.substeps), one table per scene.
#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cases/scenes.hpp"
#include "core/config.hpp"
#include "core/error.hpp"
#include "core/exec.hpp"
#include "dem/particles.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "lbm/solver.hpp"

namespace lbdem::cases {

// ----------------------------------------------------------------- particles
// The box the particles must lie in: the DEM box (lo, hi, periodic axes,
// walls). `dim` = 2 skips the z axis (a 2D scene's particles are disks in a
// one-cell-thick slab). `key` names the particles' section for messages,
// `box_key` the key that sets the box.
struct ParticleBox {
  std::array<double, 3> lo{0, 0, 0}, hi{1, 1, 1};
  std::array<bool, 3> periodic{false, false, false};
  std::vector<dem::Wall> walls;
  int dim = 3;
  std::string key = "particles";
  std::string box_key = "domain";
  std::string walls_key = "walls";
};
ParticleBox particle_box(const dem::DemParams& p, int dim, const std::string& box_key, const std::string& walls_key);

// Deepest overlap accepted between two particles or a particle and a wall,
// as a fraction of the smaller radius: touching particles, and pre-loaded
// contacts such as the stacked-spheres test of Yu et al. (cases/
// dem_03_stacked_particles.yaml, 10 %), pass; coincident or deeply
// interpenetrating particles, whose contact forces blow the run up in its
// first steps, do not.
constexpr double kMaxInitialOverlap = 0.2;

// Throws ConfigError (file, key, particle id, how far, what to change).
void check_particles_in_box(const Config& root, const dem::HostParticles& p, const ParticleBox& box);
void check_particle_overlaps(const Config& root, const dem::HostParticles& p, const ParticleBox& box);

// ----------------------------------------------------------------- grids
// The fewest fluid cells along an axis for which a scene means something:
// `what` says why (e.g. "a lid-driven cavity needs at least 4 cells per axis
// to hold its vortex").
void check_min_cells(const Config& root, const std::string& key, const std::vector<long>& cells, long min_cells,
                     const std::string& what);

// ----------------------------------------------------------------- Mach (SI fluid scenes)
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

// The resolved particle scene (lattice units): the Mach number of its
// velocity scale (imb::coupled_scales) with the key that set it and every
// way out; refuses before imb::check_coupled_setup() would.
void check_particles_mach(const Config& root, const lbm::LbmSetup& fluid, const dem::DemParams& dem,
                          const dem::HostParticles& p, double fluid_density, const std::array<double, 3>& gravity,
                          double max_mach);

// ----------------------------------------------------------------- memory
// The backend a run with these options will use (as resolve_backend, without
// its log line).
Backend planned_backend(const RunOptions& opt);
// Bytes of a lattice Boltzmann grid of `cells` cells (lbm::lbm_memory per
// cell, in double so that absurd sizes do not wrap).
double lbm_grid_bytes(const lbm::LbmSetup& s, double cells);
// Device memory of a coupled run by component, before anything is allocated:
// the fluid's (lbm::lbm_memory), the PSM coupling's (imb::psm_memory, for
// `particles` particles of the largest radius cp.psm.map.max_radius) and the
// DEM's ("DEM particles and lists": an upper bound per particle from the
// DEM's layout; its neighbour-list capacity is fitted at the first build).
MemoryUse coupled_memory(const lbm::LbmSetup& fluid, const imb::CoupledParams& cp, double particles, Backend b);
// The table `lbdem check` prints: one line per component (bytes per cell and
// total), then the total.
std::string memory_table(const MemoryUse& m, double cells);
// Refuses (ResourceError, exit 4) a coupled run whose coupled_memory() does
// not fit the backend's free memory, naming the biggest components.
void check_coupled_memory(const Config& root, const lbm::LbmSetup& fluid, const imb::CoupledParams& cp,
                          double particles, const RunOptions& opt);
// Bytes per DEM particle: host copies (the case's HostParticles and the
// solver's download) and the solver's own arrays (state, sort, cell and
// neighbour lists): a lower bound, so that a refusal is certain.
constexpr double kDemHostBytesPerParticle = 2 * 152.0;
constexpr double kDemDeviceBytesPerParticle = 400.0;
// Refuses (ResourceError) when `device_bytes` exceed the backend's free memory
// or `host_bytes` (plus device_bytes on the host backend) the host's. `key`
// names what sets the size, `fix` the way out.
void check_memory(const Config& root, Backend b, double device_bytes, double host_bytes, const std::string& key,
                  const std::string& what, const std::string& fix);

// ----------------------------------------------------------------- the plan
// Fastest rates this code reaches on one GPU of the largest kind (H100/H200),
// and the least wall time of one step (kernel launches): a planned run that
// needs more than a year even at these rates is refused without --force.
constexpr double kFastestCellUpdatesPerSecond = 1e10;
constexpr double kFastestParticleStepsPerSecond = 2e9;
constexpr double kLeastSecondsPerStep = 1e-6;
constexpr double kMaxPlannedSeconds = 365.25 * 24 * 3600;
// `steps`: planned steps, `cell_updates` / `particle_steps` per step,
// `steps_key` the key(s) that set the step count.
void check_plan(const Config& root, const RunOptions& opt, double steps, double cell_updates, double particle_steps,
                const std::string& steps_key);
// A step count computed in double (end time over dt) as a long, saturated at
// the largest long instead of overflowing; check_plan refuses such a plan.
inline long saturating_steps(double steps) {
  return steps < 9.2e18 ? static_cast<long>(steps) : std::numeric_limits<long>::max();
}

// ----------------------------------------------------------------- per scene
// One call from each scene's parse (the checks above, with the scene's keys).

// DEM scene: host memory of `count` particles before they are made (`key`
// sets the count); then the particles against the box and walls, overlaps,
// device memory and the plan.
void check_dem_particle_count(const Config& pc, double count, const std::string& key);
double random_packing_count(const std::array<double, 3>& lo, const std::array<double, 3>& hi, double solid_fraction,
                            double r_max, int dim = 3);
// A random packing (dem::random_packing) of the box [lo, hi]: the largest
// particle fits along every axis, and the particles' host memory.
void check_random_fill(const Config& pc, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                       const std::array<bool, 3>& periodic, double r_max, const std::string& box_key);
void check_dem_random_packing(const Config& pc, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                              const std::array<bool, 3>& periodic, double solid_fraction, double r_max);
void check_dem_scene(const Config& root, const dem::DemParams& p, const dem::HostParticles& hp, long steps,
                     const RunOptions& opt);

// Fluid scenes (SI units): grid sizes that mean something, then the Mach
// number with the key that set the speed (before derive_units()).
void check_fluid_scene(const Config& root, const std::string& scene, const std::string& mode,
                       const std::vector<long>& cells, const Config& scene_section, double dx, double nu,
                       double u_ref, double max_mach, std::optional<double> tau, std::optional<double> dt);
// ... and the plan, once the step count is known.
void check_fluid_plan(const Config& root, const RunOptions& opt, double steps, double fluid_cells);

// Fixed sphere: the period L = d / chi, memory, plan.
void check_fixed_sphere(const Config& root, int dim, double diameter, double chi, lbm::Precision precision,
                        lbm::StreamKind streaming, long max_steps, const RunOptions& opt);

// Resolved particles: grid (+ `particles` estimated particles) memory before
// anything is built; then, with the particles made, box, walls, overlaps,
// Mach number and plan.
void check_particles_memory(const Config& root, const lbm::LbmSetup& fluid, double particles, const RunOptions& opt);
void check_particles_random(const Config& root, const Config& pc, const lbm::LbmSetup& fluid,
                            const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                            const std::array<bool, 3>& periodic, double solid_fraction, double r,
                            const RunOptions& opt);
void check_particles_scene(const Config& root, const lbm::LbmSetup& fluid, const dem::DemParams& dem,
                           const dem::HostParticles& p, const std::array<double, 3>& gravity, bool balance,
                           int dem_substeps, long steps, const RunOptions& opt);

// ----------------------------------------------------------------- key names
using KeyMap = std::vector<std::pair<std::string, std::string>>;  // internal name -> key in the file
// The table of a scene ("particles", "fixed_sphere", "dem", the fluid scenes).
const KeyMap& key_map(const std::string& scene);
// `msg` with every internal name of `map` (whole dotted names only) replaced.
std::string user_keys(const std::string& msg, const KeyMap& map);

// Runs f(); an lbdem::Error it throws is thrown again, same type, with its
// message in the scene's key names.
template <class F>
auto with_user_keys(const std::string& scene, F&& f) -> decltype(f()) {
  const KeyMap& m = key_map(scene);
  try {
    return f();
  } catch (const ConfigError& e) {
    throw ConfigError(user_keys(e.what(), m));
  } catch (const DivergenceError& e) {
    throw DivergenceError(user_keys(e.what(), m));
  } catch (const ResourceError& e) {
    throw ResourceError(user_keys(e.what(), m));
  } catch (const CudaError& e) {
    throw CudaError(user_keys(e.what(), m));
  }
}

}  // namespace lbdem::cases
