// Resolved particle scenes (PSM fluid + DEM particles), lattice units.
//
//   scene: fixed_sphere   flow through a simple cubic (3D) / square (2D) array
//                          of fixed spheres/disks driven by a body force, run to
//                          a steady state detected automatically; drag
//                          coefficient against Sangani & Acrivos (1982).
//   scene: particles      the coupled PSM-DEM time step (imb/coupled.hpp) for
//                          any set of particles: a rotating held sphere, a
//                          sphere settling in a closed box, a periodic
//                          suspension with the weight balanced by a fluid body force.
//
// Units: these scenes take lattice units (cell size 1, fluid time step 1,
// fluid density 1) and say so (`units: lattice` is required), because the
// validation cases of the first paper are stated that way (Tables 1-2).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <spdlog/spdlog.h>

#include "cases/fixed_sphere.hpp"
#include "cases/parallel.hpp"
#include "halo/comm.hpp"
#include "halo/decomposition.hpp"
#include "cases/particle_output.hpp"
#include "cases/scenes.hpp"
#include "scene_checks.hpp"
#include "core/error.hpp"
#include "core/output.hpp"
#include "core/progress.hpp"
#include "core/signals.hpp"
#include "dem/grid_box.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "imb/coupled_checks.hpp"
#include "imb/drag_error.hpp"
#include "imb/fraction_table.hpp"

