#pragma once
// Private state of DemSystem, shared by its translation units: the particle
// store, the neighbour list and the rebuild scheduler, with the set-up
// constants and the step counters.
#include <memory>

#include "dem/system.hpp"
#include "neighbour_list.hpp"
#include "particle_store.hpp"
#include "rebuild_scheduler.hpp"
#include "state.hpp"

namespace lbdem {
struct Scratch;  // core/algorithms.hpp (kernel TUs only)
}

namespace lbdem::dem {

class DomainExchange;  // domain_exchange.hpp
class SubstepGraphs;   // substep_graphs.hpp

struct DemSystem::Impl {
  Impl();
  ~Impl();  // Scratch is complete in system.cu only
  Exec ex;
  DemParams p;
  Box box;
  Walls walls;
  ContactLaw pp, pw;
  ParticleStore store;
  NeighbourList lists;
  RebuildScheduler sched;
  double time = 0;
  long steps = 0, rebuilds = 0;
  bool forces_valid = false;
  bool old_valid = false;  // frco/trqo hold a_{n-1} of the current trajectory
  std::unique_ptr<Scratch> scratch_ptr;  // complete type in the .cu TUs only
  Scratch& scratch() { return *scratch_ptr; }
  // Migration and ghosts of a decomposed run (null on one rank).
  std::unique_ptr<DomainExchange> domain;
  const halo::Comm* comm = nullptr;  // the ranks of a decomposed run (null on one rank)
  bool decomposed() const { return domain != nullptr; }
  // Plain sub-steps as CUDA graphs (substep_graphs.hpp): made at construction
  // where DemParams::substep_graphs applies (null otherwise).
  std::unique_ptr<SubstepGraphs> graphs;
  // Each sub-step's force evaluation fused with the next sub-step's
  // kick-drift (dem/README.md, "Fused sub-steps"): one rank, particle path,
  // and LBDEM_DEM_FUSED_SUBSTEPS not 0 (set at construction).
  bool fused = false;
  long fused_steps = 0;  // sub-steps run fused (DemStats::fused_steps)

  // The set-up constants of the kernel view (no arrays bound).
  State physics() const {
    State s{};
    s.box = box; s.walls = walls; s.pp = pp; s.pw = pw;
    s.gravity = p.gravity; s.body = p.body_force; s.dt = p.dt;
    s.lanes = p.force_lanes;
    return s;
  }
  // The kernel view of the current arrays.
  State state() const {
    State s = physics();
    store.bind(s);
    lists.bind(s);
    return s;
  }
};

// Force evaluation, one instantiation per friction flag (own TU each).
void run_forces_frictionless(DemSystem::Impl& m);
void run_forces_frictional(DemSystem::Impl& m);
// The particle path's force kernel with an explicit view and stream (the
// sub-step graphs capture it; the same kernel run_forces_* launches).
void launch_force_particle_frictionless(const Exec& ex, Index n, const State& s);
void launch_force_particle_frictional(const Exec& ex, Index n, const State& s);
// The fused sub-step (ForceKickDrift, dem/README.md "Fused sub-steps"): the
// particle path's forces of the state in `s`, then the next sub-step's
// kick-drift with the arguments `a`, its positions and predicted velocities
// written into the arrays of `out` (the view after ParticleStore::
// swap_drift_targets() and the force swap).
struct KickArgs {
  int synced, extrap;
  StatusRecord *rec, *next;
  int report, check;
};
void launch_force_kick_drift_frictionless(const Exec& ex, Index n, const State& s, const State& out, const KickArgs& a);
void launch_force_kick_drift_frictional(const Exec& ex, Index n, const State& s, const State& out, const KickArgs& a);

}  // namespace lbdem::dem
