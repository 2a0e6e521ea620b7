#include "scene_checks.hpp"

#include <cmath>

#include "core/run_length.hpp"

namespace lbdem::cases {

Backend planned_backend(const RunOptions& opt) {
  if (opt.backend == "cpu" || opt.backend == "host") return Backend::Host;
  return cuda_unavailable_reason().empty() ? Backend::Cuda : Backend::Host;
}

// ----------------------------------------------------------------- per scene
void check_fluid_scene(const Config& root, const std::string& scene, const std::string& mode,
                       const std::vector<long>& cells, const Config& sc, double dx, double nu, double u_ref,
                       double max_mach, std::optional<double> tau, std::optional<double> dt) {
  lbm::MachInput m;
  m.dx = dx;
  m.nu = nu;
  m.u_ref = u_ref;
  m.max_mach = max_mach;
  m.tau = tau.value_or(0);
  m.dt = dt.value_or(0);
  if (scene == "channel") {
    check_min_cells(root, "domain.cells", {cells[1]}, 3, "a channel needs at least 3 fluid cells across (y) for a "
                                                          "velocity profile between its walls");
    if (mode == "inlet_outlet")
      check_min_cells(root, "domain.cells", {cells[0]}, 3, "an inlet/outlet channel needs at least 3 cells along x");
    if (mode == "periodic") {
      m.speed_key = sc.full_key("body_acceleration");
      m.speed_what = "Poiseuille centre-line speed a H^2 / (8 nu)";
      m.speed_scale = u_ref / sc.number("body_acceleration");
    } else {
      m.speed_key = sc.full_key("inlet_velocity");
      m.speed_what = "centre-line speed of the developed profile, 1.5 times the inlet velocity";
      m.speed_scale = 1.5;
    }
  } else if (scene == "taylor_green") {
    check_min_cells(root, "domain.cells", cells, 4, "a Taylor-Green vortex needs at least 4 cells per period");
    m.speed_key = sc.full_key("velocity");
  } else if (scene == "lid_driven_cavity") {
    check_min_cells(root, "domain.cells", cells, 4,
                    "a lid-driven cavity needs at least 4 fluid cells per axis for its vortex between the walls");
    m.speed_key = sc.full_key("lid_velocity");
  } else {
    m.speed_key = sc.full_key(sc.has("reference_velocity") ? "reference_velocity" : "initial_velocity");
    m.speed_what = sc.has("reference_velocity") ? "" : "the length of the initial velocity";
  }
  if (!(m.speed_scale > 0) || !std::isfinite(m.speed_scale)) m.speed_scale = 1;
  lbm::check_fluid_mach(root, m);
}

void check_fluid_plan(const Config& root, const RunOptions& opt, double steps, double fluid_cells) {
  std::string key = "time.steps";
  if (opt.steps) key = "--steps";
  else if (const auto t = root.optional_section("time"); t && t->has(end_key(*t))) key = t->full_key(end_key(*t)) + " / dt";
  check_plan(root, opt.force, steps, fluid_cells, 0, key);
}

}  // namespace lbdem::cases
