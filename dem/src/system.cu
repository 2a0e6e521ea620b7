// DemSystem: set-up, the velocity-Verlet time loop, list rebuilds
// (dem/README.md describes the step and the rebuild decisions).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>

#include "core/algorithms.hpp"
#include "core/error.hpp"
#include "domain_exchange.hpp"
#include "format.hpp"
#include "kernels.hpp"
#include "substep_graphs.hpp"
#include "system_impl.hpp"

namespace lbdem::dem {

namespace {

// Checks of the parameters and the particle arrays made before any geometry
// is derived from them.
void validate(const DemParams& p, const HostParticles& hp) {
  const Index n = hp.size();
  if (n >= (Index{1} << 30))
    throw ResourceError(fmtx(("DEM: {} particles exceed the 2^30 limit of 32-bit list indices"), n));
  if (hp.r.size() != static_cast<std::size_t>(n) || hp.mass.size() != static_cast<std::size_t>(n))
    throw ConfigError("DEM: particle arrays of different lengths");
  for (int k = 0; k < 3; ++k)
    if (!(p.hi[k] > p.lo[k]))
      throw ConfigError(fmtx(("domain: hi[{}] = {} must exceed lo[{}] = {}"), k, p.hi[k], k, p.lo[k]));
  if (!(p.inertia_factor > 0 && p.inertia_factor <= 1))
    throw ConfigError(fmtx(("DEM: inertia factor {} must lie in (0, 1] (0.4 a solid sphere, 0.5 a disk)"), p.inertia_factor));
  if (static_cast<int>(p.walls.size()) > kMaxWalls)
    throw ConfigError(fmtx(("walls: {} walls given, at most {} supported"), p.walls.size(), kMaxWalls));
  for (std::size_t k = 0; k < p.walls.size(); ++k)
    if (!(norm(p.walls[k].normal) > 0)) throw ConfigError(fmtx(("walls[{}].normal: must be a non-zero vector"), k));
  const Material& mat = p.material;
  auto check_e = [](double e, const char* key) {
    if (!(e > 0 && e <= 1)) throw ConfigError(fmtx(("material.{}: {} must be in (0, 1]"), key, e));
  };
  check_e(mat.restitution, "restitution");
  check_e(mat.wall_restitution, "wall_restitution");
  if (p.friction && !(mat.tangential_stiffness_ratio > 0))
    throw ConfigError("material.tangential_stiffness_ratio must be > 0 with friction");
  check_time_step(p, hp);
}

Box make_box(const DemParams& p) {
  Box box;
  for (int k = 0; k < 3; ++k) {
    box.lo[k] = p.lo[k];
    box.len[k] = p.hi[k] - p.lo[k];
    box.periodic[k] = p.periodic[k] ? 1 : 0;
  }
  return box;
}

// The walls with unit normals.
Walls make_walls(const DemParams& p) {
  Walls walls;
  for (std::size_t k = 0; k < p.walls.size(); ++k) {
    Wall w = p.walls[k];
    const double len = norm(w.normal);
    w.normal = w.normal * (1.0 / len);
    walls.w[k] = w;
  }
  walls.count = static_cast<int>(p.walls.size());
  return walls;
}

void run_forces(DemSystem::Impl& m) {
  if (m.p.friction) run_forces_frictional(m);
  else run_forces_frictionless(m);
}

// A list build at the current state: sort by cell, reorder the particles,
// build the Verlet list (carrying histories).
void rebuild_list(DemSystem::Impl& m) {
  m.sched.on_build(m.steps);
  if (m.decomposed()) {
    // Migration and ghosts first: the build sorts and lists owned and ghosts.
    m.domain->redistribute(m);
    m.lists.rebuild(m.ex, m.store, m.physics(), m.scratch());
    m.domain->bind_refresh(m);
    ++m.rebuilds;
    return;
  }
  if (m.store.size() == 0) return;
  m.lists.rebuild(m.ex, m.store, m.physics(), m.scratch());
  ++m.rebuilds;
}

// One plain sub-step's launches (SubstepGraphs captures these): the fused
// kick-drift with synced 0, extrapolation 1, no report and the displacement
// check on, then the particle path's forces, the very launches advance()
// issues for such a step.
void issue_plain_step(const Exec& ex, const State& kick, StatusRecord* rec, StatusRecord* next, const State& force,
                      bool friction) {
  const Index n = kick.n;
  if (friction) {
    launch(ex, n, KickDrift<true>{kick, 0, 1, rec, next, 0, 1});
    launch_force_particle_frictional(ex, n, force);
  } else {
    launch(ex, n, KickDrift<false>{kick, 0, 1, rec, next, 0, 1});
    launch_force_particle_frictionless(ex, n, force);
  }
}

// One plain sub-step of the fused pipeline (SubstepGraphs captures it): the
// forces of the state in `s` and the next kick-drift (synced 0,
// extrapolation 1, no report, displacement check on) into the arrays of
// `out`, the very launch advance() issues for such a step.
void issue_fused_step(const Exec& ex, const State& s, StatusRecord* rec, StatusRecord* next, const State& out,
                      bool friction) {
  const KickArgs a{0, 1, rec, next, 0, 1};
  if (friction) launch_force_kick_drift_frictional(ex, s.n, s, out, a);
  else launch_force_kick_drift_frictionless(ex, s.n, s, out, a);
}

// Whether each sub-step's forces are fused with the next sub-step's
// kick-drift (dem/README.md, "Fused sub-steps"): the particle path on one rank
// (a decomposed step refreshes the ghosts between the kick-drift and the
// forces; the pair path's forces are several kernels), where the
// environment variable LBDEM_DEM_FUSED_SUBSTEPS is not 0. On by default: the
// particles are the same bit for bit either way, on the GPU too, since the
// kernels are compiled without contraction into fused multiply-adds
// (dem/CMakeLists.txt; with it the frictional state had differed).
bool fused_apply(const DemSystem::Impl& m) {
  const char* env = std::getenv("LBDEM_DEM_FUSED_SUBSTEPS");
  bool on = true;
  if (env) {
    if (std::strcmp(env, "0") == 0) on = false;
    else if (std::strcmp(env, "1") != 0)
      throw ConfigError(std::string("LBDEM_DEM_FUSED_SUBSTEPS: '") + env +
                        "' is not 0 or 1 (1: fuse each DEM sub-step's forces with the next kick-drift, the default; "
                        "0: two kernels per sub-step)");
  }
  return on && !m.decomposed() && m.p.path == ForcePath::Particle;
}

// Whether plain sub-steps run as graphs: DemParams::substep_graphs (and no
// LBDEM_DEM_GRAPHS=0) where the step's launches are the plain pair — CUDA, one
// rank (a decomposed step exchanges ghosts between them), the particle path
// (the pair path's scan uses scratch memory), look-ahead decisions (the
// every-step test reads each step).
bool graphs_apply(const DemSystem::Impl& m) {
  if (!m.p.substep_graphs || !m.ex.on_device() || m.decomposed() || m.p.path != ForcePath::Particle ||
      m.p.rebuild_check != RebuildCheck::Lookahead)
    return false;
  const char* env = std::getenv("LBDEM_DEM_GRAPHS");
  return !(env && std::strcmp(env, "0") == 0);
}

}  // namespace

DemSystem::Impl::Impl() : scratch_ptr(std::make_unique<Scratch>()) {}
DemSystem::Impl::~Impl() = default;

DemSystem::DemSystem(Exec ex, DemParams params, const HostParticles& hp)
    : DemSystem(ex, std::move(params), hp, DemDomain{}) {}

DemSystem::DemSystem(Exec ex, DemParams params, const HostParticles& hp, const DemDomain& domain)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.ex = ex;
  m.p = std::move(params);
  const char* fl = std::getenv("LBDEM_DEM_FORCE_LANES");
  if (fl) m.p.force_lanes = std::atoi(fl);
  if (m.p.force_lanes != 1 && m.p.force_lanes != 2 && m.p.force_lanes != 4 && m.p.force_lanes != 8 &&
      m.p.force_lanes != 16)
    throw ConfigError(std::string(fl ? "LBDEM_DEM_FORCE_LANES" : "DEM force_lanes") + ": " +
                      (fl ? std::string(fl) : std::to_string(m.p.force_lanes)) +
                      " is not 1, 2, 4, 8 or 16 (threads per particle of the force kernel)");
  const DemParams& p = m.p;
  const Material& mat = p.material;
  validate(p, hp);
  const bool decomposed = domain.decomposed();
  if (decomposed && p.path == ForcePath::Pair)
    throw ConfigError("neighbours.force_path: 'pair' adds each contact force to both particles, and on more than "
                      "one rank a partner may be a ghost copy; use 'particle' (each owner sums its own contacts)");
  // Geometry: box, walls, contact laws, cell grid and skin.
  m.box = make_box(p);
  m.walls = make_walls(p);
  m.pp = make_contact_law(mat.stiffness, mat.restitution, mat.tangential_stiffness_ratio, mat.tangential_damping_ratio,
                          mat.friction);
  m.pw = make_contact_law(mat.wall_stiffness, mat.wall_restitution, mat.tangential_stiffness_ratio,
                          mat.tangential_damping_ratio, mat.wall_friction);
  // The whole set's radii: the same cell grid and skin on every rank.
  m.lists.set_geometry(m.box, hp.r, p.skin);
  // Particle store (a decomposed run keeps the particles of its piece).
  const StoreLayout layout{p.friction, p.external_forcing, p.friction ? m.walls.count : 0, p.inertia_factor};
  if (decomposed) {
    m.comm = domain.comm;
    m.domain = std::make_unique<DomainExchange>();
    m.domain->init(domain, m.box, m.lists.cutoff, ex, p.external_forcing);
    m.store.upload(ex, m.domain->select_owned(hp), m.box, layout);
  } else {
    m.store.upload(ex, hp, m.box, layout);
  }
  // Neighbour list.
  m.lists.allocate(ex, m.store.size(), p.friction, p.path == ForcePath::Pair,
                   p.neighbour_capacity > 0 ? p.neighbour_capacity : 32, decomposed);
  m.lists.gid_order = p.contact_order == ContactOrder::GlobalId;
  // Rebuild scheduler.
  m.sched.init(ex, p.rebuild_check == RebuildCheck::Lookahead, m.lists.skin, p.dt, p.lookahead_safety);
  m.sched.comm = m.comm;
  // First build; an estimated capacity is then fitted to what it needed
  // (list and history memory scale with it), grown again on overflow. A
  // decomposed run rebuilds on every rank if one refits (builds exchange).
  rebuild();
  if (p.neighbour_capacity == 0) {
    bool refit = m.lists.fit_capacity(m.ex, m.scratch());
    if (decomposed) refit = m.comm->any(refit);
    if (refit) rebuild();
  }
  m.rebuilds = 0;  // the initial build is not counted
  m.fused = fused_apply(m);
  if (graphs_apply(m))
    m.graphs = std::make_unique<SubstepGraphs>(m.ex, p.friction, m.fused ? issue_fused_step : issue_plain_step);
}

