#pragma once
// The narrow view of particles the solid-fraction mapping needs: centres and
// radii in lattice units, structure of arrays, on the backend that maps them.
// 2D runs (disks) ignore z (it may be null).
#include "core/hd.hpp"

namespace lbdem::imb {

struct SphereView {
  const double* x = nullptr;
  const double* y = nullptr;
  const double* z = nullptr;
  const double* r = nullptr;
  Index n = 0;
  int stride = 1;  // element i of each array at [i * stride] (4: DEM's Real4 records)
  // Optional (null: at rest): translational and angular velocity, same stride.
  // The map stores each slot's solid velocity at the cell centre from them
  // (the PSM step reads it there), so velocities are those at map time.
  const double* vx = nullptr;
  const double* vy = nullptr;
  const double* vz = nullptr;
  const double* wx = nullptr;
  const double* wy = nullptr;
  const double* wz = nullptr;
};

}  // namespace lbdem::imb
