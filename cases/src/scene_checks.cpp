#include "scene_checks.hpp"

#include <algorithm>
#include <cmath>

#include "core/buffer.hpp"
#include "core/run_length.hpp"

namespace lbdem::cases {

using checks::axis_name;
using checks::num;
using checks::vec;
using dem::kDemDeviceBytesPerParticle;
using dem::kDemHostBytesPerParticle;

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

// ----------------------------------------------------------------- key names
const KeyMap& key_map(const std::string& scene) {
  // The coupled solver and its checks (imb/) name the parameters of
  // CoupledParams and DemParams; the particles scene reads them from these keys.
  static const KeyMap particles = {
      {"coupling.dem_substeps", "dem.substeps"},
      {"dem.dt", "the DEM time step"},  // 1 / dem.substeps, not a key of the file
      {"coupling.gravity", "physics.gravity"},
      {"dem.gravity", "physics.gravity"},
      {"coupling.slots", "psm.slots"},
      {"material.stiffness", "dem.stiffness"},
      {"material.restitution", "dem.restitution"},
      {"material.wall_stiffness", "dem.wall_stiffness"},
      {"material.wall_restitution", "dem.wall_restitution"},
      {"material.friction", "dem.friction"},
      {"material.wall_friction", "dem.wall_friction"},
      {"fluid.body_force", "physics.balance_weight"},
      {"dem.periodic", "domain.periodic"},
      {"dem.lo", "domain.cells"},
      {"dem.hi", "domain.cells"},
  };
  // run_fixed_sphere() (imb/src/fixed_sphere.cpp) names FixedSphereSpec fields.
  static const KeyMap fixed_sphere = {
      {"fixed_sphere.dim", "geometry.dim"},
      {"fixed_sphere.chi", "geometry.chi"},
      {"fixed_sphere.diameter", "geometry.diameter"},
      {"coupling.slots", "psm.slots"},
  };
  static const KeyMap none;
  if (scene == "particles") return particles;
  if (scene == "fixed_sphere") return fixed_sphere;
  return none;
}

std::string user_keys(const std::string& msg, const KeyMap& map) {
  auto ident = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  std::string out;
  std::size_t i = 0;
  while (i < msg.size()) {
    // A dotted name starts where no name character precedes it.
    if (ident(msg[i]) && (i == 0 || (!ident(msg[i - 1]) && msg[i - 1] != '.'))) {
      std::size_t j = i;
      while (j < msg.size() && (ident(msg[j]) || (msg[j] == '.' && j + 1 < msg.size() && ident(msg[j + 1])))) ++j;
      const std::string word = msg.substr(i, j - i);
      auto it = std::find_if(map.begin(), map.end(), [&](const auto& kv) { return kv.first == word; });
      out += it != map.end() ? it->second : word;
      i = j;
    } else {
      out += msg[i++];
    }
  }
  return out;
}

}  // namespace lbdem::cases