DemSystem::~DemSystem() = default;

void DemSystem::rebuild() {
  Impl& m = *impl_;
  if (!m.sched.stale_error.empty()) m.sched.reset();
  rebuild_list(m);
}

void DemSystem::compute_forces() {
  Impl& m = *impl_;
  if (m.store.size() == 0 && !m.decomposed()) return;
  const State st = m.state();
  const Index n = m.store.owned();
  if (m.p.friction) launch(m.ex, n, SyncPredictor<true>{st});
  else launch(m.ex, n, SyncPredictor<false>{st});
  if (m.decomposed()) m.domain->refresh(m);
  run_forces(m);
  m.forces_valid = true;
  m.old_valid = false;
}

void DemSystem::advance(long steps) {
  Impl& m = *impl_;
  RebuildScheduler& r = m.sched;
  if (steps <= 0) return;
  if (!r.stale_error.empty()) throw DivergenceError(r.stale_error);
  if (m.store.size() == 0 && !m.decomposed()) {
    m.time += steps * m.p.dt;
    return;
  }
  if (!m.forces_valid) compute_forces();
  const bool ahead = r.lookahead;
  if (ahead && !r.known) r.initial_report(m.state(), m.store.owned(), m.steps);
  const double dt = m.p.dt;
  const long t_end = m.steps + steps;
  // Closing half kick (velocities synchronised at the state reached).
  // (The owned count changes at a decomposed run's builds: read it per launch.)
  auto close = [&m] {
    const Index n = m.store.owned();
    const State st = m.state();
    if (m.p.friction) launch(m.ex, n, Kick<true>{st});
    else launch(m.ex, n, Kick<false>{st});
    m.forces_valid = true;
  };
  // Plain sub-steps (SubstepGraphs) are queued and issued as one graph
  // before any other launch and before the host waits for a report, so the
  // device's queue is the same sequence of kernels as without graphs.
  SubstepGraphs* const graphs = m.graphs.get();
  auto flush = [graphs] {
    if (graphs) graphs->flush();
  };
  // Fused sub-steps (m.fused): a step's force evaluation is not issued after
  // its kick-drift but deferred, and goes out with the next step's
  // kick-drift as one kernel (ForceKickDrift) once that step's arguments are
  // decided, or on its own before the closing kick. `deferred`: the forces
  // of the current state are not issued yet.
  bool deferred = false;
  auto issue_deferred = [&m, &deferred, &flush] {
    if (!deferred) return;
    flush();
    run_forces(m);
    deferred = false;
  };
  for (long s = 0; s < steps; ++s) {
    const long t = m.steps + 1;  // the state this step produces
    bool build = false;
    if (ahead) {
      if (r.read_waits(t)) flush();  // the device works on the queued steps while the host reads
      try {
        r.read_due(t);
      } catch (const DivergenceError&) {
        flush();
        issue_deferred();
        if (s > 0) close();  // leave a consistent state (stopped at step t - 1)
        throw;
      }
      build = r.rebuild_due(t);
    }
    // Reports: every step (exact test), at the end of the call (read when the
    // next one starts), and every k steps when read within this call.
    const long k = r.report_every;
    const bool report = !ahead || t == t_end || (t - r.t_last_report >= k && t + k <= t_end);
    const State st = m.state();
    const Index n = m.store.owned();
    const int synced = s == 0, extrap = m.old_valid ? 1 : 0;
    StatusRecord *rec = r.slot(r.reports), *next = r.slot(r.reports + 1);
    const int rep = report ? 1 : 0, check = build ? 0 : 1;
    const bool plain = graphs && !report && !build && !synced && extrap && n > 0;
    if (deferred) {
      // The forces of the current state (view st) and this step's kick-drift
      // in one kernel: its positions and predictors go to the store's twins,
      // swapped in here with the forces' swap (the view `out`), so that all
      // that follows reads the new state from the store's usual arrays.
      m.store.swap_drift_targets();
      m.store.frc.swap(m.store.frco);
      if (m.p.friction) m.store.trq.swap(m.store.trqo);
      const State out = m.state();
      ++m.fused_steps;
      ++m.steps;
      m.time += dt;
      if (plain) {
        // A plain step: queued (its own forces stay deferred).
        graphs->add(st, rec, next, out);
        m.old_valid = true;
        continue;
      }
      flush();
      const KickArgs a{synced, extrap, rec, next, rep, check};
      if (m.p.friction) launch_force_kick_drift_frictional(m.ex, n, st, out, a);
      else launch_force_kick_drift_frictionless(m.ex, n, st, out, a);
      deferred = false;
    } else {
      if (plain && !m.fused) {
        // A plain step: the same bookkeeping, its launches queued.
        m.store.frc.swap(m.store.frco);
        if (m.p.friction) m.store.trq.swap(m.store.trqo);
        ++m.steps;
        m.time += dt;
        graphs->add(st, rec, next, m.state());
        m.old_valid = true;
        continue;
      }
      flush();
      if (m.p.friction) launch(m.ex, n, KickDrift<true>{st, synced, extrap, rec, next, rep, check});
      else launch(m.ex, n, KickDrift<false>{st, synced, extrap, rec, next, rep, check});
      // The forces just used become the "old" ones of the velocity predictor.
      m.store.frc.swap(m.store.frco);
      if (m.p.friction) m.store.trq.swap(m.store.trqo);
      ++m.steps;
      m.time += dt;
    }
    // A rank without particles reports zeros (a decomposed run; the kernel's
    // particle 0 zeroes the next slot otherwise).
    if (n == 0 && report) r.zero_slot(r.reports + 1);
    if (ahead) {
      if (report) r.take_report(t, t == t_end ? t + 1 : t + k);
    } else {
      build = r.exact_check(t);
    }
    if (build) rebuild_list(m);
    else if (m.decomposed()) m.domain->refresh(m);
    if (m.fused) deferred = true;
    else run_forces(m);
    m.old_valid = true;
  }
  flush();
  issue_deferred();
  close();
}

