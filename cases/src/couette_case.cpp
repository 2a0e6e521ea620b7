// Plane Couette flow started from rest: fluid between a wall at rest (y = 0)
// and a wall sliding at U along x (y = H), periodic along x (and z in 3D).
// The start-up has a closed form (a Fourier series of the diffusion equation):
//
//   u(y, t) = U y/H - (2U/pi) sum_n (-1)^(n+1)/n sin(n pi y/H) exp(-n^2 pi^2 nu t / H^2),
//
// which the check compares with at the last step (relative L2 over the fluid
// cells, summed rank by rank: no field is gathered). Half-way bounce-back puts
// the walls half a cell outside the first and last fluid rows; the sliding
// wall is Ladd's moving-wall rule.
//
// The scene is the example of a scene on the one time loop
// (halo/simulation.hpp): parse, set up, step, verify and its summary fields
// in this file, one line in cases/src/registry.cpp.
#include <spdlog/spdlog.h>

#include <cmath>
#include <optional>

#include "cases/scenes.hpp"
#include "halo/simulation.hpp"
#include "lbm/checkpoint.hpp"
#include "core/output_section.hpp"
#include "core/run_length.hpp"
#include "core/memory_use.hpp"
#include "core/signals.hpp"
#include "core/piece_output.hpp"
#include "core/units.hpp"
#include "lbm/distributed_fluid.hpp"
#include "lbm/tau.hpp"

