#pragma once
// Particle arrays of a DemSystem, resident on one backend (structure of
// arrays), with the twin of each array that a reorder gathers into.
#include <cstdint>
#include <vector>

#include "core/buffer.hpp"
#include "core/exec.hpp"
#include "dem/geometry.hpp"
#include "dem/particle_view.hpp"
#include "dem/particles.hpp"

namespace lbdem::dem {

struct State;

// Which optional arrays a store holds.
struct StoreLayout {
  bool rotation = false;          // predicted angular velocity (friction)
  bool external_forcing = false;  // coupling input: external force and torque
  int wall_histories = 0;         // tangential histories per particle, one per wall (friction)
  double inertia_factor = 0.4;    // moment of inertia = factor m r^2 (DemParams::inertia_factor)
};

// Every array of a store on the host (n records, the first n_owned owned),
// for the migration and ghost exchange of a decomposed run.
struct HostState {
  Index n = 0, n_owned = 0;
  std::vector<Real4> pos, vel, omg, frc, trq, frco, trqo, vpr, wpr, extf, extt;
  std::vector<std::int64_t> gid;
  std::vector<int> type;
  std::vector<Vec3d> whist;  // [w * n + i]
  void resize(Index count, const StoreLayout& lay);
};

// Particles in storage order, which changes at every neighbour-list build
// (reorder into cell order); the global id names a particle across orders.
// Owned particles occupy [0, n_owned): those the time step integrates. The
// arrays hold n >= n_owned records; without domain decomposition n == n_owned.
class ParticleStore {
 public:
  // Copies the particles to the backend: positions wrapped into the box,
  // 1/m and 1/I in the w components. Throws ConfigError for a non-positive
  // mass, or ids missing or not unique.
  // The arrays nothing copies into are zeroed on ex's queue.
  void upload(const Exec& ex, const HostParticles& hp, const Box& box, const StoreLayout& layout);
  // A decomposed run's records (owned first, then ghosts): the arrays grow to
  // hold them (with head room, never shrinking), the contents are replaced.
  void load(Backend be, const HostState& h);
  // The owned records (every array) to the host.
  void save(HostState& h) const;
  // Every array into the order dst[i] = src[perm[i]] (perm over all n records).
  // Afterwards gid_prev() holds the ids of the previous order.
  void reorder(const Exec& ex, const int* perm);
  // Particles in storage order, with the last forces (torques when rotating).
  HostParticles download() const;
  // Swaps the positions and the predicted velocities (and angular ones) with
  // their twins: a fused sub-step (dem/README.md, "Fused sub-steps") writes
  // the new ones into the twins while its forces still read these; the swap
  // makes them the current arrays, which every other reader then sees.
  void swap_drift_targets() {
    pos.swap(pos2);
    vpr.swap(vpr2);
    wpr.swap(wpr2);
  }
  // The particle arrays of the kernel view.
  void bind(State& s) const;
  ParticleView view();

  Index size() const { return n; }
  Index owned() const { return n_owned; }
  const std::int64_t* gid_prev() const { return gid2.data(); }

  Index n = 0;        // records held (owned first)
  Index n_owned = 0;  // particles integrated here
  StoreLayout layout;
  // Position and radius; velocity and 1/m; angular velocity and 1/I; force and
  // torque (this step, the previous step); predicted velocities; coupling
  // input; positions at the last list build (not reordered: the build rewrites them).
  Buffer<Real4> pos, vel, omg, frc, trq, frco, trqo, vpr, wpr, extf, extt, x0;
  Buffer<std::int64_t> gid;
  Buffer<int> type;
  Buffer<Vec3d> whist;  // wall histories [w * n + i] (friction)

 private:
  // Reorder targets, swapped with the arrays above by reorder(); pos2, vpr2
  // and wpr2 are also the targets of a fused sub-step (swap_drift_targets()).
  // Each is written whole before it is swapped in.
  Buffer<Real4> pos2, vel2, omg2, frc2, trq2, frco2, trqo2, vpr2, wpr2, extf2, extt2;
  Buffer<std::int64_t> gid2;
  Buffer<int> type2;
  Buffer<Vec3d> whist2;
};

}  // namespace lbdem::dem