void DemSystem::sync_ghosts() {
  Impl& m = *impl_;
  if (m.decomposed()) m.domain->sync_state(m);
}

void DemSystem::return_ghost_coupling() {
  Impl& m = *impl_;
  if (m.decomposed()) m.domain->return_coupling(m);
}

void DemSystem::bench_integrate() {
  Impl& m = *impl_;
  const State st = m.state();
  const Index n = m.store.owned();
  // Displacement checks go to the sink slot; the moved particles call for a
  // fresh report before the next advance() decides anything.
  StatusRecord* sink = m.sched.sink();
  if (m.p.friction) launch(m.ex, n, KickDrift<true>{st, 0, 1, sink, sink, 0, 1});
  else launch(m.ex, n, KickDrift<false>{st, 0, 1, sink, sink, 0, 1});
  m.sched.known = false;
}
void DemSystem::bench_forces() { run_forces(*impl_); }
void DemSystem::bench_rebuild() { rebuild(); }
void DemSystem::synchronize() const {
  impl_->ex.synchronize();
  impl_->sched.check_arrived();
}

double DemSystem::time() const { return impl_->time; }
Index DemSystem::size() const { return impl_->store.owned(); }
Index DemSystem::global_size() const {
  const Impl& m = *impl_;
  return m.comm ? static_cast<Index>(m.comm->sum(static_cast<long>(m.store.owned()))) : m.store.owned();
}
const DemParams& DemSystem::params() const { return impl_->p; }
Backend DemSystem::backend() const { return impl_->ex.backend(); }
double DemSystem::cell_size(int axis) const { return 1.0 / impl_->lists.grid.inv_cl[axis]; }

}  // namespace lbdem::dem