namespace lbdem {
namespace {

void require_lattice_units(const Config& root) {
  const std::string u = root.choice("units", {"lattice"});
  (void)u;
}

// fluid.magic: auto (the default) marks Lambda for the resolution rule
// (imb::psm_magic_auto, set once the particle diameter is known).
constexpr double kMagicAuto = -1.0;

lbm::CollisionKind read_collision(const Config& f, double& magic, const std::string& def = "trt") {
  const auto c = f.choice("collision", def, {"bgk", "trt"});
  // The PSM drag depends on Lambda (bench/imb/NOTES.md, "Fixed-sphere drag"): auto
  // takes 1e-4 below d/l 16 and 3e-2 from 16, the setting the drag map is built on.
  if (!f.has("magic") || f.text("magic") == "auto") {
    if (f.has("magic")) f.accept("magic");
    magic = kMagicAuto;
  } else {
    magic = f.number_in("magic", 1e-6, 10.0,
                        "TRT parameter Lambda, or auto (1e-4 below d/l 16, 3e-2 from 16: the mapped PSM setting)");
  }
  return c == "bgk" ? lbm::CollisionKind::BGK : lbm::CollisionKind::TRT;
}

// Lambda of a PSM scene with particles of diameter d (cells): auto resolved.
double resolve_magic(double magic, double d) { return magic == kMagicAuto ? imb::psm_magic_auto(d) : magic; }

// tau, collision (with Lambda) and precision of a resolved scene's fluid
// section (FixedSphereSpec and LbmSetup name these fields alike).
template <class S>
void read_fluid_common(const Config& f, S& s) {
  s.tau = f.number_in("tau", 0.52, 0.5001, 5.0, "relaxation time tau > 1/2");
  s.collision = read_collision(f, s.magic);
  if (s.collision == lbm::CollisionKind::BGK && s.tau < 0.51)
    f.fail("tau", "BGK needs tau >= 0.51 to stay stable; use collision: trt for smaller tau");
  s.precision = f.choice("precision", "fp64", {"fp32", "fp64"}) == "fp32" ? lbm::Precision::FP32 : lbm::Precision::FP64;
}

// psm.max_expected_drag_error when not given: the half Table 1 bar at the scene's d/l.
constexpr double kMaxDragErrorBar = -1.0;

void read_psm(const Config& ps, imb::PsmOptions& o, int& slots, double& max_drag_error) {
  const auto fr = ps.choice("fraction", "exact", {"exact", "table", "linear"});
  o.map.method = fr == "table" ? imb::FractionMethod::Table : fr == "linear" ? imb::FractionMethod::Linear
                                                                             : imb::FractionMethod::Exact;
  o.variant = ps.choice("operator", "nebb", {"nebb", "superposition"}) == "nebb" ? imb::PsmVariant::NEBB
                                                                                 : imb::PsmVariant::Superposition;
  const auto we = ps.choice("weight", "noble_torczynski_wall", {"noble_torczynski_wall", "noble_torczynski", "linear"});
  o.weight = we == "linear"             ? imb::PsmWeight::Linear
             : we == "noble_torczynski" ? imb::PsmWeight::NobleTorczynski
                                        : imb::PsmWeight::NobleTorczynskiWall;
  max_drag_error = ps.has("max_expected_drag_error")
                       ? ps.number_in("max_expected_drag_error", 1e-6, 1.0,
                                      "relative drag error (0.02 = 2 %) above which the start report warns")
                       : kMaxDragErrorBar;
  o.map.table_in_constant = ps.boolean("table_in_constant", false);
  const auto pl = ps.choice("pipeline", "auto", {"auto", "fused", "mapped"});
  o.pipeline = pl == "fused" ? imb::PsmPipeline::Fused : pl == "mapped" ? imb::PsmPipeline::Mapped : imb::PsmPipeline::Auto;
  o.tile_capacity = static_cast<int>(ps.integer_in("tile_capacity", 64, 1, imb::kFusedMaxCapacity));
  slots = static_cast<int>(ps.integer_in("slots", 4, 1, 64));
  if (o.pipeline == imb::PsmPipeline::Fused) {  // refuse now, before any output is written
    imb::PsmOptions probe = o;
    if (probe.map.method == imb::FractionMethod::Table) probe.map.table = nullptr;
    try {
      (void)imb::resolve_pipeline(probe, slots);
    } catch (const ConfigError& e) {
      ps.fail("pipeline", e.what());
    }
  }
}

// The expected drag error of the scene as set up (imb/drag_error.hpp), told at
// `lbdem check` and at the start of a run; a warning when it is above
// psm.max_expected_drag_error (default: half the first paper's Table 1 error at
// this d/l).
void report_expected_drag_error(const imb::DragErrorQuery& q, double max_drag_error, const RunOptions& opt) {
  const auto e = imb::expected_drag_error(q);
  const double limit = max_drag_error == kMaxDragErrorBar ? e.bar : max_drag_error;
  const bool tell = opt.validate_only || !opt.quiet;  // `lbdem check` is quiet otherwise but tells this
  if (!e.known) {
    if (tell)
      spdlog::info("expected drag error at d/l = {}, tau = {}: no estimate ({})", q.diameter, q.tau, e.reason);
    return;
  }
  if (std::abs(e.error) > limit)
    spdlog::warn("expected drag error at d/l = {}, tau = {}: {:+.2f}% ({}), above psm.max_expected_drag_error = {:.2f}%: "
                 "a larger particle diameter in cells (a finer grid) or a tau nearer 0.5 lowers it",
                 q.diameter, q.tau, 100 * e.error, e.reason, 100 * limit);
  else if (tell)
    spdlog::info("expected drag error at d/l = {}, tau = {}: {:+.2f}% ({}; limit {:.2f}%)", q.diameter, q.tau,
                 100 * e.error, e.reason, 100 * limit);
}

imb::DragErrorQuery drag_query(double d, double tau, lbm::CollisionKind coll, double magic, const imb::PsmOptions& o,
                               lbm::Precision prec) {
  imb::DragErrorQuery q;
  q.diameter = d;
  q.tau = tau;
  q.trt = coll == lbm::CollisionKind::TRT;
  q.magic = magic;
  q.weight = o.weight;
  q.variant = o.variant;
  q.method = o.map.method;
  q.fp32 = prec == lbm::Precision::FP32;
  return q;
}

// ------------------------------------------------------------ fixed sphere
int run_fixed_sphere_case(const Config& root, const RunOptions& opt) {
  require_lattice_units(root);
  cases::FixedSphereSpec s;
  const Config g = root.section("geometry");
  s.dim = static_cast<int>(g.integer_in("dim", 3, 2, 3));
  s.diameter = g.number_in("diameter", 2.0, 1000.0, "sphere diameter in cells (d/l)");
  s.chi = g.number_in("chi", 0.5, 0.05, 0.75, "d/L, L the array period (Sangani-Acrivos series valid to 0.75)");
  s.offset = g.number_in("offset", 0.0, -0.5, 0.5, "sphere centre offset from the cell-aligned centre, cells");
  g.finish();
  const Config f = root.section("fluid");
  read_fluid_common(f, s);
  s.streaming = f.choice("streaming", "aa", {"aa", "two_lattice"}) == "aa" ? lbm::StreamKind::AA
                                                                          : lbm::StreamKind::TwoLattice;
  s.re_p = f.number_in("re_p", 0.2, 1e-4, 50.0, "target particle Reynolds number (sets the body force)");
  f.finish();
  imb::PsmOptions po;
  po.weight = imb::PsmWeight::NobleTorczynskiWall;  // the default with or without a psm section
  double max_drag_error = kMaxDragErrorBar;
  if (auto ps = root.optional_section("psm")) {
    read_psm(*ps, po, s.slots, max_drag_error);
    ps->finish();
  }
  s.magic = resolve_magic(s.magic, s.diameter);
  s.method = po.map.method;
  s.pipeline = po.pipeline;
  s.variant = po.variant;
  s.weight = po.weight;
  const Config st = root.section("steady");
  s.tolerance = st.number_in("tolerance", 1e-7, 1e-14, 1e-2, "estimated remaining relative change of the drag");
  s.max_steps = st.integer_in("max_steps", 2000000, 1, std::numeric_limits<long>::max());
  st.finish();
  const Config o = root.section("output");
  std::string outdir = o.text("directory");
  o.finish();
  s.parallel = parse_parallel(root);
  root.accept("scene");
  root.finish();
  if (opt.output) outdir = *opt.output;
  if (opt.steps) s.max_steps = *opt.steps;
  cases::check_fixed_sphere(root, s.dim, s.diameter, s.chi, s.precision, s.streaming, s.max_steps, opt);
  if (s.dim == 3) report_expected_drag_error(drag_query(s.diameter, s.tau, s.collision, s.magic, po, s.precision),
                                             max_drag_error, opt);
  const Backend backend = resolve_backend(opt.backend);
  const halo::Comm& comm = halo::Comm::world();
  s.comm = &comm;
  if (comm.distributed()) {
    // The cut is checked before anything is allocated or written.
    const long L = std::lround(s.diameter / s.chi);
    halo::decompose(Grid::whole({L, L, s.dim == 3 ? L : 1}), comm.size(), s.parallel.decomposition,
                    "parallel.decomposition");
  }
  if (opt.validate_only) return 0;
  if (comm.root()) io::prepare_output_dir(outdir, opt.overwrite);
  std::unique_ptr<imb::FractionTable> table;
  if (s.method == imb::FractionMethod::Table) {
    table = std::make_unique<imb::FractionTable>(imb::build_fraction_table(s.dim));
    s.table = table.get();
  }
  s.quiet = opt.quiet;
  if (!opt.quiet)
    spdlog::info("scene fixed_sphere: {}D, d/l = {}, chi = {}, tau = {}, {} Lambda = {}, {} fractions, backend {}",
                 s.dim, s.diameter, s.chi, s.tau, to_string(s.collision), s.magic, imb::to_string(s.method),
                 to_string(backend));
  const auto r = cases::run_fixed_sphere(s, backend);
  std::ostringstream js;
  js.precision(17);  // K to the last digit: runs are compared across rank counts and settings
  js << "{\n  \"scene\": \"fixed_sphere\",\n  \"dim\": " << s.dim << ",\n  \"diameter\": " << s.diameter
     << ",\n  \"chi\": " << s.chi << ",\n  \"tau\": " << s.tau << ",\n  \"magic\": " << s.magic
     << ",\n  \"K\": " << r.K << ",\n  \"K_reference\": " << r.K_ref << ",\n  \"relative_error\": " << r.rel_error
     << ",\n  \"re_p\": " << r.re_p << ",\n  \"steps\": " << r.steps << ",\n  \"converged\": "
     << (r.converged ? "true" : "false") << ",\n  \"seconds\": " << r.seconds << ",\n  \"mlups\": " << r.mlups
     << ",\n  \"interrupted\": " << (r.interrupted ? "true" : "false") << ",\n  \"ranks\": " << comm.size() << "\n}\n";
  if (comm.root()) io::write_text_atomically(outdir + "/summary.json", js.str());
  if (r.interrupted) {
    spdlog::warn("stopped by {} at step {} before the drag converged; K so far in {}/summary.json", stop_signal_name(),
                 r.steps, outdir);
    return kExitInterrupted;
  }
  if (!opt.quiet) {
    spdlog::info("K = {:.5f} against {} {:.5f}: error {:+.3f}%, Re_p = {:.3f}, {} steps{} in {:.1f} s ({:.1f} MLUPS)",
                 r.K, s.dim == 3 ? "Sangani & Acrivos (1982)" : "Sangani & Acrivos (1982, cylinders)", r.K_ref,
                 100 * r.rel_error, r.re_p, r.steps, r.converged ? "" : " (NOT converged: raise steady.max_steps)",
                 r.seconds, r.mlups);
    spdlog::info("results: {}/summary.json", outdir);
  }
  return r.converged ? 0 : 1;
}

// --------------------------------------------------------- coupled particles
struct ParticlesCase {
  lbm::LbmSetup setup;
  dem::DemParams dem;
  dem::HostParticles particles;
  imb::CoupledParams coupling;
  bool balance = false;
  double density_ratio = 1;
  long steps = 0, series_interval = 100, output_interval = 0;
  std::vector<std::int64_t> track;
  std::string outdir;
  double max_mach = 0.3;
  double max_drag_error = kMaxDragErrorBar;
};

ParticlesCase parse_particles(const Config& root, const RunOptions& opt) {
  require_lattice_units(root);
  ParticlesCase c;
  auto& s = c.setup;
  const Config d = root.section("domain");
  const auto cells = d.integers("cells", 2, 3, 1, 1 << 20);
  const int dim = cells.size() == 2 ? 2 : 3;
  s.lattice = dim == 2 ? lbm::LatticeKind::D2Q9 : lbm::LatticeKind::D3Q19;
  const auto per = d.integers("periodic", static_cast<std::size_t>(dim), 3, 0, 1);
  std::array<bool, 3> periodic{per[0] != 0, per[1] != 0, dim == 3 ? per[2] != 0 : true};
  d.finish();
  // Closed axes get a wall layer on each side: the fluid spans [1, cells + 1] there.
  std::array<long, 3> ext{cells[0], cells[1], dim == 3 ? cells[2] : 1};
  for (int a = 0; a < dim; ++a)
    if (!periodic[static_cast<std::size_t>(a)]) ext[static_cast<std::size_t>(a)] += 2;
  s.domain = Grid::whole(ext, periodic);
  bool any_wall = false;
  for (int a = 0; a < dim; ++a) any_wall |= !periodic[static_cast<std::size_t>(a)];
  if (any_wall) {
    s.boundaries.count = 1;
    s.boundaries.kind[0] = lbm::BoundaryKind::Wall;
    s.boundaries.rho[0] = 1.0;
  }
  const Config f = root.section("fluid");
  read_fluid_common(f, s);
  c.max_mach = f.number_in("max_mach", 0.3, 0.01, 0.5, "largest lattice Mach number |u| sqrt(3) before the run stops");
  f.finish();
  cases::check_particles_memory(root, s, 0, opt);
  const Config ph = root.section("physics");
  const auto gv = ph.numbers("gravity", {0, 0, 0}, 3, 3);
  c.coupling.gravity = {gv[0], gv[1], gv[2]};
  const bool all_periodic = periodic[0] && periodic[1] && periodic[2];
  c.balance = ph.boolean("balance_weight", all_periodic);
  if (c.balance && !all_periodic)
    ph.fail("balance_weight", "only a fully periodic domain needs a fluid body force to balance the particles' weight");
  c.coupling.buoyancy = ph.boolean("buoyancy", true);
  ph.finish();
  const Config pc = root.section("particles");
  c.density_ratio = pc.number_in("density_ratio", 1.0, 1e-3, 1e6, "solid / fluid density");
  const double diam = pc.number_in("diameter", 1.0, 1e4, "particle diameter in cells");
  const auto v0 = pc.numbers("velocity", {0, 0, 0}, 3, 3);
  const auto w0 = pc.numbers("angular_velocity", {0, 0, 0}, 3, 3);
  const bool held = pc.boolean("held", false);  // position and rotation prescribed (infinite mass)
  const std::string init = pc.choice("init", {"list", "random"});
  const double r = 0.5 * diam;
  // Mass of a solid sphere of density rho_s (lattice units: fluid density 1).
  const double rho_s = held ? 1e300 : c.density_ratio;
  if (init == "list") {
    for (const Config& it : pc.sequence("list")) {
      const auto x = it.numbers("position", dim, 3);
      c.particles.add({x[0], x[1], dim == 3 ? x[2] : 0.5}, r, held ? 1e300 / (4.0 / 3.0 * M_PI * r * r * r) : rho_s,
                      {v0[0], v0[1], v0[2]}, {w0[0], w0[1], w0[2]});
      it.finish();
    }
  } else {
    if (dim != 3) pc.fail("init", "random packing is 3D only; give a list in 2D");
    dem::RandomPackingSpec rs;
    for (int a = 0; a < 3; ++a) {
      const bool wa = !periodic[static_cast<std::size_t>(a)];
      rs.lo[static_cast<std::size_t>(a)] = wa ? 1.0 : 0.0;
      rs.hi[static_cast<std::size_t>(a)] = double(cells[static_cast<std::size_t>(a)]) + (wa ? 1.0 : 0.0);
    }
    rs.periodic = periodic;
    rs.solid_fraction = pc.number_in("solid_fraction", 1e-4, 0.6, "solid volume fraction of the box");
    rs.r_min = rs.r_max = r;
    rs.density = rho_s;
    rs.seed = static_cast<std::uint64_t>(pc.integer_in("seed", 1, 0, std::numeric_limits<long>::max()));
    cases::check_particles_random(root, pc, s, rs.lo, rs.hi, rs.periodic, rs.solid_fraction, r, opt);
    c.particles = dem::random_packing(rs);
    for (Index i = 0; i < c.particles.size(); ++i) {
      c.particles.v[static_cast<std::size_t>(i)] = {v0[0], v0[1], v0[2]};
      c.particles.w[static_cast<std::size_t>(i)] = {w0[0], w0[1], w0[2]};
    }
  }
  pc.finish();
  // DEM in lattice units: the fluid grid's box, walls where the fluid has walls, contact law.
  auto& p = c.dem;
  dem::set_box_from_grid(p, s.domain);
  for (int a = 0; a < dim; ++a) {
    if (periodic[static_cast<std::size_t>(a)]) continue;
    Vec3d n{}, q{};
    n[a] = 1;
    q[a] = 1.0;
    p.walls.push_back({q, n});
    n[a] = -1;
    q[a] = p.hi[static_cast<std::size_t>(a)] - 1.0;
    p.walls.push_back({q, n});
  }
  p.gravity = {c.coupling.gravity[0], c.coupling.gravity[1], c.coupling.gravity[2]};
  p.external_forcing = true;
  p.friction = true;  // rotation under hydrodynamic torque; friction coefficient as given (0: none)
  const Config dm = root.section("dem");
  p.material.stiffness = dm.positive("stiffness");
  p.material.restitution = dm.number_in("restitution", 0.9, 1e-6, 1.0, "restitution coefficient e in (0, 1]");
  p.material.wall_stiffness = dm.positive("wall_stiffness", p.material.stiffness);
  p.material.wall_restitution = dm.number_in("wall_restitution", p.material.restitution, 1e-6, 1.0, "e in (0, 1]");
  p.material.friction = dm.number_in("friction", 0.0, 0.0, 10.0);
  p.material.wall_friction = dm.number_in("wall_friction", p.material.friction, 0.0, 10.0);
  c.coupling.dem_substeps = static_cast<int>(dm.integer_in("substeps", 10, 1, 100000));
  p.dt = 1.0 / c.coupling.dem_substeps;
  p.skin = 0.1 * diam;
  dm.finish();
  c.coupling.psm.weight = imb::PsmWeight::NobleTorczynskiWall;  // the default with or without a psm section
  if (auto ps = root.optional_section("psm")) {
    read_psm(*ps, c.coupling.psm, c.coupling.slots, c.max_drag_error);
    ps->finish();
  }
  c.coupling.psm.map.max_radius = r;
  s.magic = resolve_magic(s.magic, diam);
  const Config t = root.section("time");
  c.steps = t.integer_in("steps", 0, std::numeric_limits<long>::max());
  t.finish();
  const Config o = root.section("output");
  c.outdir = o.text("directory");
  c.output_interval = o.integer_in("interval", 0, 0, std::numeric_limits<long>::max());
  c.series_interval = o.integer_in("series_interval", 100, 1, std::numeric_limits<long>::max());
  o.finish();
  root.accept("scene");
  root.finish();
  if (opt.steps) c.steps = *opt.steps;
  if (opt.output) c.outdir = *opt.output;
  if (c.particles.size() == 0) throw ConfigError("particles: no particles given");
  if (c.balance) {
    const double V = double(ext[0]) * ext[1] * ext[2];
    s.body_force = imb::balancing_body_force(c.particles, dim, c.coupling.gravity, 1.0, V, s.tau, c.coupling.psm.weight);
  }
  // Refuse up front what would blow up (Mach, cell Reynolds number, light
  // particles, DEM sub-steps, unbalanced weight), naming the key to change.
  cases::check_particles_scene(root, s, p, c.particles, c.coupling.gravity, c.balance, c.coupling.dem_substeps, c.steps, opt);
  imb::check_coupled_setup(s, p, c.particles, c.coupling);
  return c;
}

int run_particles_case(const Config& root, const RunOptions& opt) {
  ParticlesCase c = parse_particles(root, opt);
  if (c.setup.lattice == lbm::LatticeKind::D3Q19)
    report_expected_drag_error(drag_query(2 * c.particles.r[0], c.setup.tau, c.setup.collision, c.setup.magic,
                                          c.coupling.psm, c.setup.precision),
                               c.max_drag_error, opt);
  const Backend backend = resolve_backend(opt.backend);
  const std::size_t need = lbm::lbm_memory_estimate(c.setup);
  if (need > backend_free_bytes(backend))
    throw ResourceError("key 'domain.cells': the grid needs " + std::to_string(need >> 20) + " MiB but " +
                      std::to_string(backend_free_bytes(backend) >> 20) + " MiB are free");
  if (opt.validate_only) return 0;
  io::prepare_output_dir(c.outdir, opt.overwrite);
  auto fluid = lbm::make_lbm_solver(c.setup, backend);
  const auto& n = c.setup.domain.local;
  const auto N = static_cast<std::size_t>(n[0] * n[1] * n[2]);
  // Closed axes carry one layer of half-way bounce-back wall cells on each side
  // (the walls sit at 1 and cells + 1; parse_particles put the DEM walls there).
  std::vector<std::uint8_t> flags(N, 0);
  for (long z = 0; z < n[2]; ++z)
    for (long y = 0; y < n[1]; ++y)
      for (long x = 0; x < n[0]; ++x) {
        const long q[3] = {x, y, z};
        bool wall = false;
        for (int a = 0; a < 3; ++a)
          if (!c.setup.domain.periodic[static_cast<std::size_t>(a)] && (q[a] == 0 || q[a] == n[a] - 1)) wall = true;
        if (wall) flags[static_cast<std::size_t>(x + n[0] * (y + n[1] * z))] = 1;
      }
  fluid->initialize(flags, std::vector<double>(N, 1.0), std::vector<double>(3 * N, 0.0));
  dem::DemSystem dem(Exec(backend), c.dem, c.particles);
  std::unique_ptr<imb::FractionTable> table;  // outlives cs, which reads it every step
  if (c.coupling.psm.map.method == imb::FractionMethod::Table) {
    table = std::make_unique<imb::FractionTable>(imb::build_fraction_table(c.setup.lattice == lbm::LatticeKind::D2Q9 ? 2 : 3));
    c.coupling.psm.map.table = table.get();
  }
  imb::CoupledSolver cs(*fluid, dem, c.coupling);
  if (!opt.quiet)
    spdlog::info("scene particles: {} particles (d = {} cells, rho_s/rho_f = {}), grid {}x{}x{}, tau = {}, {} DEM "
                 "sub-steps, backend {}, weight balance {}, {} fractions, {} pipeline; output in {}",
                 dem.size(), 2 * c.particles.r[0], c.density_ratio, n[0], n[1], n[2], c.setup.tau,
                 c.coupling.dem_substeps, to_string(backend), c.balance ? "on" : "off",
                 imb::to_string(c.coupling.psm.map.method), imb::to_string(cs.coupling().pipeline()), c.outdir);
  io::ParticleWriter pw(c.outdir, "particles");
  io::GridWriter gw(c.outdir, "fields", c.setup.domain);
  io::TimeSeries series(c.outdir + "/series.csv",
                        {"step", "fluid_mass_rel_change", "fluid_momentum_x", "fluid_momentum_y", "fluid_momentum_z",
                         "max_mach", "particle_momentum_x", "particle_momentum_y", "particle_momentum_z",
                         "mean_vx", "mean_vy", "mean_vz", "x0", "y0", "z0", "vx0", "vy0", "vz0", "wx0", "wy0", "wz0",
                         "fx0", "fy0", "fz0", "tx0", "ty0", "tz0"});
  std::vector<double> rho, u;
  auto write_output = [&](long step) {
    const auto hf = cs.hydro_force_host();
    cases::write_particle_snapshot(pw, step, double(step), dem.download(), {{"hydrodynamic_force", 3, hf.data()}});
    fluid->macroscopic(rho, u);
    const auto eps = cs.solid_fraction_host();
    gw.write(step, double(step),
             {{"density", 1, rho.data(), "lattice"}, {"velocity", 3, u.data(), "lattice (cells per step)"},
              {"solid_fraction", 1, eps.data(), "1"}});
  };
  const auto d0 = fluid->diagnostics();
  auto series_row = [&](long step) {
    const auto d = fluid->diagnostics();
    const auto hp = dem.download();
    const auto hf = cs.hydro_force_host();
    const auto ht = cs.hydro_torque_host();
    double P[3] = {0, 0, 0}, V[3] = {0, 0, 0};
    Index i0 = 0;
    for (Index i = 0; i < hp.size(); ++i) {
      for (int k = 0; k < 3; ++k) {
        P[k] += (hp.mass[i] > 1e100 ? 0 : hp.mass[i]) * hp.v[i][k];
        V[k] += hp.v[i][k] / double(hp.size());
      }
      if (hp.id[i] == 0) i0 = i;
    }
    const double ma = d.max_speed * std::sqrt(3.0);
    series.append({double(step), (d.mass - d0.mass) / d0.mass, d.momentum[0], d.momentum[1], d.momentum[2], ma, P[0],
                   P[1], P[2], V[0], V[1], V[2], hp.x[i0][0], hp.x[i0][1], hp.x[i0][2], hp.v[i0][0], hp.v[i0][1],
                   hp.v[i0][2], hp.w[i0][0], hp.w[i0][1], hp.w[i0][2], hf[3 * i0], hf[3 * i0 + 1], hf[3 * i0 + 2],
                   ht[3 * i0], ht[3 * i0 + 1], ht[3 * i0 + 2]});
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
  if (c.output_interval > 0) write_output(0);
  series_row(0);
  Progress prog("particles", c.steps, 5.0, opt.quiet);
  using clk = std::chrono::steady_clock;
  const auto t0 = clk::now();
  long step = 0;
  // One coupled step per advance() call (the same steps as one longer call):
  // a stop signal (core/signals.hpp) ends the run after the step in progress.
  while (step < c.steps && !stop_requested()) {
    long next = std::min(c.steps, (step / c.series_interval + 1) * c.series_interval);
    if (c.output_interval > 0) next = std::min(next, (step / c.output_interval + 1) * c.output_interval);
    for (; step < next && !stop_requested(); ++step) cs.advance(1);
    if (step % c.series_interval == 0 || step == c.steps || stop_requested()) series_row(step);
    if (c.output_interval > 0 && step % c.output_interval == 0) write_output(step);
    if (prog.due()) {
      fluid->synchronize();
      prog.report(step, double(step), double(N) / 1e6, "MLUPS (coupled)");
    }
  }
  fluid->synchronize();
  cs.check_overflow();
  const double secs = std::chrono::duration<double>(clk::now() - t0).count();
  if (c.output_interval == 0 || step % c.output_interval != 0) write_output(step);
  const bool interrupted = step < c.steps;
  std::ostringstream js;
  js << "{\n  \"scene\": \"particles\",\n  \"particles\": " << dem.size() << ",\n  \"steps\": " << step
     << ",\n  \"steps_planned\": " << c.steps << ",\n  \"seconds\": " << secs << ",\n  \"coupled_mlups\": "
     << double(N) * step / std::max(secs, 1e-12) / 1e6 << ",\n  \"backend\": \"" << to_string(backend)
     << "\",\n  \"interrupted\": " << (interrupted ? "true" : "false") << "\n}\n";
  io::write_text_atomically(c.outdir + "/summary.json", js.str());
  if (interrupted) {
    spdlog::warn("stopped by {} at step {} of {}; output up to that step is in {}", stop_signal_name(), step, c.steps,
                 c.outdir);
    return kExitInterrupted;
  }
  if (!opt.quiet)
    spdlog::info("done: {} coupled steps in {:.1f} s ({:.1f} MLUPS coupled); results: {}/fields.xdmf, "
                 "{}/particles.xdmf (ParaView), {}/series.csv (lattice units)",
                 step, secs, double(N) * step / std::max(secs, 1e-12) / 1e6, c.outdir, c.outdir, c.outdir);
  return 0;
}

}  // namespace

std::vector<std::string> psm_scene_names() { return {"fixed_sphere", "particles"}; }

int run_psm_case(const Config& root, const RunOptions& opt) {
  const std::string scene = root.text("scene");
  return cases::with_user_keys(scene, [&] {
    return scene == "fixed_sphere" ? run_fixed_sphere_case(root, opt) : run_particles_case(root, opt);
  });
}

}  // namespace lbdem
