// Fluid-only scenes: channel (Poiseuille, or velocity inlet / pressure
// outlet), Taylor-Green vortex (2D and 3D), lid-driven cavity, periodic box.
// Parses and validates the whole case before touching the output folder.
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <optional>
#include <sstream>

#include "lbm/distributed_fluid.hpp"
#include "lbm/fluid_reader.hpp"
#include "cases/scenes.hpp"
#include "halo/simulation.hpp"
#include "core/output_section.hpp"
#include "core/run_length.hpp"
#include "core/json.hpp"
#include "lbm/checkpoint.hpp"
#include "scene_checks.hpp"
#include "core/buffer.hpp"
#include "core/output.hpp"
#include "core/progress.hpp"
#include "core/signals.hpp"
#include "core/units.hpp"
#include "halo/stop_poll.hpp"
#include "lbm/solver.hpp"
#include "lbm/storage_checks.hpp"
#include "lbm/tau.hpp"

namespace lbdem {

std::vector<std::string> lbm_scene_names() { return {"channel", "taylor_green", "lid_driven_cavity", "periodic_box"}; }

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Verification {
  std::string name;
  double value = 0;
  std::string note;
};

struct LbmCase {
  std::string scene;
  lbm::LbmSetup setup;
  Units units;
  long steps = 0;
  std::string outdir;
  long out_interval = 0;
  long diag_interval = 1000;
  double max_mach = 0.3;
  std::array<long, 3> fluid_cells{1, 1, 1};
  std::array<int, 3> pad{0, 0, 0};  // boundary layers added below each axis
  halo::ParallelOptions parallel;
  std::vector<std::uint8_t> flags;
  std::vector<double> rho, u;
  ckpt::Policy checkpoint;
  // Scene-specific reference, evaluated at the end (lattice units in/out).
  std::function<std::vector<Verification>(long step, const std::vector<double>& rho, const std::vector<double>& u)> verify;
};

std::size_t idx(const LbmCase& c, long x, long y, long z) {
  const auto& d = c.setup.domain.local;
  return static_cast<std::size_t>(x + d[0] * (y + d[1] * z));
}

// Relative L2 norm of (u - ref) over fluid cells, velocity components only.
double rel_l2(const LbmCase& c, const std::vector<double>& u, const std::function<std::array<double, 3>(long, long, long)>& ref) {
  const auto& d = c.setup.domain.local;
  double num = 0, den = 0;
  for (long z = 0; z < d[2]; ++z)
    for (long y = 0; y < d[1]; ++y)
      for (long x = 0; x < d[0]; ++x) {
        const auto i = idx(c, x, y, z);
        if (c.flags[i]) continue;
        const auto r = ref(x, y, z);
        for (int a = 0; a < 3; ++a) {
          const double e = u[3 * i + static_cast<std::size_t>(a)] - r[static_cast<std::size_t>(a)];
          num += e * e;
          den += r[static_cast<std::size_t>(a)] * r[static_cast<std::size_t>(a)];
        }
      }
  return den > 0 ? std::sqrt(num / den) : std::sqrt(num);
}

LbmCase parse(const Config& root, const RunOptions& opt) {
  LbmCase c;
  c.scene = root.text("scene");
  auto& s = c.setup;
  s.lattice = root.choice("lattice", {"D2Q9", "D3Q19"}) == "D2Q9" ? lbm::LatticeKind::D2Q9 : lbm::LatticeKind::D3Q19;
  const int D = s.lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  s.precision = lbm::precision_from_string(root.choice("precision", "fp64", {"fp32", "fp64", "fp16s", "fp16c"}));
  s.streaming = root.choice("streaming", "aa", {"aa", "two_lattice"}) == "aa" ? lbm::StreamKind::AA : lbm::StreamKind::TwoLattice;

  c.parallel = halo::parse_parallel(root);
  const lbm::SiFluid si = lbm::read_si_fluid(root, s);  // collision, fluid, domain, time
  const auto& cells = si.cells;
  const double dx = si.dx, nu_si = si.nu;
  for (int a = 0; a < D; ++a) c.fluid_cells[static_cast<std::size_t>(a)] = cells[static_cast<std::size_t>(a)];

  const OutputSettings out = read_output(root, kOutputInterval, "runs/" + c.scene, 1000000000000L);
  c.outdir = out.directory;
  c.out_interval = out.interval;
  const auto diag = root.optional_section("diagnostics");
  c.diag_interval = diag ? diag->integer_in("interval", 1000, 1, 1000000000L) : 1000;
  c.max_mach = diag ? diag->number_in("max_mach", 0.3, 1e-6, 0.5, "lattice Mach number above which the run stops; 0.3 is the usual limit") : 0.3;
  if (diag) diag->finish();

  // Scene geometry: which axes are closed by boundary layers.
  const Config sc = root.section(c.scene);
  std::array<bool, 3> closed{false, false, false};
  double u_ref = 0;
  std::array<double, 3> accel{0, 0, 0};
  std::array<double, 3> u0{0, 0, 0};
  double U = 0;
  std::string mode;
  if (c.scene == "channel") {
    mode = sc.choice("mode", "periodic", {"periodic", "inlet_outlet"});
    closed[1] = true;
    if (mode == "periodic") {
      accel[0] = sc.positive("body_acceleration");
      const double H = c.fluid_cells[1] * dx;
      u_ref = accel[0] * H * H / (8 * nu_si);
    } else {
      closed[0] = true;
      U = sc.positive("inlet_velocity");
      u_ref = 1.5 * U;
    }
  } else if (c.scene == "taylor_green") {
    U = sc.positive("velocity");
    u_ref = U;
    for (int a = 1; a < D; ++a)
      if (cells[static_cast<std::size_t>(a)] != cells[0])
        root.section("domain").fail("cells", "the Taylor-Green vortex needs equal cells on every axis");
  } else if (c.scene == "lid_driven_cavity") {
    U = sc.positive("lid_velocity");
    u_ref = U;
    for (int a = 0; a < D; ++a) closed[static_cast<std::size_t>(a)] = true;
  } else {  // periodic_box
    const auto a = sc.numbers("body_acceleration", {0, 0, 0}, 3, 3);
    const auto v = sc.numbers("initial_velocity", {0, 0, 0}, 3, 3);
    for (int k = 0; k < 3; ++k) {
      accel[static_cast<std::size_t>(k)] = a[static_cast<std::size_t>(k)];
      u0[static_cast<std::size_t>(k)] = v[static_cast<std::size_t>(k)];
    }
    if (D == 2 && (accel[2] != 0 || u0[2] != 0)) sc.fail("initial_velocity", "2D (D2Q9) cases have no z component: set it to 0");
    u_ref = std::sqrt(u0[0] * u0[0] + u0[1] * u0[1] + u0[2] * u0[2]);
    u_ref = sc.positive("reference_velocity", u_ref > 0 ? u_ref : 1e-3);
  }
  sc.finish();
  c.checkpoint = ckpt::read_policy(root);
  root.finish();

  cases::check_fluid_scene(root, c.scene, mode, cells, sc, dx, nu_si, u_ref, c.max_mach, si.tau, si.dt);
  c.units = lbm::si_fluid_units(root, si, u_ref, c.max_mach, s);
  long steps = lbm::si_fluid_steps(si, c.units);
  if (opt.steps) steps = *opt.steps;
  c.steps = steps;
  {
    // 16-bit storage: warn where its rounding is not good enough (lbm/storage_checks.hpp).
    // The flow's scale: the narrowest gap between walls, else the largest periodic length.
    double walled = 0, open = 0;
    for (int a = 0; a < D; ++a) {
      const auto k = static_cast<std::size_t>(a);
      const double n = static_cast<double>(c.fluid_cells[k]);
      if (closed[k]) walled = walled > 0 ? std::min(walled, n) : n;
      else open = std::max(open, n);
    }
    const double scale = walled > 0 ? walled : open;
    for (const auto& w : lbm::storage_warnings(s, c.units.to_lattice_velocity(u_ref), scale, static_cast<double>(c.steps)))
      spdlog::warn("{}: {}", root.source(), w);
  }
  if (opt.output) c.outdir = *opt.output;
  cases::check_fluid_plan(root, opt, si.length.end && !opt.steps ? *si.length.end / c.units.dt : double(c.steps), double(c.fluid_cells[0]) * double(c.fluid_cells[1]) * double(c.fluid_cells[2]));

  // Grid with boundary layers.
  for (int a = 0; a < 3; ++a) c.pad[static_cast<std::size_t>(a)] = closed[static_cast<std::size_t>(a)] ? 1 : 0;
  std::array<long, 3> n{};
  for (int a = 0; a < 3; ++a) n[static_cast<std::size_t>(a)] = c.fluid_cells[static_cast<std::size_t>(a)] + 2 * c.pad[static_cast<std::size_t>(a)];
  s.domain = Grid::whole(n, {!closed[0], !closed[1], !closed[2]});
  s.domain.spacing = c.units.dx;
  // The first fluid cell's lower corner is at 0: the boundary layer lies below it.
  for (int a = 0; a < 3; ++a) s.domain.origin[static_cast<std::size_t>(a)] = -c.pad[static_cast<std::size_t>(a)] * c.units.dx;
  for (int a = 0; a < 3; ++a) s.body_force[static_cast<std::size_t>(a)] = c.units.to_lattice_acceleration(accel[static_cast<std::size_t>(a)]);
  return c;
}

// Defined below: runs a parsed case.
int run_parsed(LbmCase& c, const RunOptions& opt);

}  // namespace

