#pragma once
// The narrow view of the particles that coupling modules (PSM, unresolved
// CFD-DEM) see, without knowing the rest of DEM. Trivially copyable; pass it
// by value into kernels. Arrays are structure-of-arrays of 32-byte Real4
// records (one aligned vector load per record on the GPU), indexed by the
// current storage order (which changes at neighbour-list rebuilds: never keep
// an index across a DEM step; use the global id if identity is needed).
#include "core/hd.hpp"
#include "core/vec.hpp"

namespace lbdem::dem {

struct alignas(32) Real4 {
  double x, y, z, w;
};
LBDEM_HD inline Vec3d xyz(const Real4& a) { return {a.x, a.y, a.z}; }
LBDEM_HD inline void set_xyz(Real4& a, const Vec3d& v) { a.x = v.x; a.y = v.y; a.z = v.z; }

struct ParticleView {
  Real4* pos_r = nullptr;     // centre x,y,z [m], w = radius [m]
  Real4* vel_im = nullptr;    // velocity [m/s], w = 1/mass [1/kg]
  Real4* omega_ii = nullptr;  // angular velocity [rad/s], w = 1/moment of inertia [1/(kg m^2)]
  // Coupling input: hydrodynamic force [N] and torque [N m] per particle, held
  // over DEM sub-steps and added to the contact forces each sub-step. The
  // coupling writes or accumulates them (w unused). Present only when the
  // system was created with external forcing enabled (else null).
  Real4* ext_force = nullptr;
  Real4* ext_torque = nullptr;
  // Total force / torque of the last DEM force evaluation (read-only for couplers).
  const Real4* force = nullptr;
  const Real4* torque = nullptr;
  Index n = 0;
};

}  // namespace lbdem::dem
