// DEM scene driver: `scene: dem` case files (cases/dem_*.yaml).
//
// Every key is read through Config (range-checked, unknown keys rejected by
// finish() on each section); the command line (RunOptions) wins over the file
// for backend, step count, output folder, overwrite and quiet.
//
// The time loop: advance the DEM system in chunks up to the next output or
// time-series sample; nothing is copied to the host between samples (apart
// from the engine's small asynchronous rebuild reports, dem/src/system.cu).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <sstream>

#include "dem/particle_output.hpp"
#include "cases/scenes.hpp"
#include "halo/simulation.hpp"
#include "dem/checkpoint.hpp"
#include "dem/particle_reader.hpp"
#include "scene_checks.hpp"
#include "core/output_section.hpp"
#include "core/run_length.hpp"
#include "core/error.hpp"
#include "core/output.hpp"
#include "core/progress.hpp"
#include "core/signals.hpp"
#include "dem/domain.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"
#include "halo/comm.hpp"
#include "halo/parallel_options.hpp"

namespace lbdem {

namespace {

using dem::DemParams;
using dem::HostParticles;

Vec3d vec3(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

struct DemCase {
  DemParams params;
  HostParticles particles;
  long steps = 0;
  std::string outdir;
  long output_interval = 0;  // particle snapshots every N steps (0: first and last only)
  long series_interval = 0;  // time-series rows every N steps
  std::vector<std::int64_t> track;  // ids whose position/velocity go into the series
  std::array<int, 3> decomposition{0, 0, 0};  // ranks per axis ({0, 0, 0}: chosen)
  std::string decomposition_key;              // where the case file gave it
  ckpt::Policy checkpoint;
};

DemCase read_case(const Config& root, const RunOptions& opt) {
  DemCase c;
  DemParams& p = c.params;
  {
    const Config d = root.section("domain");
    const auto lo = d.numbers("lo", 3, 3), hi = d.numbers("hi", 3, 3);
    for (int k = 0; k < 3; ++k) {
      p.lo[k] = lo[k];
      p.hi[k] = hi[k];
      if (!(hi[k] > lo[k])) d.fail("hi", "each component must exceed domain.lo");
    }
    if (d.has("periodic")) {
      const auto per = d.integers("periodic", 3, 3, 0, 1);
      for (int k = 0; k < 3; ++k) p.periodic[k] = per[k] != 0;
    }
    d.finish();
  }
  if (root.has("walls")) {
    for (const Config& w : root.sequence("walls")) {
      dem::Wall wall{vec3(w.numbers("point", 3, 3)), vec3(w.numbers("normal", 3, 3))};
      if (!(norm(wall.normal) > 0)) w.fail("normal", "must be a non-zero vector (pointing into the domain)");
      p.walls.push_back(wall);
      w.finish();
    }
  }
  {
    const Config ph = root.section("physics");
    p.gravity = vec3(ph.numbers("gravity", {0, 0, 0}, 3, 3));
    p.body_force = vec3(ph.numbers("body_force", {0, 0, 0}, 3, 3));
    p.friction = ph.boolean("friction", false);
    ph.finish();
  }
  dem::read_material(root.section("material"), p, dem::FrictionFrom::Physics);
  c.particles =
      dem::read_particles(root.section("particles"), p, {.density = 2600.0, .validate_only = opt.validate_only});
  double rmin = 1e300;
  for (double r : c.particles.r) rmin = std::min(rmin, r);
  {
    const auto nb = root.optional_section("neighbours");
    p.skin = 0.2 * rmin;
    p.path = dem::ForcePath::Particle;
    if (nb) {
      p.skin = nb->positive("skin", p.skin);
      // Default: particle-parallel (deterministic, no atomics). See
      // bench/NOTES_dem.md for the pair-path numbers behind this choice.
      p.path = nb->choice("force_path", "particle", {"particle", "pair"}) == "pair" ? dem::ForcePath::Pair
                                                                              : dem::ForcePath::Particle;
      p.neighbour_capacity = static_cast<int>(nb->integer_in("capacity", 0, 0, 4096));
      // global_id: contacts summed in partner-id order, the same sums on any
      // number of ranks (the default on several ranks).
      if (nb->has("contact_order"))
        p.contact_order = nb->choice("contact_order", {"storage", "global_id"}) == "global_id"
                              ? dem::ContactOrder::GlobalId
                              : dem::ContactOrder::Storage;
      nb->finish();
    }
    if (halo::Comm::world().size() > 1 && !(nb && nb->has("contact_order")))
      p.contact_order = dem::ContactOrder::GlobalId;
  }
  {
    const Config t = root.section("time");
    p.min_steps_per_collision = t.number_in("min_steps_per_collision", 50.0, 5.0, 1e9,
                                            "steps per collision time below which dt is refused (Yu et al. use 50)");
    const double tc = dem::min_collision_time(p, c.particles);
    if (t.has("dt")) {
      p.dt = t.positive("dt");
    } else {
      const double spc = t.number_in("steps_per_collision", 50.0, 5.0, 1e9);
      if (!std::isfinite(tc)) t.fail("steps_per_collision", "no contacts possible: give time.dt");
      p.dt = tc / spc;
    }
    dem::check_time_step(p, c.particles, t.full_key(t.has("dt") ? "dt" : "steps_per_collision"));
    const RunLength len = read_run_length(t, 0, std::numeric_limits<long>::max());
    c.steps = len.end ? saturating_steps(std::ceil(*len.end / p.dt - 1e-9)) : *len.steps;
    t.finish();
  }
  {
    OutputSettings o = read_output(root, kOutputInterval | kOutputSeries | kOutputTrack);
    c.outdir = o.directory;
    c.output_interval = o.interval;
    c.series_interval = o.series_interval;
    c.track = std::move(o.track);
  }
  // The cut: parallel.decomposition, as in every scene. The top-level
  // `decomposition` of earlier versions still works, with a warning naming
  // the new key.
  c.decomposition = halo::parse_parallel(root).decomposition;
  c.decomposition_key = "parallel.decomposition";
  if (root.has("decomposition")) {
    if (c.decomposition[0] > 0) root.fail("decomposition", "give the cut once, as parallel.decomposition");
    const auto d = root.integers("decomposition", 3, 3, 1, 1 << 20);
    for (std::size_t k = 0; k < 3; ++k) c.decomposition[k] = static_cast<int>(d[k]);
    c.decomposition_key = "decomposition";
    if (halo::Comm::world().root())
      spdlog::warn("{}: key 'decomposition' is deprecated; write it as 'parallel.decomposition'", root.source());
  }
  c.checkpoint = ckpt::read_policy(root);
  root.accept("scene");
  root.finish();
  if (opt.steps) c.steps = *opt.steps;
  if (opt.output) c.outdir = *opt.output;
  // Tracked ids must exist.
  for (std::int64_t id : c.track)
    if (std::find(c.particles.id.begin(), c.particles.id.end(), id) == c.particles.id.end())
      throw ConfigError("output.track: particle id " + std::to_string(id) + " does not exist (ids 0.." +
                        std::to_string(c.particles.size() - 1) + ")");
  dem::check_dem_scene(root, c.params, c.particles, c.steps, cases::planned_backend(opt), opt.force, opt.steps.has_value());
  return c;
}

// Particles of every rank, in global-id order (collective; written by rank 0).
void write_particles(io::ParticleWriter* w, const dem::DemSystem& sys, long step) {
  const HostParticles h = sys.gather();
  if (!w) return;
  const std::vector<double> frc = dem::interleave(h.f);
  dem::write_particle_snapshot(*w, step, sys.time(), h, {{"force", 3, frc.data()}});
}

// A series row from every rank's particles (collective; the row on rank 0).
// The sums run in global-id order on several ranks, and with contact_order
// global_id on one (the same bits on any number of ranks); else in storage order.
std::vector<double> series_row(const dem::DemSystem& sys, long step, const std::vector<std::int64_t>& track) {
  const bool by_id = halo::Comm::world().size() > 1 || sys.params().contact_order == dem::ContactOrder::GlobalId;
  const HostParticles h = by_id ? sys.gather() : sys.download();
  if (!halo::Comm::world().root()) return {};
  double ke = 0, kr = 0, vmax = 0;
  std::map<std::int64_t, Index> at;
  for (Index i = 0; i < h.size(); ++i) {
    ke += 0.5 * h.mass[i] * dot(h.v[i], h.v[i]);
    kr += 0.5 * dem::sphere_inertia(h.mass[i], h.r[i]) * dot(h.w[i], h.w[i]);
    vmax = std::max(vmax, norm(h.v[i]));
    at[h.id[i]] = i;
  }
  std::vector<double> row{static_cast<double>(step), sys.time(), ke, kr, vmax,
                          static_cast<double>(sys.stats().rebuilds)};
  for (std::int64_t id : track) {
    const Index i = at.at(id);
    for (int k = 0; k < 3; ++k) row.push_back(h.x[i][k]);
    for (int k = 0; k < 3; ++k) row.push_back(h.v[i][k]);
  }
  return row;
}

// Steps between two stop checks of a DEM run: a power of two, so that a
// chunk takes ~0.1-0.3 s at the speeds this code reaches (bench/results:
// ~1e9 particle-steps/s on one GPU, a step no shorter than ~30 us; ~1e6 per
// host core), 16 to 8192. A chunk boundary costs a closing half kick (cheaper
// than the integration of one step) and, on the GPU, one wait for the
// rebuild report: under 1 % at these lengths.
long stop_poll_steps(Index particles, Backend backend) {
  const double budget = backend == Backend::Cuda ? 2e8 : 2.5e5;  // particle-steps per chunk
  const double want = budget / static_cast<double>(std::max<Index>(particles, 1));
  long s = 16;
  while (s < 8192 && 2.0 * static_cast<double>(s) <= want) s *= 2;
  return s;
}

}  // namespace

std::vector<std::string> dem_scene_names() { return {"dem"}; }

int run_dem_case(const Config& root, const RunOptions& opt) {
  DemCase c = read_case(root, opt);
  const Backend backend = resolve_backend(opt.backend);
  // Many ranks (mpirun): each owns the particles of its piece of the box;
  // rank 0 writes every file.
  const halo::Comm& comm = halo::Comm::world();
  const dem::DemDomain domain = comm.size() > 1 || c.decomposition[0] > 0
                                    ? dem::decompose_box(comm, c.params, c.particles, c.decomposition, c.decomposition_key)
                                    : dem::DemDomain{};
  if (opt.validate_only) return 0;
  const bool writer_rank = comm.root();
  // A checkpoint of any rank count restarts here (rank 0 reads it).
  ckpt::Run ck = halo::open_run(c.outdir, c.checkpoint,
                                 ckpt::Identity{}
                                     .add("scene", "dem")
                                     .add("particles", std::to_string(c.particles.size()))
                                     .add("friction", c.params.friction ? "on" : "off")
                                     .add("force_path", dem::to_string(c.params.path)),
                                 opt.restart, comm);
  const std::string dims = domain.decomposed() ? domain.dec.describe() : "1 x 1 x 1";
  if (comm.distributed()) ck.set_layout(halo::rank_layout(comm.size(), dims));
  halo::prepare_output_on_writer(ck, writer_rank, comm, opt.overwrite, c.outdir);
  dem::DemSystem sys(Exec(backend), c.params, c.particles, domain);
  const DemParams& p = sys.params();
  const Index n_particles = sys.global_size();
  const bool quiet = opt.quiet || !writer_rank;
  if (!quiet) {
    if (domain.decomposed())
      spdlog::info("scene dem: {} ranks, decomposition {}", comm.size(), domain.dec.describe());
    spdlog::info("scene dem: {} particles, backend {}, {} force path, friction {}, dt = {:.6g} s (t_c/{:.1f}), {} "
                 "steps = {:.6g} s; output in {}",
                 n_particles, to_string(backend), dem::to_string(p.path), p.friction ? "on" : "off", p.dt,
                 dem::min_collision_time(p, c.particles) / p.dt, c.steps, c.steps * p.dt, c.outdir);
  }
  std::optional<io::ParticleWriter> writer;
  if (writer_rank) writer.emplace(c.outdir, "particles");
  std::vector<std::string> cols{"step", "time", "kinetic_energy", "rotational_energy", "max_speed", "rebuilds"};
  for (std::int64_t id : c.track)
    for (const char* q : {"x", "y", "z", "vx", "vy", "vz"}) cols.push_back(std::string(q) + "_" + std::to_string(id));
  std::optional<io::TimeSeries> series;
  if (writer_rank) series.emplace(halo::open_series(ck, c.outdir + "/series.csv", cols, c.series_interval));
  io::ParticleWriter* w = writer ? &*writer : nullptr;
  long step0 = 0;
  if (ck.restarting()) {  // the state of the checkpoint's step; its series and snapshots are kept
    dem::load_dem(ck, comm, sys, dims);
    step0 = ck.restart_step();
    if (writer) writer->resume(step0);
  }
  // A stop signal (core/signals.hpp) is honoured between advance() calls,
  // which end at the series and output steps and at every multiple of
  // stop_poll_steps. The chunk lengths (each call ends with a closing half
  // kick, so they shape the bits) depend on the case and the backend only,
  // never on the wall clock or on whether a signal came: a run stopped and
  // restarted gives the bits of one never stopped. A signal reaching any rank
  // stops all of them at the same step.
  sim::Simulation loop(comm, "dem", step0, c.steps,
                       sim::Stepping{.chunk = stop_poll_steps(n_particles, backend), .wait = [&] { sys.synchronize(); }},
                       "dem");
  loop.add("series", sim::Trigger{.every_steps = c.series_interval, .at_start = true, .at_end = true},
           [&](const sim::Event& e) {
             const std::vector<double> row = series_row(sys, e.step, c.track);
             if (series) series->append(row);
             if (comm.any(series && !std::isfinite(row[2])))
               throw DivergenceError("scene dem: kinetic energy is " +
                                     (row.empty() ? std::string("not finite") : std::to_string(row[2])) + " at step " +
                                     std::to_string(e.step) + " (t = " + std::to_string(sys.time()) +
                                     " s): lower time.dt or check the material and the initial overlaps");
           });
  loop.add("snapshot", sim::Trigger{.every_steps = c.output_interval, .at_start = true, .at_end = true},
           [&](const sim::Event& e) { write_particles(w, sys, e.step); });
  // DEM's bits depend on where its fixed chunks end: a checkpoint interval
  // must not add chunk ends (a run with checkpoints equals one without), so
  // a checkpoint comes where a chunk end falls on a multiple of the interval.
  sim::Trigger ckpt_when = sim::checkpoint_trigger(c.checkpoint);
  ckpt_when.aligned = false;
  loop.add("checkpoint", ckpt_when,
           [&](const sim::Event& e) { dem::save_dem(ck, comm, e.step, sys.time(), sys, {}); });
  loop.progress([&](long) { return sys.time(); }, static_cast<double>(n_particles), "particle-steps/s", quiet);
  loop.run([&](long n) { sys.advance(n); });
  const long step = loop.step();
  const auto st = sys.stats();
  loop.summary()
      .set("particles", n_particles)
      .set("time_s", sys.time())
      .set("rebuilds", st.rebuilds)
      .set("backend", to_string(backend));
  if (loop.conclude(c.outdir, sys.time()) != 0) return kExitInterrupted;
  if (!quiet) {
    spdlog::info("done: {} steps in {}, {} neighbour-list rebuilds (every {:.1f} steps), {:.1f} neighbours per "
                 "particle; results: {}/particles.xdmf (ParaView), {}/series.csv",
                 step, format_duration(loop.elapsed()), st.rebuilds,
                 st.rebuilds > 0 ? static_cast<double>(step) / st.rebuilds : 0.0, st.mean_neighbours, c.outdir,
                 c.outdir);
  }
  return 0;
}

}  // namespace lbdem
