// Unresolved CFD-DEM scene driver: `scene: fluidized_bed` (cases/fluidized_bed_*.yaml).
//
// Physical units throughout. The gas (cfd::GasSolver: volume-averaged
// equations, Anderson-Jackson set I, on a coarse MAC grid of cubic cells that
// fill the box `domain`) and the particles (dem::DemSystem with friction,
// rotation and walls on every closed face of the box) advance through the
// shared coupled step (dem::CoupledLoop with cfd::GasDemCoupling): one gas step,
// then `dem.substeps` DEM steps with the fluid force held.
//
// Keys (every one read through Config: range-checked, unknown keys refused):
//   domain      lo, hi [m]
//   gas         density [kg/m^3], viscosity [Pa s], cell_size [m], dt [s], drag (gidaspow, wen_yu,
//               di_felice, beetstra, tenneti), void_fraction (centroid, linear, quadratic),
//               min_gas_fraction, initial_velocity [m/s], boundaries.{x,y,z}_{lo,hi} (type: periodic,
//               no_slip, free_slip, inlet (velocity, patch {lo, hi, velocity}), outlet (pressure)),
//               pressure_solver {type (cg: Jacobi-preconditioned CG, the default; multigrid: CG
//               preconditioned by a multigrid V-cycle), tolerance, max_iterations, poll_every,
//               graphs (multigrid on the GPU: the iterations between polls as one CUDA graph)},
//               force_coupling (sequential: the default; lagged: the DEM sub-steps of gas step n take the
//               forces of gas step n-1, and the gas step runs beside them: cfd/lagged_coupling.hpp)
//   physics     gravity [m/s^2]
//   particles   init: list | lattice | random (region_lo, region_hi, solid_fraction or count) | csv | hdf5
//   material    stiffness [N/m], restitution, friction, wall_*, tangential_*
//   dem         substeps, dt [s] (rounded down to divide gas.dt), or steps_per_collision (default 50);
//               skin [m], force_path, force_lanes (threads per particle of the GPU's contact-force kernel:
//               1, 2, 4, 8, 16; default 1)
//   time        end [s] or steps (gas steps)
//   output      directory, interval (gas steps between field and particle snapshots; 0: first and last),
//               series_interval, track (particle ids)
//   statistics  start [s], interval (gas steps), blocks (default 5), profiles [{quantity:
//               void_fraction | particle_velocity_z, height [m]}]: time averages along x at a
//               height; the window from start to the case's end (time, not --steps) is
//               cut into `blocks` equal spans whose means give each average's standard
//               error (batch means; profiles_blocks.csv)
//   diagnostics check_interval (gas steps), max_courant
//   checkpoint  interval (gas steps), minutes, on_signal (core/checkpoint.hpp)
//
// The time series (series.csv) holds the bed's pressure drop (gas pressure at
// the inlet face, extrapolated from the two lowest cell layers, less that of
// the top layer and less the gas's own hydrostatic head), its ratio to the
// buoyant weight of the particles per unit cross-section, the bed height
// (twice the mean height of the particle centres above the floor: the height
// of a uniform bed with those centres), the particles' mean vertical velocity
// and the gas mass balance (inflow, outflow, storage, relative imbalance).
// z is taken as the vertical axis for these (gravity along -z).
//
// Watchdog: every diagnostics.check_interval gas steps the largest Courant
// number over the whole field and non-finite values of velocity, pressure and
// gas fraction (device reductions, a few scalars to the host) stop the run
// with a diagnosis naming the keys to change.
//
// Checkpoint and restart (core/checkpoint.hpp; `lbdem run CASE --restart
// RUN_DIR`): sections "run" (the statistics accumulators: sums of the
// pressure drop, its ratio and the bed height, the sample count, the largest
// Courant number and mass imbalance seen, each profile's per-cell sums and
// counts), "gas" (cfd::GasSolver::save_state) and "dem"
// (dem::DemSystem::save_state). The step count sets the time; the series
// keeps its rows up to the checkpoint. A chained run ends bit for bit where
// a straight run ends. A stop signal is polled after every gas step (a few
// ms), so the scene stops and writes its checkpoint at once.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <sstream>

#include "dem/particle_output.hpp"
#include "cases/scenes.hpp"
#include "halo/simulation.hpp"
#include "core/output_section.hpp"
#include "core/run_length.hpp"
#include "core/json.hpp"
#include "cfd/coupling.hpp"
#include "cfd/gas_monitor.hpp"
#include "cfd/lagged_coupling.hpp"
#include "core/error.hpp"
#include "core/output.hpp"
#include "core/progress.hpp"
#include "core/signals.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"
#include "halo/comm.hpp"
#include "cfd/checkpoint.hpp"
#include "cfd/gas_reader.hpp"
#include "dem/particle_reader.hpp"
#include "scene_checks.hpp"

