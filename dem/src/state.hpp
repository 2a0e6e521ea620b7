#pragma once
// The kernel-side view of a DemSystem (every array a per-particle or per-pair
// kernel reads, by pointer, and the set-up constants), and the launch helper
// all DEM kernels go through. Include only from kernel translation units.
#include <cstdint>

#include "core/exec.hpp"
#include "core/hd.hpp"
#include "dem/contact.hpp"
#include "dem/geometry.hpp"
#include "dem/particle_view.hpp"

namespace lbdem::dem {

// One contact of the pair path: particle i and the slot of its partner in i's
// neighbour-list row.
struct PairIJ {
  int i, j;
};

// Everything a per-particle or per-pair kernel reads, by pointer. Filled from
// the particle store (ParticleStore::bind), the neighbour list
// (NeighbourList::bind) and the set-up constants (DemSystem::Impl::physics).
struct State {
  Real4 *pos, *vel, *omg, *frc, *trq;
  Real4 *frc_old, *trq_old;  // forces of the previous step (velocity predictor)
  Real4 *vpr, *wpr;          // predicted velocity / angular velocity at the force time (w: 1/m, 1/I)
  const Real4 *extf, *extt;  // null when no coupling input
  Real4* x0;                 // positions at the last build
  const std::int64_t* gid;
  int* nbr;
  int* ncount;
  Vec3d* hist;   // [s * n + i] tangential history (friction)
  Vec3d* whist;  // [w * n + i]
  Index n;
  int cap;
  Box box;
  Walls walls;
  ContactLaw pp, pw;
  Vec3d gravity, body;
  double dt, half_skin2, skin;
  int* flags;  // [0] neighbour list overflow, [1] largest neighbour count seen (list build)
  int lanes;   // threads per particle of the particle path's force kernel on the device (1, 2, 4, 8, 16)
};

// for_each, but tiny host problems run serially (an OpenMP region costs more
// than a two-particle step, and the verification tests are tiny).
template <class F>
void launch(const Exec& ex, Index n, const F& f) {
  if (!ex.on_device() && n < 4096) {
    for (Index i = 0; i < n; ++i) f(i);
    return;
  }
  for_each(ex, n, f);
}

}  // namespace lbdem::dem
