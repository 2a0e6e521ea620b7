// The resolved particle scene (PSM fluid + DEM particles): the coupled PSM-DEM
// time step (imb/coupled.hpp) for any set of particles: a rotating held
// sphere, a sphere settling in a closed box, a periodic suspension with the
// weight balanced by a fluid body force.
//
// Units: lattice units or `units: physical`: SI values (fluid density and
// kinematic viscosity, particle diameter and density, gravity, box size,
// stiffness, speeds, times) with the resolution particles.cells_per_diameter
// (d/l) and fluid.tau or time.dt, converted once at parse time
// (core/units.hpp) and checked as the fluid scenes are (tau, Mach number, DEM
// time step). The run itself is in lattice units; summary.json gives the
// conversion factors dx, dt and dm.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <span>
#include <unordered_map>
#include <spdlog/spdlog.h>

#include "imb/fixed_sphere.hpp"
#include "lbm/distributed_fluid.hpp"
#include "halo/comm.hpp"
#include "halo/decomposition.hpp"
#include "halo/stop_poll.hpp"
#include "dem/particle_output.hpp"
#include "cfd/homogeneous_slip.hpp"
#include "dem/packing.hpp"
#include "imb/suspension.hpp"
#include "core/output_section.hpp"
#include "core/units.hpp"
#include "cases/scenes.hpp"
#include "halo/simulation.hpp"
#include "core/json.hpp"
#include "halo/rank_memory.hpp"
#include "imb/checkpoint.hpp"
#include "imb/coupled_run.hpp"
#include "scene_checks.hpp"
#include "core/error.hpp"
#include "core/output.hpp"
#include "core/phase_clock.hpp"
#include "core/progress.hpp"
#include "core/signals.hpp"
#include "core/memory_use.hpp"
#include "dem/domain.hpp"
#include "dem/grid_box.hpp"
#include "dem/init.hpp"
#include "dem/particle_reader.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "imb/coupled_checks.hpp"
#include "imb/coupled_output.hpp"
#include "imb/drag_error.hpp"
#include "imb/fraction_table.hpp"
#include "imb/physical_units.hpp"
#include "imb/psm_reader.hpp"
#include "imb/psm_settings.hpp"
#include "imb/suspension_reader.hpp"
#include "lbm/storage_checks.hpp"
#include "lbm/tau.hpp"

