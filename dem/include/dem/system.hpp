#pragma once
// The DEM engine: particles resident on one backend, neighbour lists, contact
// forces, walls, velocity-Verlet integration. dem/README.md describes the time
// step, the rebuild decisions (RebuildCheck) and the two force paths.
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/checkpoint.hpp"
#include "core/exec.hpp"
#include "dem/contact.hpp"
#include "dem/domain.hpp"
#include "dem/geometry.hpp"
#include "dem/particle_view.hpp"
#include "dem/particles.hpp"

namespace lbdem::dem {

enum class ForcePath {
  Particle,  // each particle sums its own contacts over a full list: no atomics, bitwise reproducible
  Pair,      // contacts compacted by a prefix sum, one thread per pair, atomic accumulation (Yu et al. 2024)
};
const char* to_string(ForcePath p);

// The order in which a particle sums its contacts (DemParams::contact_order).
enum class ContactOrder {
  Storage,   // neighbour-list order, which follows the cell order of the last build (default)
  GlobalId,  // ascending partner global id: the same sums whatever the storage order and the
             // decomposition, so a run on N ranks gives the one-rank states bitwise
};
const char* to_string(ContactOrder o);

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

// How the host decides neighbour-list rebuilds (dem/README.md, "Rebuild decisions").
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
  ContactOrder contact_order = ContactOrder::Storage;
  // Moment of inertia of each particle = inertia_factor m r^2: 0.4 for solid
  // spheres, 0.5 for the disks (cylinders about their axis) of a 2D scene.
  double inertia_factor = 0.4;
  // CUDA, one rank, particle force path, look-ahead rebuilds: the sub-steps
  // between two host decisions (reports, rebuilds) run as CUDA graphs
  // (dem/README.md, "Sub-step graphs"); the same kernels in the same order,
  // so the same particles bit for bit. false: each kernel launched on its own.
  // The environment variable LBDEM_DEM_GRAPHS=0 turns it off for a whole run
  // (A/B timing of a case without a key for it).
  bool substep_graphs = true;
  // Threads per particle of the particle path's force kernel on the device
  // (1, 2, 4, 8 or 16; dem/README.md, "The two force paths"): several lanes
  // share a particle's neighbour list and add their partial sums in a fixed
  // order, which hides the list's load latency when the system has too few
  // particles to fill the device (a bed of ~10^4). The sums then differ from
  // one lane's by rounding. The host backend ignores it. The environment
  // variable LBDEM_DEM_FORCE_LANES replaces it for a whole run (A/B timing).
  int force_lanes = 1;
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
  long graph_launches = 0;  // sub-step graphs launched (DemParams::substep_graphs)
  long graph_steps = 0;     // sub-steps run inside them (the rest were launched kernel by kernel)
  long graph_captures = 0;  // graphs captured (a new set of buffers, counts or run length)
  long fused_steps = 0;     // sub-steps whose kick-drift ran fused with the previous forces (one kernel)
  // Decomposed run, this rank: particles sent to another rank across a face,
  // an edge and a corner of its piece (1, 2 and 3 piece coordinates changed,
  // periodic wrap included), and the ghosts held at the last build.
  long migrations[3] = {0, 0, 0};
  long migrations_periodic = 0;  // of those, through a periodic face of the box
  Index ghosts = 0;
};

class DemSystem {
 public:
  DemSystem(Exec ex, DemParams params, const HostParticles& particles);
  // One rank's part of a run decomposed over the ranks of domain.comm
  // (dem/README.md, "Many ranks"). Every rank passes the same whole particle
  // set and keeps the particles whose centre lies in its piece. Collective:
  // every rank constructs, advances, rebuilds and gathers together. Throws
  // ConfigError for a piece thinner than the ghost width or the pair force
  // path (it adds forces to partners, which may be ghosts).
  DemSystem(Exec ex, DemParams params, const HostParticles& particles, const DemDomain& domain);
  ~DemSystem();
  DemSystem(const DemSystem&) = delete;
  DemSystem& operator=(const DemSystem&) = delete;