namespace lbdem {

namespace {

using cfd::FaceKind;

constexpr double kPi = 3.14159265358979323846;

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.6g", v + 0.0);
  return b;
}
Vec3d vec3(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

enum class ProfileQuantity { VoidFraction, ParticleVelocityZ };
struct Profile {
  ProfileQuantity quantity = ProfileQuantity::VoidFraction;
  double height = 0;
  std::vector<double> sum, count;    // per x cell
  std::vector<double> bsum, bcount;  // per block and x cell (block-major): the batch means
};

struct CfdCase {
  cfd::GasGridView grid;
  cfd::GasParams gas;
  Vec3d initial_velocity{};
  bool lagged_forces = false;
  dem::DemParams dem;
  dem::HostParticles particles;
  int substeps = 1;
  long steps = 0;
  long case_steps = 0;  // the case file's own length (time.end or time.steps), whatever --steps says
  std::string outdir;
  long output_interval = 0, series_interval = 100;
  std::vector<std::int64_t> track;
  double stats_start = 0;
  long stats_interval = 0;  // 0: no statistics
  int stats_blocks = 5;
  std::vector<Profile> profiles;
  long check_interval = 100;
  double max_courant = 0.5;
  ckpt::Policy checkpoint;
};

void read_gas(const Config& root, const RunOptions& opt, CfdCase& c, const std::array<double, 3>& lo,
              const std::array<double, 3>& hi) {
  cfd::GasSection g;
  cfd::read_gas(root.section("gas"), lo, hi, cases::planned_backend(opt), g);
  c.grid = g.grid;
  c.gas = g.gas;
  c.initial_velocity = g.initial_velocity;
  c.lagged_forces = g.lagged_forces;
}

CfdCase read_case(const Config& root, const RunOptions& opt) {
  CfdCase c;
  std::array<double, 3> lo{}, hi{};
  {
    const Config d = root.section("domain");
    const auto l = d.numbers("lo", 3, 3), u = d.numbers("hi", 3, 3);
    for (std::size_t k = 0; k < 3; ++k) {
      lo[k] = l[k];
      hi[k] = u[k];
      if (!(hi[k] > lo[k]) || !std::isfinite(hi[k] - lo[k])) d.fail("hi", "each component must exceed domain.lo");
    }
    d.finish();
  }
  read_gas(root, opt, c, lo, hi);
  dem::DemParams& p = c.dem;
  p.lo = lo;
  p.hi = hi;
  for (int a = 0; a < 3; ++a) {
    p.periodic[static_cast<std::size_t>(a)] = c.grid.periodic[a];
    if (c.grid.periodic[a]) continue;
    // Particles bounce off every closed face of the gas box (walls, the
    // distributor, the outlet screen).
    Vec3d n{0, 0, 0};
    n[a] = 1;
    p.walls.push_back(dem::Wall{vec3({lo[0], lo[1], lo[2]}), n});
    n[a] = -1;
    p.walls.push_back(dem::Wall{vec3({hi[0], hi[1], hi[2]}), n});
  }
  {
    const Config ph = root.section("physics");
    p.gravity = vec3(ph.numbers("gravity", {0, 0, -9.80665}, 3, 3));
    for (int a = 0; a < 3; ++a)
      if (!(std::fabs(p.gravity[a]) < 1e4)) ph.fail("gravity", "each component must be finite, |g| < 1e4 m/s^2");
    c.gas.gravity = p.gravity;
    ph.finish();
  }
  dem::read_material(root.section("material"), p, dem::FrictionFrom::Values);
  p.external_forcing = true;
  c.particles = dem::read_particles(root.section("particles"), p,
                                    {.density = std::nullopt, .validate_only = opt.validate_only});
  double rmin = 1e300, rmax = 0;
  for (double r : c.particles.r) {
    rmin = std::min(rmin, r);
    rmax = std::max(rmax, r);
  }
  if (2 * rmax > c.grid.h)
    throw ConfigError(root.where("gas") + ": key 'gas.cell_size' = " + num(c.grid.h) +
                      " m is smaller than the largest particle diameter " + num(2 * rmax) +
                      " m (particles.radius): the unresolved mode needs cells of 1-5 particle diameters");
  c.substeps = cfd::read_bed_dem(root, c.gas.dt, rmin, c.particles, p);
  {
    const Config t = root.section("time");
    const RunLength len = read_run_length(t, 0, std::numeric_limits<long>::max());
    double planned = 0;
    std::string key = "time.steps";
    if (len.end) {
      planned = std::ceil(*len.end / c.gas.dt - 1e-9);
      key = t.full_key(len.end_key) + " = " + num(*len.end) + " s with gas.dt = " + num(c.gas.dt) + " s";
    } else {
      planned = static_cast<double>(*len.steps);
    }
    t.finish();
    c.case_steps = static_cast<long>(planned);
    if (opt.steps) {
      planned = static_cast<double>(*opt.steps);
      key = "--steps";
    }
    const double np = static_cast<double>(c.particles.size());
    check_plan(root, opt.force, planned, static_cast<double>(c.grid.cells()), np * c.substeps,
                      key + " (x dem.substeps DEM steps)");
    c.steps = static_cast<long>(planned);
  }
  {
    OutputSettings o = read_output(root, kOutputInterval | kOutputSeries | kOutputTrack);
    c.outdir = o.directory;
    c.output_interval = o.interval;
    c.series_interval = o.series_interval;
    c.track = std::move(o.track);
  }
  if (const auto st = root.optional_section("statistics")) {
    c.stats_start = st->number_in("start", 0.0, 0.0, 1e9, "simulated time [s] from which averages are taken");
    c.stats_interval = st->integer_in("interval", 10, 1, std::numeric_limits<long>::max());
    c.stats_blocks = static_cast<int>(st->integer_in("blocks", 5, 2, 1000));
    if (st->has("profiles")) {
      for (const Config& pc : st->sequence("profiles")) {
        Profile pr;
        pr.quantity = pc.choice("quantity", {"void_fraction", "particle_velocity_z"}) == "void_fraction"
                          ? ProfileQuantity::VoidFraction
                          : ProfileQuantity::ParticleVelocityZ;
        pr.height = pc.number_in("height", lo[2], hi[2], "a height inside the box (domain.lo, domain.hi) [m]");
        pr.sum.assign(static_cast<std::size_t>(c.grid.n[0]), 0.0);
        pr.count.assign(static_cast<std::size_t>(c.grid.n[0]), 0.0);
        pr.bsum.assign(static_cast<std::size_t>(c.grid.n[0]) * static_cast<std::size_t>(c.stats_blocks), 0.0);
        pr.bcount.assign(pr.bsum.size(), 0.0);
        c.profiles.push_back(pr);
        pc.finish();
      }
    }
    st->finish();
  }
  if (const auto dg = root.optional_section("diagnostics")) {
    c.check_interval = dg->integer_in("check_interval", 100, 1, std::numeric_limits<long>::max());
    c.max_courant = dg->number_in("max_courant", 0.5, 1e-3, 1.0,
                                  "largest |u| gas.dt / gas.cell_size anywhere (upwind convection is monotone up to 1/2)");
    dg->finish();
  }
  c.checkpoint = ckpt::read_policy(root);
  root.accept("scene");
  root.finish();
  if (opt.output) c.outdir = *opt.output;
  for (std::int64_t id : c.track)
    if (std::find(c.particles.id.begin(), c.particles.id.end(), id) == c.particles.id.end())
      throw ConfigError(root.source() + ": output.track: particle id " + std::to_string(id) + " does not exist (ids 0.." +
                        std::to_string(c.particles.size() - 1) + ")");
  // The particles against the box, its closed faces and each other; memory.
  const dem::ParticleBox box = dem::particle_box(p, 3, "domain.lo, domain.hi", "gas.boundaries (closed faces)");
  dem::check_particles_in_box(root, c.particles, box);
  dem::check_particle_overlaps(root, c.particles, box);
  const double n = static_cast<double>(c.particles.size());
  check_memory(root, cases::planned_backend(opt), n * dem::kDemDeviceBytesPerParticle,
                      n * dem::kDemHostBytesPerParticle, "particles", num(n) + " particles", "use fewer particles");
  return c;
}

// Whole-bed measures for the series and the statistics.
struct BedState {
  double dp = 0, ratio = 0, height = 0, mean_vz = 0, mean_speed = 0, max_speed = 0;
};

}  // namespace

std::vector<std::string> cfd_scene_names() { return {"fluidized_bed"}; }

int run_cfd_case(const Config& root, const RunOptions& opt) {
  const halo::Comm& comm = halo::Comm::world();
  if (comm.distributed())
    throw ConfigError(root.source() + ": scene 'fluidized_bed' runs on one rank (started here on " +
                      std::to_string(comm.size()) + " ranks): run it without mpirun");
  CfdCase c = read_case(root, opt);
  if (opt.validate_only) return 0;
  const Backend backend = resolve_backend(opt.backend);
  // A restart checks its checkpoint against this case before any output is touched.
  const cfd::GasGridView& g0 = c.grid;
  ckpt::Run ck = halo::open_run(
      c.outdir, c.checkpoint,
      ckpt::Identity{}
          .add("scene", "fluidized_bed")
          .add("particles", std::to_string(c.particles.size()))
          .add("gas_grid", std::to_string(g0.n[0]) + "x" + std::to_string(g0.n[1]) + "x" + std::to_string(g0.n[2]))
          .add("gas_cell_size", num(g0.h))
          .add("gas_dt", num(c.gas.dt))
          .add("dem_substeps", std::to_string(c.substeps))
          .add("friction", c.dem.friction ? "on" : "off")
          .add("force_path", dem::to_string(c.dem.path)),
      opt.restart, comm);
  halo::prepare_output_on_writer(ck, true, comm, opt.overwrite, c.outdir);
  Exec ex(backend);
  // The gas's and the DEM's small kernels launched overlapped (core/exec.hpp;
  // the same results bit for bit); LBDEM_OVERLAP_LAUNCHES=0 launches them one
  // after the other.
  const char* overlap = std::getenv("LBDEM_OVERLAP_LAUNCHES");
  ex.set_overlap_launches(!(overlap && std::strcmp(overlap, "0") == 0));
  dem::DemSystem dem(ex, c.dem, c.particles);
  // Lagged forces: the gas on a second queue beside the DEM's (one queue on the host).
  // LBDEM_LAGGED_ONE_QUEUE=1 keeps the gas on the DEM's queue (the same
  // lagged arithmetic, nothing at the same time: for comparison).
  const Lanes lanes;
  const char* one_queue = std::getenv("LBDEM_LAGGED_ONE_QUEUE");
  const bool second_queue = c.lagged_forces && !(one_queue && std::strcmp(one_queue, "1") == 0);
  cfd::GasSolver gas(second_queue ? lanes.edge(ex) : ex, c.grid, c.gas);
  gas.set_velocity(c.initial_velocity);
  cfd::GasDemCoupling coupling(gas);
  dem::CoupledLoop loop(dem, coupling, c.substeps);
  std::optional<cfd::LaggedCoupling> lagged;
  if (c.lagged_forces) {
    std::int64_t id_limit = 0;
    for (std::int64_t id : c.particles.id) id_limit = std::max(id_limit, id + 1);
    lagged.emplace(ex, lanes, dem, gas, c.substeps, id_limit);
    lanes.fork(ex);  // the gas's first look at the particles waits for their upload
  }
  gas.initialise(dem.view());
  if (c.lagged_forces) lanes.join(ex);
  cfd::GasMonitor monitor(ex);
  const cfd::GasGridView& g = c.grid;
  const double h = g.h;
  const Index np = dem.size();
  const bool quiet = opt.quiet;

  // Buoyant weight per unit cross-section: the pressure drop that carries a
  // fluidized bed (set I: the gas pressure gradient acts on gas and solid).
  const double gmag = std::fabs(c.gas.gravity[2]);
  const double area = (g.n[0] * h) * (g.n[1] * h);
  double weight = 0;
  for (std::size_t i = 0; i < c.particles.x.size(); ++i) {
    const double vp = 4.0 / 3.0 * kPi * c.particles.r[i] * c.particles.r[i] * c.particles.r[i];
    weight += (c.particles.mass[i] - c.gas.rho * vp) * gmag;
  }
  const double weight_per_area = weight / area;
  const double floor_z = g.origin[2];
  const double top_z = g.origin[2] + g.n[2] * h;

  if (!quiet)
    spdlog::info("scene fluidized_bed: {} particles, {} x {} x {} gas cells of {:.4g} m, backend {}, drag {}, void "
                 "fraction {}, pressure solver {}, gas dt {:.4g} s with {} DEM sub-steps ({:.4g} s, "
                 "{} forces), {} steps = {:.6g} s; output in {}",
                 np, g.n[0], g.n[1], g.n[2], h, to_string(backend), cfd::to_string(c.gas.drag),
                 cfd::to_string(c.gas.deposition), cfd::to_string(c.gas.pressure_solver), c.gas.dt, c.substeps, c.dem.dt,
                 c.lagged_forces ? "lagged" : "sequential", c.steps, c.steps * c.gas.dt, c.outdir);

  io::GridWriter gas_writer(c.outdir, "gas", {g.n[0], g.n[1], g.n[2]}, {g.origin[0], g.origin[1], g.origin[2]},
                            {h, h, h});
  io::ParticleWriter particle_writer(c.outdir, "particles");
  std::vector<std::string> cols{"step",        "time",         "pressure_drop", "pressure_drop_over_weight",
                                "bed_height",  "mean_vz",      "mean_speed",    "max_speed",
                                "gas_inflow",  "gas_outflow",  "gas_storage",   "mass_imbalance",
                                "max_courant", "cg_iterations"};
  for (std::int64_t id : c.track)
    for (const char* q : {"x", "y", "z", "vx", "vy", "vz"}) cols.push_back(std::string(q) + "_" + std::to_string(id));
  io::TimeSeries series = halo::open_series(ck, c.outdir + "/series.csv", cols, c.series_interval);

  double t = 0;
  auto measure_bed = [&](const dem::HostParticles& hp, const cfd::GasMeasures& m, double p_second) {
    BedState b;
    // Pressure at the inlet face from the two lowest layers (linear), less
    // the top layer's and the gas's own head between them.
    const double p_face = 1.5 * m.p_bottom - 0.5 * p_second;
    b.dp = p_face - m.p_top - c.gas.rho * gmag * (top_z - floor_z - 0.5 * h);
    b.ratio = b.dp / weight_per_area;
    double zs = 0, vz = 0, sp = 0;
    for (Index i = 0; i < hp.size(); ++i) {
      zs += hp.x[static_cast<std::size_t>(i)].z - floor_z;
      vz += hp.v[static_cast<std::size_t>(i)].z;
      const double s = norm(hp.v[static_cast<std::size_t>(i)]);
      sp += s;
      b.max_speed = std::max(b.max_speed, s);
    }
    const double n = static_cast<double>(std::max<Index>(hp.size(), 1));
    b.height = 2 * zs / n;
    b.mean_vz = vz / n;
    b.mean_speed = sp / n;
    return b;
  };
  // Mean pressure of the second cell layer (for the extrapolation to the inlet face).
  std::vector<double> pres_host, eps_host, uc_host[3];
  auto second_layer = [&]() {
    const Index layer = static_cast<Index>(g.n[0]) * g.n[1];
    if (g.n[2] < 2) return 0.0;
    std::vector<double> row(static_cast<std::size_t>(layer));
    gas.pressure().copy_to_host(row.data(), layer, layer);
    double s = 0;
    for (double v : row) s += v;
    return s / static_cast<double>(layer);
  };
  // Largest Courant number and mass imbalance seen: at the regular series and
  // check steps (what a checkpoint carries, the same in a chained run as in a
  // straight one), and at a run's last step off those grids (a stop).
  double max_courant_seen = 0, max_imbalance = 0, last_courant = 0, last_imbalance = 0;
  auto regular = [&](long s, long interval) { return s % interval == 0; };
  auto series_row = [&](long step) {
    ex.synchronize();
    const cfd::GasMeasures m = monitor.measure(gas);
    const double p2 = g.n[2] >= 2 ? second_layer() : m.p_bottom;
    const dem::HostParticles hp = dem.gather();
    const BedState b = measure_bed(hp, m, p2);
    const double imb = (m.inflow - m.outflow - m.storage) / std::max({m.inflow, m.outflow, 1e-300});
    if (regular(step, c.series_interval)) {
      max_courant_seen = std::max(max_courant_seen, m.max_courant);
      if (step > 0) max_imbalance = std::max(max_imbalance, std::fabs(imb));
    } else {
      last_courant = std::max(last_courant, m.max_courant);
      last_imbalance = std::max(last_imbalance, std::fabs(imb));
    }
    std::vector<double> row{static_cast<double>(step), t, b.dp, b.ratio, b.height, b.mean_vz, b.mean_speed,
                            b.max_speed, c.gas.rho * m.inflow, c.gas.rho * m.outflow, c.gas.rho * m.storage, imb,
                            m.max_courant, static_cast<double>(gas.last_solve().iterations)};
    for (std::int64_t id : c.track) {
      const auto i = static_cast<std::size_t>(id);  // gather(): ascending global id
      for (int k = 0; k < 3; ++k) row.push_back(hp.x[i][k]);
      for (int k = 0; k < 3; ++k) row.push_back(hp.v[i][k]);
    }
    series.append(row);
    return std::make_pair(b, m);
  };
  auto write_fields = [&](long step) {
    ex.synchronize();
    eps_host = gas.gas_fraction().to_vector();
    pres_host = gas.pressure().to_vector();
    std::vector<double> vel(3 * eps_host.size());
    for (int a = 0; a < 3; ++a) {
      uc_host[a] = gas.cell_velocity(a).to_vector();
      for (std::size_t i = 0; i < eps_host.size(); ++i) vel[3 * i + static_cast<std::size_t>(a)] = uc_host[a][i];
    }
    gas_writer.write(step, t, {{"gas_fraction", 1, eps_host.data(), ""},
                               {"pressure", 1, pres_host.data(), "Pa"},
                               {"velocity", 3, vel.data(), "m/s"}});
    const dem::HostParticles hp = dem.gather();
    dem::write_particle_snapshot(particle_writer, step, t, hp);
  };
  // The statistics window [statistics.start, the case file's end] is cut into
  // statistics.blocks equal spans (the case's end, not --steps: a chain of
  // shorter runs and a straight run put each sample in the same block);
  // block_at(b, i): where block b's sums of x cell i are.
  const double stats_window = c.case_steps * c.gas.dt - c.stats_start;
  auto block_at = [&](int b, int i) {
    return static_cast<std::size_t>(b) * static_cast<std::size_t>(g.n[0]) + static_cast<std::size_t>(i);
  };
  // The standard error of a profile's time average at x cell i from its
  // batch means (the blocks that hold samples there; nan below two):
  // sqrt(var(block means) / blocks). Blocks much longer than the bed's
  // correlation time (bubbles: well under a second) make them independent.
  auto batch_error = [&](const Profile& pr, int i) -> std::string {
    double m = 0, m2 = 0;
    int k = 0;
    for (int b = 0; b < c.stats_blocks; ++b) {
      const std::size_t at = block_at(b, i);
      if (pr.bcount[at] <= 0) continue;
      const double x = pr.bsum[at] / pr.bcount[at];
      ++k;
      const double d = x - m;  // Welford
      m += d / k;
      m2 += d * (x - m);
    }
    return k >= 2 ? num(std::sqrt(m2 / (k - 1) / k)) : std::string("nan");
  };
  // Time averages: the bed's pressure drop and height, and the profiles.
  double avg_dp = 0, avg_ratio = 0, avg_height = 0;
  long samples = 0;
  auto sample = [&]() {
    ex.synchronize();
    const cfd::GasMeasures m = monitor.measure(gas);
    const dem::HostParticles hp = dem.download();
    const BedState b = measure_bed(hp, m, g.n[2] >= 2 ? second_layer() : m.p_bottom);
    avg_dp += b.dp;
    avg_ratio += b.ratio;
    avg_height += b.height;
    ++samples;
    if (c.profiles.empty()) return;
    const int nb = c.stats_blocks;
    const int blk =
        stats_window > 0 ? std::clamp(static_cast<int>(std::floor((t - c.stats_start) / stats_window * nb)), 0, nb - 1) : 0;
    const std::size_t boff = block_at(blk, 0);
    eps_host = gas.gas_fraction().to_vector();
    for (Profile& pr : c.profiles) {
      if (pr.quantity == ProfileQuantity::VoidFraction) {
        // Linear in z between the two cell layers around the height, mean over y.
        const double zc = (pr.height - floor_z) / h - 0.5;
        const int k0 = std::clamp(static_cast<int>(std::floor(zc)), 0, std::max(g.n[2] - 2, 0));
        const int k1 = std::min(k0 + 1, g.n[2] - 1);
        const double w1 = std::clamp(zc - k0, 0.0, 1.0);
        for (int i = 0; i < g.n[0]; ++i) {
          double s = 0;
          for (int j = 0; j < g.n[1]; ++j)
            s += (1 - w1) * eps_host[static_cast<std::size_t>(g.index(i, j, k0))] +
                 w1 * eps_host[static_cast<std::size_t>(g.index(i, j, k1))];
          pr.sum[static_cast<std::size_t>(i)] += s / g.n[1];
          pr.count[static_cast<std::size_t>(i)] += 1;
          pr.bsum[boff + static_cast<std::size_t>(i)] += s / g.n[1];
          pr.bcount[boff + static_cast<std::size_t>(i)] += 1;
        }
      } else {
        // Particles whose centre lies within half a cell of the height, by x cell.
        for (Index q = 0; q < hp.size(); ++q) {
          const Vec3d& x = hp.x[static_cast<std::size_t>(q)];
          if (std::fabs(x.z - pr.height) > 0.5 * h) continue;
          const int i = std::clamp(static_cast<int>(std::floor((x.x - g.origin[0]) / h)), 0, g.n[0] - 1);
          pr.sum[static_cast<std::size_t>(i)] += hp.v[static_cast<std::size_t>(q)].z;
          pr.count[static_cast<std::size_t>(i)] += 1;
          pr.bsum[boff + static_cast<std::size_t>(i)] += hp.v[static_cast<std::size_t>(q)].z;
          pr.bcount[boff + static_cast<std::size_t>(i)] += 1;
        }
      }
    }
  };
  auto watchdog = [&](long step) {
    ex.synchronize();
    const cfd::GasMeasures m = monitor.measure(gas);
    const std::string at = " at gas step " + std::to_string(step) + " (t = " + num(t) + " s)";
    if (m.nonfinite > 0)
      throw DivergenceError(root.source() + ": the gas field has " + num(m.nonfinite) +
                            " non-finite values (velocity, pressure or gas fraction)" + at +
                            ": lower gas.dt, raise dem.substeps (or dem.steps_per_collision) or soften the contacts "
                            "(material.stiffness), and check gas.min_gas_fraction");
    if (m.max_courant > c.max_courant)
      throw DivergenceError(root.source() + ": the largest Courant number |u| dt / h of the gas is " +
                            num(m.max_courant) + at + ", above diagnostics.max_courant = " + num(c.max_courant) +
                            ": lower gas.dt (" + num(c.gas.dt) + " s) or use larger cells (gas.cell_size = " + num(h) +
                            " m); the fastest gas follows the inlet velocities (gas.boundaries.*.velocity)");
    const cfd::CgReport cg = gas.last_solve();
    if (!cg.converged && !quiet)
      spdlog::warn("gas pressure solve did not converge{} ({} iterations, residual {:.3g}): raise "
                   "gas.pressure_solver.max_iterations or gas.pressure_solver.tolerance",
                   at, cg.iterations, cg.residual);
    if (regular(step, c.check_interval)) max_courant_seen = std::max(max_courant_seen, m.max_courant);
    else last_courant = std::max(last_courant, m.max_courant);
    const dem::HostParticles hp = dem.download();
    for (Index i = 0; i < hp.size(); ++i) {
      const Vec3d& v = hp.v[static_cast<std::size_t>(i)];
      if (!(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z)))
        throw DivergenceError(root.source() + ": particle id " + std::to_string(hp.id[static_cast<std::size_t>(i)]) +
                              " has a non-finite velocity" + at +
                              ": raise dem.substeps (or dem.steps_per_collision), soften the contacts "
                              "(material.stiffness) or lower gas.dt");
    }
  };

