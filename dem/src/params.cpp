// Time-step checks against the collision time.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <fmt/format.h>

#include "core/error.hpp"
#include "dem/system.hpp"

namespace lbdem::dem {

const char* to_string(ForcePath p) { return p == ForcePath::Particle ? "particle" : "pair"; }
const char* to_string(RebuildCheck c) { return c == RebuildCheck::Lookahead ? "lookahead" : "every_step"; }
const char* to_string(ContactOrder o) { return o == ContactOrder::Storage ? "storage" : "global_id"; }

double min_collision_time(const DemParams& p, const HostParticles& hp) {
  if (hp.size() == 0) return std::numeric_limits<double>::infinity();
  const double mmin = *std::min_element(hp.mass.begin(), hp.mass.end());
  const Material& mat = p.material;
  double tc = std::numeric_limits<double>::infinity();
  // Two of the lightest particles (m_eff = m/2) give the shortest particle contact.
  if (hp.size() > 1 && mat.stiffness > 0) tc = std::min(tc, collision_time(mat.stiffness, 0.5 * mmin, mat.restitution));
  if (!p.walls.empty() && mat.wall_stiffness > 0)
    tc = std::min(tc, collision_time(mat.wall_stiffness, mmin, mat.wall_restitution));
  if (p.friction) {
    // Tangential spring: oscillation of the contact point, effective mass
    // m_eff * 2/7 for solid spheres; its period must be resolved as well.
    const double kt = mat.tangential_stiffness_ratio;
    if (kt > 0) {
      if (hp.size() > 1 && mat.stiffness > 0)
        tc = std::min(tc, M_PI / std::sqrt(kt * mat.stiffness / (0.5 * mmin * 2.0 / 7.0)));
      if (!p.walls.empty() && mat.wall_stiffness > 0)
        tc = std::min(tc, M_PI / std::sqrt(kt * mat.wall_stiffness / (mmin * 2.0 / 7.0)));
    }
  }
  return tc;
}

void check_time_step(const DemParams& p, const HostParticles& hp, const std::string& key) {
  const double tc = min_collision_time(p, hp);
  if (!(p.dt > 0)) throw ConfigError(fmt::format("{}: time step {} s must be > 0", key, p.dt));
  if (std::isfinite(tc) && p.dt > tc / p.min_steps_per_collision) {
    throw ConfigError(fmt::format(
        "{}: time step {:.6g} s is too large: the shortest collision lasts t_c = {:.6g} s and needs at least {} "
        "steps (dt <= {:.6g} s); lower dt or soften the contacts",
        key, p.dt, tc, p.min_steps_per_collision, tc / p.min_steps_per_collision));
  }
}

}  // namespace lbdem::dem