  // Advances `steps` velocity-Verlet steps. Throws DivergenceError when the
  // neighbour list was found stale (dem/README.md, "Rebuild decisions"); after that
  // every advance() throws until rebuild() is called.
  void advance(long steps);
  // Recomputes forces at the current state (with the current list).
  void compute_forces();
  // Forces a neighbour-list rebuild (reorders the particle arrays); also
  // clears a stale-list error (contacts of the stale steps may have been missed).
  void rebuild();

  double time() const;
  Index size() const;         // particles owned here (all of them on one rank)
  Index global_size() const;  // over all ranks (collective)
  const DemParams& params() const;
  DemStats stats() const;
  Backend backend() const;
  // Coupling view. Write only the external force/torque through it: the
  // rebuild decisions assume positions and velocities change only in advance().
  ParticleView view();
  // The particles' global ids in the storage order of view() (backend
  // memory); valid until the next advance() or rebuild() reorders them.
  const std::int64_t* ids() const;
  // The same with the ghost copies a decomposed run holds behind the owned
  // particles (n = owned + ghosts; owned first): what a coupling that maps
  // particles onto this rank's cells needs. On one rank: view().
  ParticleView held_view();
  // Decomposed run (no-ops on one rank), collective. sync_ghosts(): the
  // ghosts take their owners' current positions, velocities and angular
  // velocities (between advance() calls the ghosts hold predicted
  // velocities). return_ghost_coupling(): each ghost's external force and
  // torque (a coupling's share from this rank's cells) is added to its
  // owner's, the shares of several ranks in ascending rank order after the
  // owner's own; the ghosts' values are left as they were. Needs external
  // forcing (DemParams::external_forcing).
  void sync_ghosts();
  void return_ghost_coupling();
  // Particles in the current storage order, with their last forces. Waits for
  // the device; throws DivergenceError if a report that arrived meanwhile
  // shows a stale list (once; advance() keeps refusing).
  HostParticles download() const;  // the owned particles
  // Every rank's particles on rank `root`, in ascending global id (empty on
  // the other ranks; collective). On one rank: download() sorted by id.
  HostParticles gather(int root = 0) const;
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
  // Checkpoint state (core/checkpoint.hpp): every particle array in storage
  // order (global ids, tangential histories, forces of the last two steps,
  // positions at the last build), the Verlet list, the rebuild scheduler's
  // reports and the step count and time, so that advance() goes on as if
  // never stopped. Load into a system constructed from the same parameters
  // and particles; a stored set of another size or layout is refused
  // (ConfigError). A decomposed system saves its rank's records (owned and
  // ghosts) and the ghost bookkeeping, and loads them into a system of the
  // same decomposition (dem/checkpoint.hpp). Synchronous.
  void save_state(ckpt::Sink& out) const;
  void load_state(ckpt::Source& in);

  // A restart on another decomposition (or rank count). saved_particles()
  // reads a section save_state() wrote (one rank's, decomposed or not) and
  // appends its owned particles to `out` as portable records: every
  // per-particle array, the wall histories and the list row as (partner
  // global id, tangential history); it returns the system's counters.
  // select_particles() keeps the records whose centre lies in this rank's
  // piece; restore_particles() replaces the particles with them (sorted by
  // global id), rebuilds the neighbour list (carrying the tangential
  // histories by partner id, as a build after migration does) and restores
  // the counters (collective on a decomposed system). The rebuild at load
  // makes the continued run agree with the straight one to round-off (the
  // contact sums follow the new storage order), not bitwise.
  struct SavedCounters {
    std::int64_t steps = 0, rebuilds = 0;
    double time = 0;
    std::uint8_t forces_valid = 0, old_valid = 0;
  };
  SavedCounters saved_particles(ckpt::Source& in, std::vector<std::byte>& out) const;
  std::vector<std::byte> select_particles(const std::vector<std::byte>& records) const;
  void restore_particles(const std::vector<std::byte>& mine, const SavedCounters& c);

  struct Impl;  // opaque; defined in dem/src/system_impl.hpp

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace lbdem::dem