namespace lbdem {

namespace {
constexpr double kPi = 3.14159265358979323846;

// The series above at distance y from the resting wall, lattice units; terms
// until they fall below 1e-18 of U (at t > 0 they decay as exp(-n^2)).
double couette_startup(double U, double H, double nu, double y, double t) {
  double s = 0;
  for (int n = 1; n <= 100000; ++n) {
    const double decay = std::exp(-double(n) * n * kPi * kPi * nu * t / (H * H));
    if (decay < 1e-18 && n > 1) break;
    s += (n % 2 ? 1.0 : -1.0) / n * std::sin(n * kPi * y / H) * decay;
  }
  return U * y / H - 2.0 * U / kPi * s;
}
}  // namespace

std::vector<std::string> couette_scene_names() { return {"couette"}; }

int run_couette_case(const Config& root, const RunOptions& opt) {
  // ---- parse: every key checked before anything is touched.
  lbm::LbmSetup s;
  s.lattice = root.choice("lattice", "D2Q9", {"D2Q9", "D3Q19"}) == "D2Q9" ? lbm::LatticeKind::D2Q9
                                                                        : lbm::LatticeKind::D3Q19;
  const std::size_t D = s.lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  s.precision = lbm::precision_from_string(root.choice("precision", "fp64", {"fp32", "fp64", "fp16s", "fp16c"}));
  const Config coll = root.section("collision");
  s.collision = coll.choice("model", "trt", {"bgk", "trt"}) == "bgk" ? lbm::CollisionKind::BGK : lbm::CollisionKind::TRT;
  s.magic = coll.number_in("magic", 3.0 / 16.0, 1e-6, 100.0, "TRT magic parameter Lambda; 3/16 exact walls");
  UnitsRequest ur;
  if (coll.has("tau")) ur.tau = coll.number("tau");
  coll.finish();
  const Config fl = root.section("fluid");
  ur.rho = fl.positive("density");
  ur.nu = fl.positive("kinematic_viscosity");
  fl.finish();
  const Config dom = root.section("domain");
  const auto cells = dom.integers("cells", D, D, 1, 1L << 16);
  ur.dx = dom.positive("spacing");
  dom.finish();
  const Config sc = root.section("couette");
  const double U_si = sc.positive("wall_velocity");
  sc.finish();
  const Config time = root.section("time");
  const RunLength len = read_run_length(time, 1, 1000000000000L);
  const std::optional<long> steps_given = len.steps;
  const double t_end = len.end.value_or(0.0);
  time.finish();
  const OutputSettings out = read_output(root, kOutputInterval, "runs/couette", 1000000000000L);
  std::string outdir = out.directory;
  const long out_interval = out.interval;
  const halo::ParallelOptions parallel = halo::parse_parallel(root);
  const ckpt::Policy policy = ckpt::read_policy(root);
  root.finish();
  ur.u_ref = U_si;
  ur.where = root.source();
  const Units units = derive_units(ur);
  s.tau = units.tau;
  const long steps = opt.steps ? *opt.steps
                               : steps_given.value_or(std::max<long>(1, std::lround(t_end / units.dt)));
  if (opt.output) outdir = *opt.output;
  // Fluid rows 1..H between the wall rows 0 and H + 1.
  const long H = cells[1];
  std::array<long, 3> n{cells[0], H + 2, D == 3 ? cells[2] : 1};
  s.domain = Grid::whole(n, {true, false, true});
  s.domain.spacing = units.dx;
  s.domain.origin[1] = -units.dx;
  const double U = units.to_lattice_velocity(U_si);
  s.boundaries.count = 2;
  s.boundaries.kind[0] = lbm::BoundaryKind::Wall;
  s.boundaries.kind[1] = lbm::BoundaryKind::Velocity;
  s.boundaries.u[1][0] = U;
  s.boundaries.rho[0] = s.boundaries.rho[1] = 1.0;
  const halo::Comm& comm = halo::Comm::world();
  // The cut and the memory of this rank's piece, checked before anything is allocated.
  const Backend backend = resolve_backend(opt.backend);
  const std::size_t need = lbm::distributed_fluid_memory(s, parallel, comm.size());
  if (need > backend_free_bytes(backend))
    throw ResourceError("key 'domain.cells': the grid needs " + std::to_string(need >> 20) + " MiB of " +
                        to_string(backend) + " memory but " + std::to_string(backend_free_bytes(backend) >> 20) +
                        " MiB are free; use fewer cells or precision: fp32");
  if (opt.validate_only) return 0;
  lbm::DistributedFluid fluid(s, backend, parallel, comm);

  // ---- set up: each rank its piece, at rest; a restart its checkpoint.
  ckpt::Run ck = halo::open_run(outdir, policy, lbm::fluid_identity("couette", s), opt.restart, comm);
  if (comm.root()) ck.prepare_output(opt.overwrite);
  if (comm.distributed()) ck.set_layout(halo::rank_layout(comm.size(), fluid.decomposition().describe()));
  fluid.initialize_uniform([&](long, long y, long) -> std::uint8_t { return y == 0 ? 1 : y == H + 1 ? 2 : 0; }, 1.0);
  lbm::LbmSolver& ls = fluid.local();
  long step0 = 0;
  if (ck.restarting()) {
    lbm::load_fluid(ck, comm, ls, s.domain, {});
    step0 = ck.restart_step();
  }
  io::PieceGridWriter writer(outdir, "fields", s.domain, fluid.piece_boxes(), comm.rank(), ls.setup().domain.owned());
  if (ck.restarting() && comm.root()) writer.resume(step0);
  const std::vector<io::SlabField> fields{{"velocity", 3, "m/s"}};
  std::vector<double> rho_slab;

  // ---- step, with its operations.
  sim::Simulation loop(comm, "couette", step0, steps, sim::Stepping{.wait = [&] { fluid.synchronize(); }}, "lbm");
  loop.add("watchdog", sim::Trigger::steps_and_end(1000), [&](const sim::Event& e) {
    if (!fluid.diagnostics().finite)
      throw DivergenceError("scene couette: non-finite velocity at step " + std::to_string(e.step) +
                            "; raise collision.tau or lower couette.wall_velocity");
  });
  loop.add("output", sim::Trigger{.every_steps = out_interval, .at_start = out_interval > 0, .at_end = true},
           [&](const sim::Event& e) {
             if (comm.root()) writer.record(e.step);
             if (comm.distributed()) comm.barrier();
             writer.write_piece(e.step, e.step * units.dt, fields, ls.output_slab_cells(),
                                [&](const CellBox& b, const std::vector<double*>& o) {
                                  rho_slab.resize(static_cast<std::size_t>(b.size()));
                                  ls.macroscopic_box(b, rho_slab.data(), o[0]);
                                  for (Index i = 0; i < 3 * b.size(); ++i) o[0][i] = units.to_si_velocity(o[0][i]);
                                });
             if (comm.distributed()) comm.barrier();
             if (comm.root()) writer.index(e.step, e.step * units.dt, fields);
           }, true);
  loop.add("checkpoint", sim::checkpoint_trigger(policy), [&](const sim::Event& e) {
    lbm::save_fluid(ck, comm, e.step, e.step * units.dt, ls, {});
  });
  loop.progress([&](long st) { return st * units.dt; }, double(n[0] * H * n[2]) / 1e6, "MLUPS", opt.quiet);
  loop.run([&](long k) { fluid.step(k); });

  // ---- verify: each rank its owned fluid cells, the sums over the ranks.
  const long t = loop.step();
  const double nu = lbm::lattice_viscosity(s.tau);
  std::vector<double> sums{0, 0};  // sum (u - u_ref)^2, sum u_ref^2
  const Grid& piece = ls.setup().domain;
  const CellBox own = piece.owned();
  std::vector<double> u_slab;
  for (const CellBox& b : slabs_of(own, ls.output_slab_cells())) {
    rho_slab.resize(static_cast<std::size_t>(b.size()));
    u_slab.resize(3 * static_cast<std::size_t>(b.size()));
    ls.macroscopic_box(b, rho_slab.data(), u_slab.data());
    std::size_t i = 0;
    for (int z = b.lo[2]; z < b.lo[2] + b.ext[2]; ++z)
      for (int y = b.lo[1]; y < b.lo[1] + b.ext[1]; ++y)
        for (int x = b.lo[0]; x < b.lo[0] + b.ext[0]; ++x, ++i) {
          const long gy = y - own.lo[1] + piece.offset[1];
          if (gy < 1 || gy > H) continue;  // a wall row
          const double ref = couette_startup(U, double(H), nu, double(gy) - 0.5, double(t));
          sums[0] += (u_slab[3 * i] - ref) * (u_slab[3 * i] - ref);
          sums[1] += ref * ref;
        }
  }
  if (comm.distributed()) comm.sum(sums);
  const double error = std::sqrt(sums[0] / std::max(sums[1], 1e-300));
  loop.summary().set("dx_m", units.dx).set("dt_s", units.dt).set("tau", units.tau).set("wall_velocity_lattice", U);
  loop.summary()["verification"].set("velocity_rel_l2_vs_startup_series", error);
  if (loop.conclude(outdir, t * units.dt) != 0) return kExitInterrupted;
  if (!opt.quiet)
    spdlog::info("check: velocity against the start-up series of plane Couette flow at t = {:.6g} s: relative L2 "
                 "error {:.3e} ({} fluid rows, tau = {:.4g})",
                 t * units.dt, error, H, units.tau);
  return 0;
}

}  // namespace lbdem