namespace lbdem {
namespace {

// --------------------------------------------------------- coupled particles
struct ParticlesCase {
  lbm::LbmSetup setup;
  dem::DemParams dem;
  dem::HostParticles particles;  // this rank's with particles.packing: blocks, else every particle
  // particles.packing: blocks (dem/block_packing.hpp): packed per rank once
  // the decomposition is known; particle_count is over all ranks.
  std::optional<dem::BlockPackingSpec> blocks;
  long particle_count = 0;
  imb::CoupledParams coupling;
  bool balance = false;
  double density_ratio = 1;
  long steps = 0, series_interval = 100, output_interval = 0;
  std::vector<std::int64_t> track;
  std::string outdir;
  double max_mach = 0.3;
  // units: physical converts the file's SI values with `units` once, here;
  // in lattice units `units` is the identity (dx = dt = dm = 1).
  bool physical = false;
  Units units;
  double diameter = 1;        // lattice units (cells)
  double solid_fraction = 0;  // sum of the particle volumes over the fluid box
  int dim = 3;
  std::array<long, 3> fluid_lo{0, 0, 0}, fluid_hi{1, 1, 1};
  bool fields_fp32 = false;  // output.field_precision
  bool async_output = false;  // output.background
  bool final_output = true;   // output.final
  ckpt::Policy checkpoint;
  double max_drag_error = imb::kMaxDragErrorBar;
  halo::ParallelOptions parallel;  // mpirun: how the grid (and with it the particles) is cut
  imb::PsmSettings psm;            // every resolved PSM setting (summary.json "psm")
};

ParticlesCase parse_particles(const Config& root, const RunOptions& opt) {
  ParticlesCase c;
  c.physical = root.choice("units", {"lattice", "physical"}) == "physical";
  auto& s = c.setup;
  Units& U = c.units;  // identity in lattice units
  const Config d = root.section("domain");
  const Config f = root.section("fluid");
  const Config pc = root.section("particles");
  const Config t = root.section("time");
  // What the checks and messages of the coupled code call the parameters: the keys of this file.
  imb::CoupledKeys& keys = c.coupling.keys;
  keys.cells = keys.dem_lo = keys.dem_hi = d.full_key(c.physical ? "size" : "cells");
  keys.dem_periodic = d.full_key("periodic");
  keys.density = pc.full_key(c.physical ? "density" : "density_ratio");
  keys.dem_dt = "the DEM time step";  // 1 / dem.substeps, not a key of the file
  keys.slots = "psm.slots";
  std::vector<long> cells;
  double diam = 0;
  if (c.physical) {
    // SI in (imb/physical_units.hpp): dx from the particle diameter and d/l, tau or dt from the viscosity.
    imb::PhysicalGrid g = imb::read_physical_grid(root, d, f, pc, t);
    U = g.units;
    s.tau = U.tau;
    diam = g.cells_per_diameter;
    cells = std::move(g.cells);
  } else {
    cells = d.integers("cells", 2, 3, 1, 1 << 20);
  }
  const int dim = cells.size() == 2 ? 2 : 3;
  c.dim = dim;
  s.lattice = dim == 2 ? lbm::LatticeKind::D2Q9 : lbm::LatticeKind::D3Q19;
  const auto per = d.integers("periodic", static_cast<std::size_t>(dim), 3, 0, 1);
  std::array<bool, 3> periodic{per[0] != 0, per[1] != 0, dim == 3 ? per[2] != 0 : true};
  d.finish();
  // Closed axes get a wall layer on each side: the fluid spans [1, cells + 1] there.
  std::array<long, 3> ext{cells[0], cells[1], dim == 3 ? cells[2] : 1};
  for (int a = 0; a < dim; ++a)
    if (!periodic[static_cast<std::size_t>(a)]) ext[static_cast<std::size_t>(a)] += 2;
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    c.fluid_lo[k] = a < dim && !periodic[k] ? 1 : 0;
    c.fluid_hi[k] = c.fluid_lo[k] + (a < dim ? cells[k] : 1);
  }
  s.domain = Grid::whole(ext, periodic);
  bool any_wall = false;
  for (int a = 0; a < dim; ++a) any_wall |= !periodic[static_cast<std::size_t>(a)];
  if (any_wall) {
    s.boundaries.count = 1;
    s.boundaries.kind[0] = lbm::BoundaryKind::Wall;
    s.boundaries.rho[0] = 1.0;
  }
  imb::read_fluid_common(f, s, !c.physical);
  if (c.physical && lbm::bgk_too_close_to_half(s.collision, s.tau))
    (f.has("tau") ? f : t).fail(f.has("tau") ? "tau" : "dt", "gives tau = " + std::to_string(s.tau) +
                                                                  ": BGK needs tau >= 0.51 to stay stable; use "
                                                                  "collision: trt for smaller tau");
  c.max_mach = f.number_in("max_mach", 0.3, 0.01, 0.5, "largest lattice Mach number |u| sqrt(3) before the run stops");
  f.finish();
  imb::check_particles_memory(root, keys, s, 0, cases::planned_backend(opt));
  const Config ph = root.section("physics");
  keys.gravity = keys.dem_gravity = ph.full_key("gravity");
  keys.body_force = ph.full_key("balance_weight");
  const auto gv = ph.numbers("gravity", {0, 0, 0}, 3, 3);
  c.coupling.gravity = {U.to_lattice_acceleration(gv[0]), U.to_lattice_acceleration(gv[1]),
                        U.to_lattice_acceleration(gv[2])};
  const bool all_periodic = periodic[0] && periodic[1] && periodic[2];
  c.balance = ph.boolean("balance_weight", all_periodic);
  if (c.balance && !all_periodic)
    ph.fail("balance_weight", "only a fully periodic domain needs a fluid body force to balance the particles' weight");
  c.coupling.buoyancy = ph.boolean("buoyancy", true);
  ph.finish();
  imb::FluidBox fb{dim, cells, c.fluid_lo, c.fluid_hi, periodic};
  imb::SuspensionParticles sp = imb::read_suspension_particles(
      root, pc, fb,
      {&U, c.physical, diam, c.max_mach, &s, cases::planned_backend(opt), opt.validate_only, keys});
  c.density_ratio = sp.density_ratio;
  c.diameter = diam = sp.diameter;
  c.particles = std::move(sp.particles);
  c.blocks = sp.blocks;
  c.solid_fraction = sp.solid_fraction;
  const double r = 0.5 * diam;
  // DEM in lattice units: the fluid grid's box, walls where the fluid has walls, contact law.
  auto& p = c.dem;
  imb::coupled_dem_box(p, s.domain, dim, diam);
  p.gravity = {c.coupling.gravity[0], c.coupling.gravity[1], c.coupling.gravity[2]};
  if (dim == 2) p.inertia_factor = 0.5;  // a disk about its axis
  p.external_forcing = true;
  p.friction = true;  // rotation under hydrodynamic torque; friction coefficient as given (0: none)
  const Config dm = root.section("dem");
  c.coupling.dem_substeps = dem::read_coupled_dem(dm, U, p);
  keys.dem_substeps = dm.full_key("substeps");
  keys.stiffness = dm.full_key("stiffness");
  p.skin = 0.1 * diam;
  dm.finish();
  c.coupling.psm.weight = imb::PsmWeight::NobleTorczynskiWall;  // the default with or without a psm section
  bool wall_lubrication = false;  // psm.wall_lubrication: off by default (an old case's answer stays)
  if (auto ps = root.optional_section("psm")) {
    imb::read_psm(*ps, c.coupling.psm, c.coupling.slots, c.max_drag_error);
    wall_lubrication = ps->choice("wall_lubrication", "off", {"on", "off"}) == "on";
    ps->finish();
  }
  c.coupling.psm.map.max_radius = r;
  s.magic = imb::resolve_magic(s.magic, diam, s.tau);
  {  // the gap correction at the fluid's walls (the bounce-back faces of the closed axes), if inside its fit
    imb::LubricationWall walls[imb::kMaxLubricationWalls];
    const int nw = imb::closed_box_walls(s.domain, dim, walls);
    c.coupling.wall_lubrication = imb::resolve_wall_lubrication(
        wall_lubrication, dim, s.tau, s.collision == lbm::CollisionKind::TRT, s.magic, c.coupling.psm.weight,
        c.coupling.psm.variant, c.coupling.psm.map.method, c.coupling.fluid_density, walls, nw);
  }
  c.steps = imb::read_coupled_steps(t, U, c.physical);  // time.end in seconds with physical units
  t.finish();
  const OutputSettings o = read_output(root, kOutputInterval | kOutputSeries | kOutputFields);
  c.outdir = o.directory;
  c.output_interval = o.interval;
  c.series_interval = o.series_interval;
  c.fields_fp32 = o.field_precision == "fp32" || (o.field_precision == "storage" && s.precision != lbm::Precision::FP64);
  c.async_output = o.background;  // a device pack and a host copy of the piece: 20 or 40 B per cell each
  c.final_output = o.final;
  c.checkpoint = ckpt::read_policy(root);
  c.parallel = halo::parse_parallel(root);
  root.accept("scene");
  root.finish();
  if (opt.steps) c.steps = *opt.steps;
  if (opt.output) c.outdir = *opt.output;
  const halo::Comm& world = halo::Comm::world();
  const bool split = c.blocks && world.distributed();  // each rank holds its own particles
  if (c.blocks) {
    // This rank's piece, as run_particles_case cuts the grid and the DEM box.
    std::optional<dem::DemDomain> dom;
    if (split)
      dom = dem::domain_from_decomposition(
          world, halo::decompose(s.domain, world.size(), c.parallel.decomposition, "parallel.decomposition"), p);
    c.particles = dem::suspension_blocks(*c.blocks, dom ? &*dom : nullptr);
    if (dim == 2)  // disks one cell deep, as above
      for (std::size_t i = 0; i < c.particles.mass.size(); ++i) c.particles.mass[i] *= 0.75 / c.particles.r[i];
  }
  c.particle_count = c.blocks ? c.blocks->count : static_cast<long>(c.particles.size());
  if (c.particle_count == 0) throw ConfigError("particles: no particles given");
  if (c.balance) {
    const double V = double(ext[0]) * ext[1] * ext[2];
    if (c.blocks) {
      // Every particle of a block packing has one radius and mass: the
      // count times one particle's share, the same on every rank.
      dem::HostParticles one;
      one.add(c.particles.x[0], c.particles.r[0], 0.0);
      one.mass[0] = c.particles.mass[0];
      const auto f1 = imb::balancing_body_force(one, dim, c.coupling.gravity, 1.0, V);
      for (std::size_t a = 0; a < 3; ++a) s.body_force[a] = f1[a] * double(c.particle_count);
    } else {
      s.body_force = imb::balancing_body_force(c.particles, dim, c.coupling.gravity, 1.0, V);
    }
  }
  // Refuse up front what would blow up (Mach, cell Reynolds number, light
  // particles, DEM sub-steps, unbalanced weight), naming the key to change.
  // With each rank's own particles, every rank refuses if one does.
  std::string refused;
  try {
    imb::check_particles_scene(root, s, p, c.particles, c.coupling, c.balance, c.steps, cases::planned_backend(opt),
                               opt.force, opt.steps ? "--steps" : "time.steps");
    imb::check_coupled_setup(s, p, c.particles, c.coupling, {}, split ? &world : nullptr);
  } catch (const ConfigError& e) {
    if (!split) throw;
    refused = e.what();
  }
  if (split && world.any(!refused.empty()))
    throw ConfigError(refused.empty() ? root.source() + ": another rank's particles were refused (its message above)"
                                      : refused);
  {
    // 16-bit storage (lbm/storage_checks.hpp). The flow's scale: the largest
    // particle diameter (the flow around a particle sets the slowest local relaxation).
    double scale = 0;
    for (Index i = 0; i < c.particles.size(); ++i) scale = std::max(scale, 2 * c.particles.r[static_cast<std::size_t>(i)]);
    for (const auto& w : lbm::storage_warnings(s, 0.0, scale, double(c.steps))) spdlog::warn("{}: {}", root.source(), w);
  }
  // Every device allocation of the run, by component, before any is made (exit 4 when it does not fit).
  imb::check_coupled_memory(root, s, c.coupling, static_cast<double>(c.particles.size()), cases::planned_backend(opt),
                            {c.async_output, c.fields_fp32});
  return c;
}

// What the suspension statistics need of the scene.
imb::SuspensionStatsSpec suspension_stats_spec(const ParticlesCase& c) {
  imb::SuspensionStatsSpec sp;
  sp.dim = c.dim;
  sp.fluid_lo = c.fluid_lo;
  sp.fluid_hi = c.fluid_hi;
  sp.periodic = c.setup.domain.periodic;
  sp.gravity = c.coupling.gravity;
  sp.body_force = c.setup.body_force;
  sp.fluid_density = c.coupling.fluid_density;
  sp.buoyancy = c.coupling.buoyancy;
  sp.diameter = c.diameter;
  return sp;
}

// The Wen-Yu homogeneous slip of this suspension (cells per step). In 2D, of
// spheres of the disks' diameter and density at the areal fraction: the first
// paper's Table 2 gives its 2D and 3D suspensions one (the sphere's) terminal
// velocity, and compares both with Wen & Yu.
double wen_yu_prediction(const ParticlesCase& c) {
  const double nu = lbm::lattice_viscosity(c.setup.tau);
  return cfd::wen_yu_slip(c.solid_fraction, c.diameter, c.coupling.fluid_density, c.coupling.fluid_density * nu,
                            imb::mean_net_weight(suspension_stats_spec(c), c.particles, true));
}

// The Sangani-Acrivos terminal slip of one sphere in a periodic cube (0 otherwise), and the slip along -g.
double periodic_settling_reference(const ParticlesCase& c) {
  return imb::periodic_settling_reference(suspension_stats_spec(c), c.particles, c.setup.domain.global, c.setup.tau,
                                          c.solid_fraction);
}
double last_slip_along_gravity(const ParticlesCase& c, const imb::SuspensionSample& s) {
  return imb::slip_along_gravity(suspension_stats_spec(c), s);
}

json::Value json_vec(const std::array<double, 3>& v) { return json::Value::array_of(std::vector<double>(v.begin(), v.end())); }

// summary.json of a particle scene: the run, its units and conversion
// factors, the lattice parameters it ran with (numbers to the last bit: a
// physical-unit case and its lattice-unit twin compare exactly), the
// statistics against Wen-Yu.
void particles_summary(json::Value& js, const ParticlesCase& c, const imb::ParticleSeries& series, Index particles,
                       long job_steps, double secs, double cells, Backend backend) {
  const Units& U = c.units;
  const auto& n = c.setup.domain.global;
  const double wy = wen_yu_prediction(c);
  const double v_si = U.dx / U.dt;  // m/s per cell per step
  const auto& last = series.last();
  js.set("particles", particles)
      .set("seconds", secs)
      .set("coupled_mlups", cells * double(job_steps) / std::max(secs, 1e-12) / 1e6)
      .set("backend", to_string(backend))
      .set("units", c.physical ? "physical" : "lattice");
  js["conversion"]
      .set("dx_m", U.dx)
      .set("dt_s", U.dt)
      .set("dm_kg", U.dm())
      .set("note",
           "series.csv, fields and particle positions are in lattice units: length x dx_m, time x dt_s, mass x dm_kg, "
           "velocity x dx_m/dt_s, force x dm_kg dx_m/dt_s^2; the series' time column and the snapshots' times are in "
           "seconds in a physical-unit scene");
  js["lattice"]
      .set("cells", json::Value::array_of(std::vector<long>{n[0], n[1], n[2]}))
      .set("tau", c.setup.tau)
      .set("nu", lbm::lattice_viscosity(c.setup.tau))
      .set("diameter", c.diameter)
      .set("density_ratio", c.density_ratio)
      .set("gravity", json_vec(c.coupling.gravity))
      .set("body_force", json_vec(c.setup.body_force))
      .set("stiffness", c.dem.material.stiffness)
      .set("wall_stiffness", c.dem.material.wall_stiffness)
      .set("dem_substeps", c.coupling.dem_substeps)
      .set("solid_fraction", c.solid_fraction)
      .set("particle_count", c.particle_count);
  js["statistics"]
      .set("seconds", series.seconds())
      .set("fraction_of_run", series.seconds() / std::max(secs, 1e-12))
      .set("averaged_from_step", c.steps / 2)
      .set("averaged_samples", series.averaged_samples())
      .set("mean_slip", series.mean_slip())
      .set("mean_drag_over_weight", series.mean_drag_over_weight())
      .set("wen_yu_slip", wy)
      .set("slip_over_wen_yu", wy > 0 ? series.mean_slip() / wy : 0.0)
      .set("mean_slip_m_per_s", series.mean_slip() * v_si)
      .set("wen_yu_slip_m_per_s", wy * v_si)
      .set("last_slip", json_vec(last.slip))
      .set("last_granular_temperature", last.granular_temperature)
      .set("note",
           "slip: fluid velocity over the fluid volume minus the mean particle velocity, along -gravity, lattice units "
           "(cells per step) unless _m_per_s; Wen-Yu: the slip at which the Wen & Yu (1966) drag of a homogeneous "
           "suspension at this solid fraction balances the mean net weight");
  if (const double ref = periodic_settling_reference(c); ref > 0) {
    const double w = last_slip_along_gravity(c, last);
    js["reference"]
        .set("what",
             "terminal slip of one sphere in a periodic cube: Stokes drag of a simple cubic array, Sangani & Acrivos "
             "(1982) Eq. 60")
        .set("chi", c.diameter / double(n[0]))
        .set("slip", ref)
        .set("measured_slip", w)
        .set("relative_error", (w - ref) / ref)
        .set("re_p", w * c.diameter / lbm::lattice_viscosity(c.setup.tau));
  }
  js.set("psm", json::Value::parse(imb::psm_settings_json(c.psm)));
}

int run_particles(const Config& root, const RunOptions& opt) {
  // Set-up phases (summary.json "timing"), host wall time; each one ends
  // with the device idle, so its work is counted in it.
  using sclk = std::chrono::steady_clock;
  auto since = [](sclk::time_point t) { return std::chrono::duration<double>(sclk::now() - t).count(); };
  auto t_setup = sclk::now();
  ParticlesCase c = parse_particles(root, opt);  // the case, with the packing of init: random
  const double packing_secs = since(t_setup);
  const halo::Comm& comm = halo::Comm::world();
  const bool ranks = comm.distributed();
  const bool writer = comm.root();  // rank 0 writes every file
  dem::DemDomain domain;  // one rank: not cut
  if (ranks) {
    // The cut, checked before anything is allocated or written. Contacts
    // are summed in global-id order, so that the cut does not change them.
    domain = imb::coupled_domain(root.source(), c.setup, c.dim, c.dem, c.particles.r, c.parallel, comm, c.coupling.keys);
    c.dem.contact_order = dem::ContactOrder::GlobalId;
  }
  if (writer)  // 2D: the 2D map (fixed disks)
    imb::report_expected_drag_error(imb::drag_query(2 * c.particles.r[0], c.setup.tau, c.setup.collision, c.setup.magic,
                                                    c.coupling.psm, c.setup.precision, c.dim),
                                    c.max_drag_error, opt.validate_only, opt.quiet);
  c.psm = imb::psm_settings(root, imb::drag_query(c.diameter, c.setup.tau, c.setup.collision, c.setup.magic,
                                        c.coupling.psm, c.setup.precision, c.dim),
                       imb::to_string(imb::resolve_pipeline(c.coupling.psm, c.coupling.slots)), c.setup.precision, writer);
  c.psm.wall_lubrication = c.coupling.wall_lubrication;
  if (writer) {  // psm.wall_lubrication: told at check always, at the start of a run when asked for
    const auto& wl = c.coupling.wall_lubrication;
    if (wl.requested && !wl.applied) spdlog::warn("{}: psm.wall_lubrication {}", root.source(), wl.note);
    else if (opt.validate_only || (wl.requested && !opt.quiet)) spdlog::info("psm.wall_lubrication {}", wl.note);
  }
  const Backend backend = resolve_backend(opt.backend);
  const MemoryUse planned = imb::coupled_memory(c.setup, c.coupling, static_cast<double>(c.particles.size()), backend,
                                                {c.async_output, c.fields_fp32});
  const double cells = static_cast<double>(c.setup.domain.global_cells());
  if (opt.validate_only) {
    if (!writer) return 0;
    std::printf("%s: device memory (%s, %s, %s pipeline), %.4g cells, %lld particles:\n%s", root.source().c_str(),
                to_string(backend), lbm::to_string(c.setup.precision),
                imb::to_string(imb::resolve_pipeline(c.coupling.psm, c.coupling.slots)), cells,
                static_cast<long long>(c.particle_count), memory_table(planned, cells).c_str());
    return 0;
  }
  const bool quiet = opt.quiet || !writer;
  // A restart checks its checkpoint against this case before any output is
  // touched (rank 0 reads it; a checkpoint of any rank count restarts here).
  ckpt::Run ck = halo::open_run(
      c.outdir, c.checkpoint,
      lbm::fluid_identity("particles", c.setup).add("particles", std::to_string(c.particle_count)), opt.restart,
      comm);
  halo::prepare_output_on_writer(ck, writer, comm, opt.overwrite, c.outdir);
  // The fluid: the whole grid on one rank, this rank's piece (with its halo
  // exchange) on several.
  t_setup = sclk::now();
  lbm::DistributedFluid dfluid(c.setup, backend, c.parallel, comm);
  lbm::LbmSolver* fluid = &dfluid.local();
  if (ranks) ck.set_layout(halo::rank_layout(comm.size(), dfluid.decomposition().describe()));
  const auto& n = c.setup.domain.local;  // the whole grid (Grid::whole)
  const auto N = static_cast<std::size_t>(n[0] * n[1] * n[2]);
  // Closed axes carry one layer of half-way bounce-back wall cells on each side
  // (the walls sit at 1 and cells + 1; parse_particles put the DEM walls there).
  // Each rank sets up its own piece only (no whole-grid field).
  auto wall_flag = [&](long x, long y, long z) -> std::uint8_t {
    const long q[3] = {x, y, z};
    for (int a = 0; a < 3; ++a)
      if (!c.setup.domain.periodic[static_cast<std::size_t>(a)] && (q[a] == 0 || q[a] == n[a] - 1)) return 1;
    return 0;
  };
  dfluid.initialize_uniform(wall_flag, 1.0);
  // A restart does not compare whole-grid flags (none is built): the walls
  // follow from domain.periodic, which the checkpoint's identity holds.
  const std::vector<std::uint8_t> flags;
  fluid->synchronize();
  const double fluid_init_secs = since(t_setup);
  t_setup = sclk::now();
  dem::DemSystem dem(Exec(backend), c.dem, c.particles, domain);
  fluid->synchronize();
  const double distribution_secs = since(t_setup);
  t_setup = sclk::now();
  std::unique_ptr<imb::FractionTable> table;  // outlives cs, which reads it every step
  if (c.coupling.psm.map.method == imb::FractionMethod::Table) {
    table = std::make_unique<imb::FractionTable>(imb::build_fraction_table(c.setup.lattice == lbm::LatticeKind::D2Q9 ? 2 : 3));
    c.coupling.psm.map.table = table.get();
  }
  imb::CoupledSolver cs(*fluid, dem, c.coupling, {dfluid.halo(), &comm});
  fluid->synchronize();
  const double first_map_secs = since(t_setup);
  if (!quiet && ranks) spdlog::info("parallel: {} ({})", dfluid.describe(), comm.describe());
  if (!quiet)
    spdlog::info("scene particles: {} particles (d = {} cells, rho_s/rho_f = {}), grid {}x{}x{}, tau = {}, {} DEM "
                 "sub-steps, backend {}, weight balance {}, {} fractions, {} pipeline; output in {}",
                 c.particle_count, 2 * c.particles.r[0], c.density_ratio, n[0], n[1], n[2], c.setup.tau,
                 c.coupling.dem_substeps, to_string(backend), c.balance ? "on" : "off",
                 imb::to_string(c.coupling.psm.map.method), imb::to_string(cs.coupling().pipeline()), c.outdir);
  // Snapshots in pieces, every rank its own (imb/coupled_output.hpp); fields
  // leave the device slab by slab through the staging buffers the solver and
  // the coupling reserved at start: output allocates no device memory.
  imb::CoupledSnapshots snaps({c.outdir, c.fields_fp32, c.async_output, c.units.dt}, c.setup.domain,
                              dfluid.piece_boxes(), *fluid, dem, cs, comm);
  // A restart keeps the series rows up to its checkpoint and the series' accumulators.
  imb::SuspensionStatsSpec spec = suspension_stats_spec(c);
  if (ranks) {  // each rank keeps the coarse cells near its own piece (imb/suspension.hpp)
    spec.comm = &comm;
    for (const io::PieceBox& p : dfluid.piece_boxes()) {
      spec.piece_offset.push_back(p.offset);
      spec.piece_cells.push_back(p.cells);
    }
  }
  imb::ParticleSeries series(c.outdir + "/series.csv", cs, spec, c.units.dt, &ck, c.series_interval,
                               ranks ? std::function<lbm::LbmDiagnostics()>([&dfluid] { return dfluid.diagnostics(); })
                                     : std::function<lbm::LbmDiagnostics()>());
  series.average_from(c.steps / 2);  // the mean slip of summary.json: the run's second half
  long step0 = 0;
  if (ck.restarting()) {  // the state of the checkpoint's step; its series and snapshots are kept
    series.restore(imb::load_coupled(ck, comm, *fluid, c.setup.domain, flags, dem, cs,
                                       dfluid.decomposition().describe()));
    step0 = ck.restart_step();
    if (writer) {
      snaps.resume(step0);
    }
  }
  // Particles per rank at the series rows: the row with the largest max / mean.
  double ppr_max = 0, ppr_mean = 0;
  long ppr_step = 0;
  auto series_row = [&](long step) {
    cs.phase_clock().collect();  // the device samples so far (the row synchronises anyway)
    {
      const long mine = static_cast<long>(dem.size());
      const long mx = ranks ? comm.max(mine) : mine;
      const double mean = ranks ? double(comm.sum(mine)) / comm.size() : double(mine);
      if (mean > 0 && (ppr_mean == 0 || mx / mean > ppr_max / ppr_mean)) {
        ppr_max = double(mx);
        ppr_mean = mean;
        ppr_step = step;
      }
    }
    const auto d = series.append(step);
    const double ma = d.max_speed * std::sqrt(3.0);
    if (!d.finite)
      throw DivergenceError("scene particles: non-finite fluid state at step " + std::to_string(step) + ", cell (" +
                            std::to_string(d.nonfinite_cell[0]) + ", " + std::to_string(d.nonfinite_cell[1]) + ", " +
                            std::to_string(d.nonfinite_cell[2]) + "); output so far is kept in " + c.outdir +
                            ". Raise fluid.tau, lower the particle speeds, or raise dem.substeps");
    if (ma > c.max_mach)
      throw DivergenceError("scene particles: lattice Mach number " + std::to_string(ma) + " at step " +
                            std::to_string(step) + " exceeds fluid.max_mach = " + std::to_string(c.max_mach) +
                            "; output so far is kept in " + c.outdir +
                            ". Any one of: lower physics.gravity or particles.velocity; raise fluid.tau (a more "
                            "viscous fluid settles the particles slower); a finer grid (a larger particles.diameter "
                            "in cells for the same particle)");
  };
  // Coupled steps split into calls as the stop poll likes (the same steps as
  // one longer call): a stop signal (core/signals.hpp) ends the run after the
  // step in progress; several ranks agree every ~0.25 s (halo/stop_poll.hpp).
  sim::Simulation loop(comm, "particles", step0, c.steps, sim::Stepping{.wait = [&] { fluid->synchronize(); }},
                       "coupled");
  loop.add("series", sim::Trigger{.every_steps = c.series_interval, .at_start = true, .at_end = true},
           [&](const sim::Event& e) { series_row(e.step); });
  // Snapshots every output.interval steps (and at step 0); at the end with output.final.
  loop.add("output",
           sim::Trigger{.every_steps = c.output_interval, .at_start = c.output_interval > 0, .at_end = c.final_output},
           [&](const sim::Event& e) { snaps.write(e.step); }, true);
  loop.add("checkpoint", sim::checkpoint_trigger(c.checkpoint), [&](const sim::Event& e) {
    imb::save_coupled(ck, comm, e.step, double(e.step) * c.units.dt, *fluid, dem, cs, series.state());
  }, true);
  loop.progress([&](long st) { return double(st) * c.units.dt; }, double(N) / 1e6, "MLUPS (coupled)", quiet);
  loop.run([&](long k) { cs.advance(k); });
  const long step = loop.step();
  fluid->synchronize();
  cs.check_overflow();
  const double secs = loop.elapsed();
  double output_secs = loop.phase("output");
  const double checkpoint_secs = loop.phase("checkpoint");
  {  // every snapshot on disk and indexed (a background write's failure surfaces here) before the summary
    const auto w0 = std::chrono::steady_clock::now();
    snaps.finish();
    output_secs += std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
  }
  json::Value& js = loop.summary();
  particles_summary(js, c, series, dem.global_size(), step - step0, secs, double(N), backend);
  {
    // Device memory held by the fluid and the coupling (their buffers), by
    // component (on several ranks: summed over the ranks, per component).
    MemoryUse held = fluid->memory_use();
    held.add(cs.memory_use());
    held.add(snaps.memory_use());
    std::vector<double> bytes;
    for (const auto& it : held.items) bytes.push_back(double(it.bytes));
    if (ranks) {
      // Every rank holds the same components (the same pipeline); a missing one counts 0.
      const std::vector<std::string> names = halo::memory_component_names(held, comm);
      bytes.assign(names.size(), 0.0);
      for (const auto& it : held.items)
        for (std::size_t k = 0; k < names.size(); ++k)
          if (names[k] == it.name) bytes[k] = double(it.bytes);
      comm.sum(bytes);
      held = MemoryUse{};
      for (std::size_t k = 0; k < names.size(); ++k) held.add(names[k], static_cast<std::size_t>(bytes[k]));
    }
    // The largest host buffer a rank's snapshot output held (values) and the
    // largest piece (cells): output holds one slab of a piece, or in the
    // background the rank's own piece (five values per cell).
    long out_buffer = static_cast<long>(snaps.largest_buffer_values());
    long piece_cells = static_cast<long>(fluid->setup().domain.cells());
    // Background snapshots' wall time, the largest rank's: what held the run
    // (the device pack and copy, waits for an earlier write) and the writer
    // thread's writes beside it.
    double bg_take = snaps.times().take, bg_wait = snaps.times().wait, bg_write = snaps.times().write;
    if (ranks) {
      out_buffer = comm.max(out_buffer);
      piece_cells = comm.max(piece_cells);
      bg_take = comm.max(bg_take);
      bg_wait = comm.max(bg_wait);
      bg_write = comm.max(bg_write);
    }
    json::Value& mem = js["memory_bytes"] = json::Value::object();
    for (const auto& it : held.items) mem.set(it.name, it.bytes);
    js.set("memory_bytes_per_cell", double(held.total()) / double(N)).set("dem_rebuilds", dem.stats().rebuilds);
    js["output"]
        .set("snapshots", snaps.count())
        .set("seconds", output_secs)
        .set("background", snaps.background())
        .set("background_copy_seconds", bg_take)
        .set("background_wait_seconds", bg_wait)
        .set("background_write_seconds", bg_write)
        .set("largest_host_buffer_values", out_buffer)
        .set("largest_piece_cells", piece_cells)
        .set("stepping_seconds", secs)
        .set("fraction_of_stepping", output_secs / std::max(secs, 1e-12))
        .set("checkpoints", ck.checkpoints_written())
        .set("checkpoint_seconds", checkpoint_secs)
        .set("note",
             "wall time in snapshot output (device copies and, unless background, the HDF5 writes) and in checkpoint "
             "writes; stepping_seconds includes the snapshots and checkpoints taken inside the loop; background: "
             "background_copy_seconds (device pack, one copy to host, particles) and background_wait_seconds (for an "
             "earlier write) hold the run, background_write_seconds is the writer thread's time beside it (max over "
             "ranks)");
    if (ranks) js.set("decomposition", dfluid.decomposition().describe());
    imb::timing_json(js, cs, dfluid, comm, {packing_secs, distribution_secs, fluid_init_secs, first_map_secs}, secs,
                output_secs, snaps.count(), ppr_max, ppr_mean, ppr_step);
  }
  if (loop.conclude(c.outdir, double(step) * c.units.dt) != 0) return kExitInterrupted;
  if (!quiet) {
    spdlog::info("done: {} coupled steps in {:.1f} s ({:.1f} MLUPS coupled); statistics {:.2f}% of it; results: "
                 "{}/fields.xdmf, {}/particles.xdmf (ParaView), {}/series.csv (lattice units; summary.json "
                 "gives dx, dt, dm)",
                 step - step0, secs, double(N) * (step - step0) / std::max(secs, 1e-12) / 1e6,
                 100 * series.seconds() / std::max(secs, 1e-12), c.outdir, c.outdir, c.outdir);
    if (c.particle_count > imb::ParticleSeries::kTrackedMax && series.averaged_samples() > 0)
      spdlog::info("mean slip over steps {}..{}: {:.4g} cells/step ({:.4g} x the Wen-Yu homogeneous slip {:.4g}); "
                   "drag / net weight {:.4f}",
                   c.steps / 2, step, series.mean_slip(), series.mean_slip() / wen_yu_prediction(c),
                   wen_yu_prediction(c), series.mean_drag_over_weight());
    if (const double ref = periodic_settling_reference(c); ref > 0) {
      const double w = last_slip_along_gravity(c, series.last());
      spdlog::info("check: terminal slip {:.5g} cells/step ({:.5g} m/s) against the Stokes drag of a periodic "
                   "array (Sangani & Acrivos 1982, d/L = {:.3g}) {:.5g}: error {:+.2f}% (PSM at d/l = {:g}; "
                   "Re_p = {:.3f})",
                   w, w * c.units.dx / c.units.dt, c.diameter / double(n[0]), ref, 100 * (w - ref) / ref, c.diameter,
                   w * c.diameter / lbm::lattice_viscosity(c.setup.tau));
    }
  }
  return 0;
}

}  // namespace

std::vector<std::string> particles_scene_names() { return {"particles"}; }

int run_particles_case(const Config& root, const RunOptions& opt) { return run_particles(root, opt); }

}  // namespace lbdem