int run_lbm_case(const Config& root, const RunOptions& opt) {
  // Parse and validate everything first: bad input never touches output.
  LbmCase c = parse(root, opt);
  lbm::check_fluid_memory(c.setup, c.parallel, halo::Comm::world().size(), resolve_backend(opt.backend));
  auto& s = c.setup;
  const auto& n = s.domain.local;
  const auto N = static_cast<std::size_t>(n[0] * n[1] * n[2]);
  c.flags.assign(N, 0);
  c.rho.assign(N, 1.0);
  c.u.assign(3 * N, 0.0);
  auto add = [&](lbm::BoundaryKind k, std::array<double, 3> u, double rho) {
    auto& bt = s.boundaries;
    const int i = bt.count++;
    bt.kind[i] = k;
    for (int a = 0; a < 3; ++a) bt.u[i][a] = u[static_cast<std::size_t>(a)];
    bt.rho[i] = rho;
    return static_cast<std::uint8_t>(i + 1);
  };
  const Units& U = c.units;
  const Config sc = root.section(c.scene);
  const double nu = s.tau > 0 ? lbm::lattice_viscosity(s.tau) : 0;

  if (c.scene == "channel") {
    const std::uint8_t wall = add(lbm::BoundaryKind::Wall, {0, 0, 0}, 1);
    const bool io = c.pad[0] == 1;
    const double H = static_cast<double>(c.fluid_cells[1]);
    double u_in = 0;
    std::uint8_t in = 0, out = 0;
    if (io) {
      u_in = U.to_lattice_velocity(sc.number("inlet_velocity"));
      in = add(lbm::BoundaryKind::Velocity, {u_in, 0, 0}, 1.0);
      out = add(lbm::BoundaryKind::Pressure, {0, 0, 0}, 1.0);
    }
    for (long z = 0; z < n[2]; ++z)
      for (long y = 0; y < n[1]; ++y)
        for (long x = 0; x < n[0]; ++x) {
          auto& f = c.flags[idx(c, x, y, z)];
          if (y == 0 || y == n[1] - 1) f = wall;
          else if (io && x == 0) f = in;
          else if (io && x == n[0] - 1) f = out;
        }
    const double F = s.body_force[0];
    c.verify = [&c, F, H, nu, io, u_in](long, const std::vector<double>&, const std::vector<double>& u) {
      // Periodic: the Poiseuille parabola u = F y (H-y) / (2 nu). Inlet/outlet:
      // plug inflow develops into the parabola of mean u_in (same shape).
      const double scale = io ? 6.0 * u_in / (H * H) : F / (2 * nu);
      const long x0 = io ? c.setup.domain.local[0] - 2 : 0;  // compare at the outlet end when developing
      auto ref = [&](long x, long y, long) -> std::array<double, 3> {
        if (io && x != x0) return {NAN, 0, 0};
        const double yy = y - 0.5;
        return {scale * yy * (H - yy), 0, 0};
      };
      double num = 0, den = 0;
      const auto& d = c.setup.domain.local;
      for (long z = 0; z < d[2]; ++z)
        for (long y = 1; y < d[1] - 1; ++y)
          for (long x = io ? x0 : 0; x <= (io ? x0 : d[0] - 1); ++x) {
            const auto i = idx(c, x, y, z);
            const double r = ref(x, y, z)[0];
            num += (u[3 * i] - r) * (u[3 * i] - r);
            den += r * r;
          }
      return std::vector<Verification>{
          {"velocity_rel_l2_vs_parabola", std::sqrt(num / den),
           io ? "outlet profile vs fully developed parabola (needs a long enough channel)"
              : "Poiseuille profile vs analytic parabola (exact to round-off with TRT Lambda=3/16 at steady state)"}};
    };
  } else if (c.scene == "taylor_green") {
    const double U0 = U.to_lattice_velocity(sc.number("velocity"));
    const double L = static_cast<double>(c.fluid_cells[0]);
    const double k = 2 * kPi / L;
    const bool d3 = s.lattice == lbm::LatticeKind::D3Q19;
    for (long z = 0; z < n[2]; ++z)
      for (long y = 0; y < n[1]; ++y)
        for (long x = 0; x < n[0]; ++x) {
          const double X = k * (x + 0.5), Y = k * (y + 0.5), Z = k * (z + 0.5);
          const auto i = idx(c, x, y, z);
          if (!d3) {
            c.u[3 * i] = -U0 * std::cos(X) * std::sin(Y);
            c.u[3 * i + 1] = U0 * std::sin(X) * std::cos(Y);
            c.rho[i] = 1.0 + 3.0 * (-U0 * U0 / 4 * (std::cos(2 * X) + std::cos(2 * Y)));
          } else {
            c.u[3 * i] = U0 * std::sin(X) * std::cos(Y) * std::cos(Z);
            c.u[3 * i + 1] = -U0 * std::cos(X) * std::sin(Y) * std::cos(Z);
            c.rho[i] = 1.0 + 3.0 * (U0 * U0 / 16 * (std::cos(2 * X) + std::cos(2 * Y)) * (std::cos(2 * Z) + 2));
          }
        }
    c.verify = [&c, U0, k, nu, d3](long step, const std::vector<double>&, const std::vector<double>& u) {
      const double t = static_cast<double>(step);
      const double decay = std::exp(-(d3 ? 3.0 : 2.0) * nu * k * k * t);
      auto ref = [&](long x, long y, long z) -> std::array<double, 3> {
        const double X = k * (x + 0.5), Y = k * (y + 0.5), Z = k * (z + 0.5);
        if (!d3) return {-U0 * std::cos(X) * std::sin(Y) * decay, U0 * std::sin(X) * std::cos(Y) * decay, 0};
        return {U0 * std::sin(X) * std::cos(Y) * std::cos(Z) * decay, -U0 * std::cos(X) * std::sin(Y) * std::cos(Z) * decay, 0};
      };
      return std::vector<Verification>{{"velocity_rel_l2_vs_analytic", rel_l2(c, u, ref),
                                        d3 ? "3D: viscous decay exp(-3 nu k^2 t), exact only as Re -> 0"
                                           : "2D: exact Navier-Stokes solution"}};
    };
  } else if (c.scene == "lid_driven_cavity") {
    const double ulid = U.to_lattice_velocity(sc.number("lid_velocity"));
    const std::uint8_t wall = add(lbm::BoundaryKind::Wall, {0, 0, 0}, 1);
    const std::uint8_t lid = add(lbm::BoundaryKind::Velocity, {ulid, 0, 0}, 1.0);
    const bool d3 = s.lattice == lbm::LatticeKind::D3Q19;
    for (long z = 0; z < n[2]; ++z)
      for (long y = 0; y < n[1]; ++y)
        for (long x = 0; x < n[0]; ++x) {
          auto& f = c.flags[idx(c, x, y, z)];
          // The lid row spans the full width, corners included.
          if (y == n[1] - 1) f = lid;
          else if (x == 0 || x == n[0] - 1 || y == 0 || (d3 && (z == 0 || z == n[2] - 1))) f = wall;
        }
    c.verify = [ulid](long, const std::vector<double>&, const std::vector<double>&) {
      return std::vector<Verification>{{"lid_velocity_lattice", ulid, "no analytic reference; compare with Ghia et al. (1982) at Re = 100"}};
    };
  } else {  // periodic_box
    const auto v = sc.numbers("initial_velocity", {0, 0, 0}, 3, 3);
    for (std::size_t i = 0; i < N; ++i)
      for (int a = 0; a < 3; ++a) c.u[3 * i + static_cast<std::size_t>(a)] = U.to_lattice_velocity(v[static_cast<std::size_t>(a)]);
    c.verify = [&c](long step, const std::vector<double>&, const std::vector<double>& u) {
      // Uniform flow plus uniform force: every cell has u0 + F t / rho exactly.
      double worst = 0;
      for (std::size_t i = 0; i < c.flags.size(); ++i)
        for (int a = 0; a < 3; ++a) {
          const double expect = c.u[3 * i + static_cast<std::size_t>(a)] + c.setup.body_force[static_cast<std::size_t>(a)] * (static_cast<double>(step) + 0.5);
          worst = std::max(worst, std::abs(u[3 * i + static_cast<std::size_t>(a)] - expect));
        }
      return std::vector<Verification>{{"max_abs_velocity_error_lattice", worst, "uniform flow accelerated by the body force: u0 + F (t + 1/2)"}};
    };
  }
  return run_parsed(c, opt);
}

