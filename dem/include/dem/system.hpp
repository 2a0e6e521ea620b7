#pragma once
// The DEM engine: particles resident on one backend, neighbour lists, contact
// forces, walls, velocity-Verlet integration.
//
// One step (advance): kick v by dt/2 and drift x by dt (and predict the
// velocity the contact forces see) -> if some particle moved more than
// skin/2 since the last build, rebuild (sort by cell, reorder the particle
// arrays, rebuild the Verlet list, carry tangential histories by partner id)
// -> forces -> kick v by dt/2. Consecutive half kicks are fused into one
// kernel; velocities are synchronised at the end of every advance() call.
//
// Rebuild decisions without a blocking read per step (the default,
// RebuildCheck::Lookahead): the host decides before each step, from a report
// of the largest displacement since the build, speed and acceleration that
// the device reduced a few steps earlier (or at the end of the previous
// advance() call) and copied asynchronously, rebuilding when that
// displacement plus a safe bound on the motion since the report could exceed
// skin/2. Every step the device also checks the real displacements; one above
// skin/2 at a step that did not rebuild (the bound failed) is reported as a
// DivergenceError when the host reads that report, never passed over. The
// schedule of reports depends only on the state and the advance() call
// lengths, so both backends and repeated runs take the same decisions.
//
// Host round trips in the time loop: no blocking read per step. Reports are
// copied into page-locked memory and read one report later: at the start of
// the next advance() call (the host waits only until the device has finished
// the previous call's DEM steps, not for work queued after them) and, inside
// long calls, every k steps with k steps of lag (k = 1..8, shorter for fast
// particles whose lists need rebuilding within a few dozen steps). A rebuild
// still reads 8 bytes (list overflow) and waits for the device. The first
// advance() call reads one report synchronously. No allocation in the loop
// once the first steps have sized the scratch space.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/exec.hpp"
#include "dem/contact.hpp"
#include "dem/geometry.hpp"
#include "dem/particle_view.hpp"
#include "dem/particles.hpp"

namespace lbdem::dem {

enum class ForcePath {
  Particle,  // each particle sums its own contacts over a full list: no atomics, bitwise reproducible
  Pair,      // contacts compacted by a prefix sum, one thread per pair, atomic accumulation (Yu et al. 2024)
};
const char* to_string(ForcePath p);

struct Material {
  double stiffness = 0;            // k_n particle-particle [N/m]
  double restitution = 1;          // e particle-particle, (0, 1]
  double friction = 0;             // mu particle-particle
  double wall_stiffness = 0;       // [N/m]
  double wall_restitution = 1;
  double wall_friction = 0;
  double tangential_stiffness_ratio = 2.0 / 7.0;  // k_t / k_n
  double tangential_damping_ratio = 0.5;          // eta_t / eta_n
};

// How the host decides neighbour-list rebuilds (see the header comment).
enum class RebuildCheck {
  Lookahead,  // ahead of time from device reports read with a lag: no blocking read per step (default)
  EveryStep,  // exactly when a displacement exceeds skin/2: one blocking 16-byte read per step (reference)
};
const char* to_string(RebuildCheck c);

struct DemParams {
  std::array<double, 3> lo{0, 0, 0}, hi{1, 1, 1};
  std::array<bool, 3> periodic{false, false, false};
  std::vector<Wall> walls;   // normals need not be unit (normalised here)
  Material material;
  bool friction = false;     // tangential forces + rotation; compiled out when false
  Vec3d gravity{};           // [m/s^2]
  Vec3d body_force{};        // external force on every particle [N]
  bool external_forcing = false;  // allocate ext_force/ext_torque (coupling input)
  double dt = 0;             // [s]
  double skin = 0;           // Verlet skin [m]; 0 -> 0.1 x the smallest diameter
  ForcePath path = ForcePath::Particle;
  int neighbour_capacity = 0;     // per particle; 0 -> estimated, grown on overflow
  double min_steps_per_collision = 50;  // refuse dt > t_c / this (Yu et al. use t_c/50)
  RebuildCheck rebuild_check = RebuildCheck::Lookahead;
  // Lookahead: factor (>= 1) on the motion predicted from the reported largest
  // speed and acceleration. 2 covers a particle that a collision sets moving
  // at up to twice the fastest speed of the report (elastic, light hit by
  // heavy); raise it if a stale-list error is ever reported.
  double lookahead_safety = 2.0;
};

// Smallest collision time among particle-particle and particle-wall contacts
// of these particles [s] (smallest mass pairs; most elastic gives the shortest).
double min_collision_time(const DemParams& p, const HostParticles& hp);
// Throws ConfigError naming dt, t_c and the limit when dt > t_c / min_steps_per_collision.
void check_time_step(const DemParams& p, const HostParticles& hp, const std::string& key = "time.dt");

struct DemStats {
  long steps = 0;
  long rebuilds = 0;
  int neighbour_capacity = 0;
  double mean_neighbours = 0;  // at the last build
  long status_reads = 0;  // rebuild-decision reports read by the host
  long status_waits = 0;  // of those, reads that found the device not yet there (CUDA; timing-dependent)
};

class DemSystem {
 public:
  DemSystem(Exec ex, DemParams params, const HostParticles& particles);
  ~DemSystem();
  DemSystem(const DemSystem&) = delete;
  DemSystem& operator=(const DemSystem&) = delete;

  // Advances `steps` velocity-Verlet steps. Throws DivergenceError when the
  // neighbour list was found stale (see the header comment); after that
  // every advance() throws until rebuild() is called.
  void advance(long steps);
  // Recomputes forces at the current state (with the current list).
  void compute_forces();
  // Forces a neighbour-list rebuild (reorders the particle arrays); also
  // clears a stale-list error (contacts of the stale steps may have been missed).
  void rebuild();

  double time() const;
  Index size() const;
  const DemParams& params() const;
  DemStats stats() const;
  Backend backend() const;
  // Coupling view. Write only the external force/torque through it: the
  // rebuild decisions assume positions and velocities change only in advance().
  ParticleView view();
  // Particles in the current storage order, with their last forces. Waits for
  // the device; throws DivergenceError if a report that arrived meanwhile
  // shows a stale list (once; advance() keeps refusing).
  HostParticles download() const;
  // Pairs (by global id, a < b) in the Verlet list / currently overlapping.
  std::vector<std::pair<std::int64_t, std::int64_t>> neighbour_pairs() const;
  std::vector<std::pair<std::int64_t, std::int64_t>> contact_pairs() const;
  double cell_size(int axis) const;
  // Benchmark hooks: one phase alone (asynchronous on the device).
  void bench_integrate();  // one fused kick+drift (the next advance() reads a fresh report first)
  void bench_forces();     // one force evaluation (no rebuild check)
  void bench_rebuild();    // one full rebuild
  // Waits for the device; checks arrived reports for a stale list like download().
  void synchronize() const;

  struct Impl;  // opaque; defined in dem/src/system_impl.hpp

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace lbdem::dem
