#pragma once
// Shared set-up for the DEM tests.
#include <gtest/gtest.h>

#include <cmath>

#include "common/backends.hpp"
#include "dem/contact.hpp"
#include "dem/system.hpp"

namespace lbdem::dem::test {

inline constexpr double kG = 9.80665;

// A closed (non-periodic) box with no walls, no gravity.
inline DemParams open_box(double half) {
  DemParams p;
  p.lo = {-half, -half, -half};
  p.hi = {half, half, half};
  return p;
}

inline Material simple_material(double k, double e, double mu = 0.0) {
  Material m;
  m.stiffness = k;
  m.restitution = e;
  m.friction = mu;
  m.wall_stiffness = k;
  m.wall_restitution = e;
  m.wall_friction = mu;
  return m;
}

inline double max_abs_component(const std::vector<Vec3d>& v) {
  double m = 0;
  for (const auto& a : v) m = std::max({m, std::fabs(a.x), std::fabs(a.y), std::fabs(a.z)});
  return m;
}

}  // namespace lbdem::dem::test