  // The run values of a checkpoint: the statistics accumulators (see the file comment).
  auto run_values = [&]() {
    halo::RunValues v{avg_dp, avg_ratio, avg_height, static_cast<double>(samples), max_courant_seen, max_imbalance};
    for (const Profile& pr : c.profiles) {
      v.insert(v.end(), pr.sum.begin(), pr.sum.end());
      v.insert(v.end(), pr.count.begin(), pr.count.end());
    }
    for (const Profile& pr : c.profiles) {  // after the sums, so that older checkpoints keep their layout
      v.insert(v.end(), pr.bsum.begin(), pr.bsum.end());
      v.insert(v.end(), pr.bcount.begin(), pr.bcount.end());
    }
    return v;
  };
  long step = 0, first_step = 0;
  bool blocks_known = true;  // false after a restart from a checkpoint without the batch sums
  if (ck.restarting()) {  // the state of the checkpoint's step; its series and snapshots are kept
    const halo::RunValues v = cfd::load_bed(ck.reader(), gas, dem);
    const std::size_t want = run_values().size();
    std::size_t without_blocks = 6;
    for (const Profile& pr : c.profiles) without_blocks += pr.sum.size() + pr.count.size();
    // A checkpoint written before the batch means holds the sums only: the
    // averages continue, their standard errors are not known (nan).
    if (v.size() != want && v.size() != without_blocks)
      throw ConfigError("--restart: the checkpoint holds " + std::to_string(v.size()) +
                        " statistics values where this case has " + std::to_string(want) +
                        " (statistics.profiles or statistics.blocks differ)");
    blocks_known = v.size() == want;
    avg_dp = v[0];
    avg_ratio = v[1];
    avg_height = v[2];
    samples = static_cast<long>(v[3]);
    max_courant_seen = v[4];
    max_imbalance = v[5];
    std::size_t at = 6;
    for (Profile& pr : c.profiles) {
      for (double& x : pr.sum) x = v[at++];
      for (double& x : pr.count) x = v[at++];
    }
    if (blocks_known)
      for (Profile& pr : c.profiles) {
        for (double& x : pr.bsum) x = v[at++];
        for (double& x : pr.bcount) x = v[at++];
      }
    step = first_step = ck.restart_step();
    loop.restore_steps(step);
    t = step * c.gas.dt;
    gas_writer.resume(step);
    particle_writer.resume(step);
  }
  // One gas step per call, a stop signal looked for after each.
  sim::Simulation run(comm, "fluidized_bed", first_step, c.steps, sim::Stepping{.chunk = 1, .wait = [&] { ex.synchronize(); }},
                      "coupled");
  // The end-of-run files (also when the watchdog stops the run: what was
  // averaged up to there is kept, and the diagnosis is in summary.json).
  auto write_results = [&](const std::string& diverged) {
    ex.synchronize();
    const double seconds = run.elapsed();
    if (!c.profiles.empty()) {
      std::ostringstream csv;
      csv << "quantity,height,x,value,samples,standard_error\n";
      for (const Profile& pr : c.profiles)
        for (int i = 0; i < g.n[0]; ++i) {
          const double n = pr.count[static_cast<std::size_t>(i)];
          csv << (pr.quantity == ProfileQuantity::VoidFraction ? "void_fraction" : "particle_velocity_z") << ","
              << num(pr.height) << "," << num(g.origin[0] + (i + 0.5) * h) << ","
              << (n > 0 ? num(pr.sum[static_cast<std::size_t>(i)] / n) : std::string("nan")) << "," << num(n) << ","
              << (blocks_known ? batch_error(pr, i) : std::string("nan")) << "\n";
        }
      io::write_text_atomically(c.outdir + "/profiles.csv", csv.str());
      if (blocks_known) {  // each block's own means: how stationary the averages are
        std::ostringstream bcsv;
        bcsv << "quantity,height,x,block,t_start,t_end,value,samples\n";
        const double span = stats_window / c.stats_blocks;
        for (const Profile& pr : c.profiles)
          for (int b = 0; b < c.stats_blocks; ++b)
            for (int i = 0; i < g.n[0]; ++i) {
              const std::size_t at = block_at(b, i);
              const double n = pr.bcount[at];
              bcsv << (pr.quantity == ProfileQuantity::VoidFraction ? "void_fraction" : "particle_velocity_z") << ","
                   << num(pr.height) << "," << num(g.origin[0] + (i + 0.5) * h) << "," << b << ","
                   << num(c.stats_start + b * span) << "," << num(c.stats_start + (b + 1) * span) << ","
                   << (n > 0 ? num(pr.bsum[at] / n) : std::string("nan")) << "," << num(n) << "\n";
            }
        io::write_text_atomically(c.outdir + "/profiles_blocks.csv", bcsv.str());
      }
    }
    const double ns = std::max<long>(samples, 1);
    auto mean = [&](double sum) { return samples ? json::Value(sum / ns) : json::Value(); };
    // The DEM's neighbour-list rebuilds and rebuild-decision reads (each a
    // host wait when the device was not there yet): the launches and host
    // synchronisations of the sub-steps besides their two kernels (cfd/NOTES.md).
    const dem::DemStats st = dem.stats();
    const long done = run.step() - first_step;
    run.summary()
        .set("particles", np)
        .set("gas_cells", g.cells())
        .set("gas_steps", run.step())
        .set("gas_steps_planned", c.steps)
        .set("dem_substeps", c.substeps)
        .set("gas_dt", c.gas.dt)
        .set("time_s", t)
        .set("seconds_per_simulated_second", done > 0 ? seconds / (double(done) * c.gas.dt) : 0.0)
        .set("particle_steps_per_second", seconds > 0 ? double(np) * c.substeps * double(done) / seconds : 0.0)
        .set("backend", to_string(backend))
        .set("drag", cfd::to_string(c.gas.drag))
        .set("void_fraction", cfd::to_string(c.gas.deposition))
        .set("pressure_tolerance", c.gas.cg_tolerance)
        .set("force_coupling", c.lagged_forces ? "lagged" : "sequential")
        .set("overlap_launches", ex.on_device() && ex.overlap_launches())
        .set("dem_force_lanes", dem.params().force_lanes)
        .set("weight_per_area_pa", weight_per_area)
        .set("statistics_samples", samples)
        .set("statistics_blocks", c.stats_blocks)
        .set("mean_pressure_drop_pa", mean(avg_dp))
        .set("mean_pressure_drop_over_weight", mean(avg_ratio))
        .set("mean_bed_height_m", mean(avg_height))
        .set("max_courant", std::max(max_courant_seen, last_courant))
        .set("max_mass_imbalance", std::max(max_imbalance, last_imbalance))
        .set("dem_steps", st.steps)
        .set("dem_fused_steps", st.fused_steps)
        .set("dem_rebuilds", st.rebuilds)
        .set("dem_report_reads", st.status_reads)
        .set("dem_report_waits", st.status_waits)
        .set("diverged", diverged.empty() ? json::Value() : json::Value(diverged));
  };
  run.add("watchdog", sim::Trigger::steps_and_end(c.check_interval), [&](const sim::Event& e) {
    try {
      watchdog(e.step);
    } catch (const DivergenceError& err) {
      write_fields(e.step);  // the field the watchdog saw, for the diagnosis
      write_results(err.what());
      run.write_summary(c.outdir);
      throw;
    }
  });
  if (c.stats_interval > 0)
    run.add("statistics", sim::Trigger::steps(c.stats_interval), [&](const sim::Event&) {
      if (t >= c.stats_start - 1e-12) sample();
    });
  run.add("series", sim::Trigger{.every_steps = c.series_interval, .at_start = true, .at_end = true},
          [&](const sim::Event& e) { series_row(e.step); });
  run.add("snapshot", sim::Trigger{.every_steps = c.output_interval, .at_start = true, .at_end = true},
          [&](const sim::Event& e) { write_fields(e.step); });
  run.add("checkpoint", sim::checkpoint_trigger(c.checkpoint), [&](const sim::Event& e) {
    const halo::RunValues v = run_values();
    ck.write(e.step, t, [&](ckpt::Writer& w) { cfd::save_bed(w, gas, dem, v); });
  });
  run.progress([&](long) { return t; }, static_cast<double>(np) * c.substeps, "particle-steps/s", quiet);
  run.run([&](long n) {
    for (long k = 0; k < n; ++k) {
      if (lagged)
        lagged->step(step == 0);  // a restart carries the lagged forces in its checkpoint
      else
        loop.step();
      ++step;
      t = step * c.gas.dt;
    }
  });
  write_results("");
  if (run.conclude(c.outdir, t) != 0) return kExitInterrupted;
  const double seconds = run.elapsed();
  if (!quiet)
    spdlog::info("done: {} gas steps in {} ({:.4g} s per simulated second); results: {}/gas.xdmf, "
                 "{}/particles.xdmf (ParaView), {}/series.csv, {}/summary.json",
                 step, format_duration(seconds), step > first_step ? seconds / (double(step - first_step) * c.gas.dt) : 0.0,
                 c.outdir, c.outdir, c.outdir, c.outdir);
  return 0;
}

}  // namespace lbdem