namespace {
int run_parsed(LbmCase& c, const RunOptions& opt) {
  auto& s = c.setup;
  const Backend backend = resolve_backend(opt.backend);
  if (opt.validate_only) return 0;
  const halo::Comm& comm = halo::Comm::world();
  const bool root = comm.root();
  // A restart checks its checkpoint against this case before any output is
  // touched (rank 0 reads it; a checkpoint of any rank count restarts here).
  ckpt::Run ck = halo::open_run(c.outdir, c.checkpoint, lbm::fluid_identity(c.scene, s), opt.restart, comm);
  if (root) ck.prepare_output(opt.overwrite);

  const Units& U = c.units;
  const auto& n = s.domain.local;
  const double fluid_cells = static_cast<double>(c.fluid_cells[0] * c.fluid_cells[1] * c.fluid_cells[2]);
  if (!opt.quiet) {
    spdlog::info("scene {}: {} {} {} {}, grid {}x{}x{} ({} fluid cells), backend {}", c.scene, to_string(s.lattice),
                 to_string(s.collision), to_string(s.precision), to_string(s.streaming), n[0], n[1], n[2],
                 static_cast<long>(fluid_cells), to_string(backend));
    spdlog::info("units: dx = {:.6g} m, dt = {:.6g} s, tau = {:.6g}, {} steps = {:.6g} s; output in {}", U.dx, U.dt,
                 U.tau, c.steps, c.steps * U.dt, c.outdir);
  }
  lbm::DistributedFluid fluid(s, backend, c.parallel, comm);
  auto* solver = &fluid;
  solver->initialize(c.flags, c.rho, c.u);
  if (!opt.quiet && comm.distributed()) spdlog::info("parallel: {} ({})", fluid.describe(), comm.describe());
  if (comm.distributed()) ck.set_layout(halo::rank_layout(comm.size(), fluid.decomposition().describe()));

  // Fields in pieces (core/piece_output.hpp): each rank writes its owned box
  // to its own file, slab by slab through the solver's output staging; rank 0
  // writes the index (a spatial collection of the pieces) and the series.
  std::optional<io::TimeSeries> series;
  lbm::LbmSolver& ls = fluid.local();
  io::PieceGridWriter writer(c.outdir, "fields", s.domain, fluid.piece_boxes(), comm.rank(), ls.setup().domain.owned());
  writer.set_float32(s.precision != lbm::Precision::FP64);
  if (root) {
    series.emplace(halo::open_series(ck, c.outdir + "/diagnostics.csv",
                                      {"step", "time_s", "mass_rel_change", "momentum_x", "momentum_y", "momentum_z",
                                       "max_speed_m_s", "max_mach"},
                                      c.diag_interval));
  }
  std::vector<double> rho, u;
  const std::vector<io::SlabField> field_list{{"density", 1, "kg/m^3"},
                                               {"velocity", 3, "m/s"},
                                               {"pressure", 1, "Pa (deviation from the reference)"},
                                               {"boundary", 1, "0 fluid, k boundary entry"}};
  auto write_fields = [&](long step) {
    if (root) writer.record(step);  // every piece named before any rank creates one
    if (comm.distributed()) comm.barrier();
    const Grid& piece = ls.setup().domain;
    const CellBox own = piece.owned();
    const GridView g = s.domain.view();  // the whole grid: the case's flags
    writer.write_piece(step, step * U.dt, field_list, ls.output_slab_cells(),
                       [&](const CellBox& b, const std::vector<double*>& out) {
                         ls.macroscopic_box(b, out[0], out[1]);
                         Index t = 0;
                         for (int z = b.lo[2]; z < b.lo[2] + b.ext[2]; ++z)
                           for (int y = b.lo[1]; y < b.lo[1] + b.ext[1]; ++y)
                             for (int x = b.lo[0]; x < b.lo[0] + b.ext[0]; ++x, ++t) {
                               const auto gi = g.index(static_cast<int>(x - own.lo[0] + piece.offset[0]),
                                                       static_cast<int>(y - own.lo[1] + piece.offset[1]),
                                                       static_cast<int>(z - own.lo[2] + piece.offset[2]));
                               const std::uint8_t f = c.flags[static_cast<std::size_t>(gi)];
                               out[2][t] = f ? 0.0 : U.to_si_pressure(out[0][t] - 1.0);
                               out[0][t] *= U.rho;
                               out[3][t] = f;
                             }
                         for (Index i = 0; i < 3 * t; ++i) out[1][i] = U.to_si_velocity(out[1][i]);
                       });
    if (comm.distributed()) comm.barrier();  // every piece on disk before the index names it
    if (root) writer.index(step, step * U.dt, field_list);
  };

  auto d0 = solver->diagnostics();
  long step0 = 0;
  if (ck.restarting()) {  // the state of the checkpoint's step; its series and fields are kept
    d0.mass = lbm::load_fluid(ck, comm, fluid.local(), s.domain, c.flags).at(0);
    step0 = ck.restart_step();
    if (root) writer.resume(step0);
  }
  // Fluid steps split into calls as the stop poll likes: shorter calls give
  // the same steps as one longer call.
  sim::Simulation loop(comm, c.scene, step0, c.steps, sim::Stepping{.wait = [&] { solver->synchronize(); }}, "lbm");
  // The rank of a cell the watchdog names (every rank stops at the same
  // step: the diagnostics are collective).
  auto on_rank = [&comm](int r) {
    return comm.distributed() && r >= 0 ? " on rank " + std::to_string(r) + " of " + std::to_string(comm.size())
                                        : std::string();
  };
  loop.add("diagnostics", sim::Trigger::steps_and_end(c.diag_interval), [&](const sim::Event& e) {
    const long step = e.step;
    const auto d = solver->diagnostics();
    const double vmax = U.to_si_velocity(d.max_speed);
    const double ma = d.max_speed * std::sqrt(3.0);
    if (root) series->append({static_cast<double>(step), step * U.dt, (d.mass - d0.mass) / d0.mass, d.momentum[0],
                   d.momentum[1], d.momentum[2], vmax, ma});
    if (!d.finite) {
      throw DivergenceError("diverged at step " + std::to_string(step) + " (t = " + std::to_string(step * U.dt) +
                            " s): non-finite density or velocity at cell (" +
                            std::to_string(d.nonfinite_cell[0]) + ", " + std::to_string(d.nonfinite_cell[1]) + ", " +
                            std::to_string(d.nonfinite_cell[2]) + ")" + on_rank(fluid.nonfinite_rank()) +
                            ". Output up to the last good step is kept in " +
                            c.outdir + ". Lower the Mach number (smaller tau/dt), raise tau, or use collision.model: trt");
    }
    if (ma > c.max_mach) {
      throw DivergenceError("stopped at step " + std::to_string(step) + ": lattice Mach number " + std::to_string(ma) +
                            " (|u| = " + std::to_string(vmax) + " m/s) at cell (" + std::to_string(d.max_speed_cell[0]) +
                            ", " + std::to_string(d.max_speed_cell[1]) + ", " + std::to_string(d.max_speed_cell[2]) +
                            ")" + on_rank(fluid.max_speed_rank()) + " exceeds diagnostics.max_mach = " + std::to_string(c.max_mach) +
                            ". Output up to the last good step is kept in " + c.outdir +
                            ". Any one of: lower the driving (the scene's velocity or body_acceleration); a "
                            "smaller time step (collision.tau or time.dt); a finer grid (domain.spacing, with "
                            "more domain.cells)");
    }
  }, true);
  // Fields every output.interval steps (and at step 0), and the final state
  // always (also when a stop signal ended the loop early).
  loop.add("output", sim::Trigger{.every_steps = c.out_interval, .at_start = c.out_interval > 0, .at_end = true},
           [&](const sim::Event& e) { write_fields(e.step); }, true);
  loop.add("checkpoint", sim::checkpoint_trigger(c.checkpoint), [&](const sim::Event& e) {
    lbm::save_fluid(ck, comm, e.step, e.step * U.dt, fluid.local(), {d0.mass});
  });
  loop.progress([&](long st) { return st * U.dt; }, fluid_cells / 1e6, "MLUPS", opt.quiet);
  loop.run([&](long n) { solver->step(n); });
  const long step = loop.step();
  solver->macroscopic(rho, u);  // lattice units again for the verification
  const auto checks = c.verify && root ? c.verify(step, rho, u) : std::vector<Verification>{};
  const std::size_t memory = solver->memory_bytes();

  const double lbm_s = loop.phase("lbm");
  const double mlups = lbm_s > 0 ? fluid_cells * static_cast<double>(step - step0) / lbm_s / 1e6 : 0;
  json::Value& js = loop.summary();
  js.set("lattice", to_string(s.lattice))
      .set("collision", to_string(s.collision))
      .set("precision", to_string(s.precision))
      .set("streaming", to_string(s.streaming))
      .set("backend", to_string(backend))
      .set("dx_m", U.dx)
      .set("dt_s", U.dt)
      .set("tau", U.tau)
      .set("decomposition", fluid.decomposition().describe())
      .set("mlups", mlups)
      .set("memory_bytes", memory);
  json::Value& ver = js["verification"] = json::Value::object();
  for (auto& v : checks) ver.set(v.name, v.value);
  if (loop.conclude(c.outdir, step * U.dt) != 0) return kExitInterrupted;
  if (!opt.quiet) {
    spdlog::info("done: {} steps in {} ({:.1f} MLUPS), memory {:.1f} MiB", step, format_duration(loop.elapsed()), mlups,
                 memory / 1048576.0);
    const PhaseTimer& phases = loop.phases();
    for (auto& [k, v] : phases.phases())
      spdlog::info("  phase {:<12} {:8.3f} s ({:.1f}%)", k, v, 100.0 * v / std::max(1e-12, phases.total()));
    for (auto& v : checks) spdlog::info("  check {} = {:.6e}  ({})", v.name, v.value, v.note);
    spdlog::info("results: {}/fields.xdmf (open in ParaView), {}/diagnostics.csv, {}/summary.json", c.outdir, c.outdir, c.outdir);
  }
  return 0;
}

}  // namespace
}  // namespace lbdem
