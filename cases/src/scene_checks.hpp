#pragma once
// What the scenes still check themselves while their case file is parsed:
// the fluid scenes' geometry and Mach number with the key that set the speed,
// and their plan (core/run_checks.hpp, lbm/fluid_checks.hpp). Each module
// checks its own state (dem::check_dem_scene, imb::check_particles_scene,
// imb::check_fixed_sphere, lbm::check_fluid_memory, ...), naming the keys a
// scene's reader hands it (imb::CoupledKeys, FixedSphereSpec::keys,
// cfd::GasKeys), so no message is rewritten afterwards.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "cases/scenes.hpp"
#include "core/config.hpp"
#include "core/error.hpp"
#include "core/exec.hpp"
#include "core/run_checks.hpp"
#include "dem/particle_checks.hpp"
#include "dem/particles.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "imb/coupled_checks.hpp"
#include "imb/coupled_memory.hpp"
#include "lbm/fluid_checks.hpp"
#include "lbm/solver.hpp"

namespace lbdem::cases {

// The backend a run with these options will use (as resolve_backend, without
// its log line).
Backend planned_backend(const RunOptions& opt);

// ----------------------------------------------------------------- per scene
// One call from each scene's parse (the checks above, with the scene's keys).

// Fluid scenes (SI units): grid sizes that mean something, then the Mach
// number with the key that set the speed (before derive_units()).
void check_fluid_scene(const Config& root, const std::string& scene, const std::string& mode,
                       const std::vector<long>& cells, const Config& scene_section, double dx, double nu,
                       double u_ref, double max_mach, std::optional<double> tau, std::optional<double> dt);
// ... and the plan, once the step count is known.
void check_fluid_plan(const Config& root, const RunOptions& opt, double steps, double fluid_cells);

}  // namespace lbdem::cases
