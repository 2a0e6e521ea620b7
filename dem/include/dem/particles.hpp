#pragma once
// Particles on the host: what initialisation produces and download() returns.
#include <cstdint>
#include <vector>

#include "core/hd.hpp"
#include "core/vec.hpp"

namespace lbdem::dem {

struct HostParticles {
  std::vector<Vec3d> x;      // centre [m]
  std::vector<Vec3d> v;      // velocity [m/s]
  std::vector<Vec3d> w;      // angular velocity [rad/s]
  std::vector<double> r;     // radius [m]
  std::vector<double> mass;  // [kg]
  std::vector<std::int64_t> id;  // global id (unique)
  std::vector<int> type;
  // Filled by download(): last evaluated force [N] and torque [N m].
  std::vector<Vec3d> f, t;
  // Set by random_packing (which places no two particles closer than the sum
  // of their radii; tests/dem DemInit checks it), reset by add(): the set-up
  // checks then skip their overlap search, which costs more than the packing.
  bool apart_by_construction = false;

  Index size() const { return static_cast<Index>(x.size()); }
  // Solid sphere of density rho [kg/m^3]; id defaults to the running count.
  void add(const Vec3d& pos, double radius, double rho, const Vec3d& vel = {}, const Vec3d& omega = {},
           int typ = 0, std::int64_t gid = -1) {
    apart_by_construction = false;
    x.push_back(pos);
    v.push_back(vel);
    w.push_back(omega);
    r.push_back(radius);
    mass.push_back(rho * 4.0 / 3.0 * 3.14159265358979323846 * radius * radius * radius);
    id.push_back(gid < 0 ? static_cast<std::int64_t>(id.size()) : gid);
    type.push_back(typ);
  }
};

// Moment of inertia of a solid sphere [kg m^2].
inline double sphere_inertia(double m, double r) { return 0.4 * m * r * r; }

}  // namespace lbdem::dem
