#pragma once
// Shared set-up for the DEM tests.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "common/backends.hpp"
#include "dem/contact.hpp"
#include "dem/init.hpp"
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

// Mueller's particles (d = 1.2 mm, k = 800 N/m, e = 0.97, mu 0.1 with
// friction, none without) packed at solid fraction 0.35 (packing seed `seed`)
// in the lowest two thirds of a closed 12 x 6 x 30 mm box (each side `scale`
// times that) with walls on all six faces, under gravity, moving at random
// speeds up to 0.3 m/s per axis (and, with `spins`, up to 300 rad/s; one
// generator seeded `vseed`, velocities first): the contacts, rebuilds and
// reports of a bubbling bed's fast particles. dt: a fiftieth of the collision
// time; the coupling input is on (external_forcing).
struct MovingBed {
  DemParams p;
  HostParticles h;
  MovingBed(bool friction, std::uint64_t seed, std::uint64_t vseed, double scale = 1, bool spins = false) {
    const double X = 0.012 * scale, Y = 0.006 * scale, Z = 0.03 * scale;
    RandomPackingSpec spec;
    spec.lo = {0, 0, 0};
    spec.hi = {X, Y, 0.02 * scale};
    spec.periodic = {false, false, false};
    spec.solid_fraction = 0.35;
    spec.r_min = spec.r_max = 0.6e-3;
    spec.density = 1000;
    spec.seed = seed;
    h = random_packing(spec);
    std::uint64_t z = vseed;
    auto uniform = [&z] {
      z = z * 6364136223846793005ULL + 1442695040888963407ULL;
      return static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0) * 2.0 - 1.0;
    };
    for (auto& v : h.v) v = {0.3 * uniform(), 0.3 * uniform(), 0.3 * uniform()};
    if (spins) {
      h.w.resize(h.v.size());
      for (auto& w : h.w) w = {300 * uniform(), 300 * uniform(), 300 * uniform()};
    }
    p.lo = {0, 0, 0};
    p.hi = {X, Y, Z};
    for (int a = 0; a < 3; ++a) {
      Vec3d n{0, 0, 0};
      n[a] = 1;
      p.walls.push_back(Wall{{0, 0, 0}, n});
      n[a] = -1;
      p.walls.push_back(Wall{{X, Y, Z}, n});
    }
    p.material.stiffness = p.material.wall_stiffness = 800;
    p.material.restitution = p.material.wall_restitution = 0.97;
    p.material.friction = p.material.wall_friction = friction ? 0.1 : 0.0;
    p.friction = friction;
    p.gravity = {0, 0, -kG};
    p.external_forcing = true;
    p.dt = min_collision_time(p, h) / 50;
  }
};

}  // namespace lbdem::dem::test
