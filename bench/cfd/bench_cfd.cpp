// Unresolved CFD-DEM benchmark: the coupled step of the second paper's Sec. 5.2
// system (Yu et al. 2024: 1,000,000 particles in a 0.5 x 0.5 x 1.2 m bed on
// 300,000 gas cells, U = 0.9 m/s).
//
//   lbdem_bench_cfd --out DIR [--particles 1000000] [--steps 20] [--host-steps 3]
//                   [--backends cuda,cpuall] [--void-fraction linear] [--gas-dt 5e-4]
//                   [--pressure-solver multigrid|cg] [--dem-graphs 1|0] [--host-threads N]
//                   [--force-coupling sequential|lagged]
//
// Set-up: 50 x 50 x 120 cubic gas cells of 10 mm (300,000); particles of
// d = 2.5 mm (4 per cell width), rho = 1000 kg/m^3, k = 800 N/m, e = 0.97,
// mu_p = 0.1 (Mueller's material, Table 1), in a random packing at solid
// fraction 0.55 filling the bottom of the box (the paper gives no particle
// size for this system; with these U_mf ~ 0.72 m/s, so 0.9 m/s fluidizes);
// walls no-slip, a uniform distributor at 0.9 m/s, pressure outlet on top;
// Gidaspow drag. Gas dt 5e-4 s (the paper's 1e-3 s halved), DEM dt t_c/50.
// The pressure solve is the multigrid-preconditioned CG of the shipped bed
// cases (`--pressure-solver cg`: the Jacobi CG the first runs of this bench
// used); `--dem-graphs 0` launches the DEM sub-steps kernel by kernel
// (DemParams::substep_graphs); `--host-threads N` runs the host on N cores
// (default: all of them, `cpuall`); `--force-coupling lagged` runs the
// sub-steps with the previous gas step's forces, the gas step beside them
// (cfd/lagged_coupling.hpp).
//
// For every backend (CUDA where usable; the host on all its cores): after
// `--warmup` gas steps, (1) the whole coupled step (gas step + DEM sub-steps,
// dem::CoupledLoop) timed over `--steps` steps, wall clock around the loop
// after a synchronisation; (2) the same number of steps again with the phases
// timed apart (GasSolver::time_phases: a wait at the end of each phase): gas,
// void fraction, drag, DEM. Reports seconds per gas step and per simulated
// second, particle-steps/s of the whole loop, the split, and the GPU's speed-up
// over the host. Writes DIR/bench_cfd.json and DIR/bench_cfd.md.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "cfd/coupling.hpp"
#include "cfd/lagged_coupling.hpp"
#include "core/error.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"

using namespace lbdem;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

struct Options {
  long particles = 1000000;
  int steps = 20, host_steps = 3, warmup = 3;
  double gas_dt = 5e-4;
  std::string backends = "cuda,cpuall";
  std::string deposition = "linear";
  std::string pressure = "multigrid";
  bool dem_graphs = true;
  std::string coupling = "sequential";
  int host_threads = 0;  // 0: all cores
  std::string out;
};

struct Result {
  std::string backend, device;
  int threads = 0;
  long particles = 0, cells = 0;
  int substeps = 0, steps = 0;
  double gas_dt = 0, dem_dt = 0;
  double step_s = 0;  // whole coupled step, no phase waits
  double gas_s = 0, void_s = 0, drag_s = 0, dem_s = 0;  // per step, with waits
  double setup_s = 0;
  int cg_iterations = 0;
  // DEM over the timed whole steps: sub-steps, list rebuilds, reports read
  // (and of those, waits), sub-step graphs launched and the sub-steps in them.
  long dem_steps = 0, rebuilds = 0, reads = 0, waits = 0, graphs = 0, graph_steps = 0;
};

Result run(const Options& o, Backend b, int threads) {
  const auto t_setup = Clock::now();
  const double Lx = 0.5, Ly = 0.5, Lz = 1.2, h = 0.01, d = 2.5e-3, rho_s = 1000;
  const double vp = 3.14159265358979323846 / 6 * d * d * d;
  dem::RandomPackingSpec spec;
  spec.lo = {0, 0, 0};
  // The bottom of the box at solid fraction 0.55 (at least 4 diameters high:
  // smaller counts fill that layer more loosely).
  const double layer = std::min(Lz, std::max(4 * d, static_cast<double>(o.particles) * vp / (0.55 * Lx * Ly)));
  spec.solid_fraction = static_cast<double>(o.particles) * vp / (Lx * Ly * layer);
  spec.hi = {Lx, Ly, layer};
  spec.periodic = {false, false, false};
  spec.r_min = spec.r_max = 0.5 * d;
  spec.density = rho_s;
  spec.seed = 1;
  const dem::HostParticles init = dem::random_packing(spec);

  dem::DemParams dp;
  dp.lo = {0, 0, 0};
  dp.hi = {Lx, Ly, Lz};
  for (int a = 0; a < 3; ++a) {
    Vec3d n{0, 0, 0};
    n[a] = 1;
    dp.walls.push_back(dem::Wall{{0, 0, 0}, n});
    n[a] = -1;
    dp.walls.push_back(dem::Wall{{Lx, Ly, Lz}, n});
  }
  dp.material.stiffness = dp.material.wall_stiffness = 800;
  dp.material.restitution = dp.material.wall_restitution = 0.97;
  dp.material.friction = dp.material.wall_friction = 0.1;
  dp.friction = true;
  dp.gravity = {0, 0, -9.80665};
  dp.external_forcing = true;
  dp.skin = 0.1 * d;
  dp.substep_graphs = o.dem_graphs;
  const int substeps = static_cast<int>(std::ceil(o.gas_dt / (dem::min_collision_time(dp, init) / 50)));
  dp.dt = o.gas_dt / substeps;

  cfd::GasGridView g;
  g.n[0] = 50;
  g.n[1] = 50;
  g.n[2] = 120;
  g.h = h;
  cfd::GasParams gp;
  gp.rho = 1.225;
  gp.mu = 1.8e-5;
  gp.dt = o.gas_dt;
  gp.gravity = dp.gravity;
  gp.faces[4].kind = cfd::FaceKind::Inlet;
  gp.faces[4].inflow = 0.9;
  gp.faces[5].kind = cfd::FaceKind::Outlet;
  gp.drag = cfd::DragLaw::Gidaspow;
  gp.deposition = cfd::parse_deposition("--void-fraction", o.deposition);
  gp.pressure_solver = cfd::parse_pressure_solver("--pressure-solver", o.pressure);
  gp.cg_poll_every = gp.pressure_solver == cfd::PressureSolverKind::Multigrid ? 2 : 25;

  if (b == Backend::Host) omp_set_num_threads(threads);
  Exec ex(b);
  // Overlapped kernel launches (core/exec.hpp) unless LBDEM_OVERLAP_LAUNCHES=0, as the bed scene.
  const char* overlap = std::getenv("LBDEM_OVERLAP_LAUNCHES");
  ex.set_overlap_launches(!(overlap && std::strcmp(overlap, "0") == 0));
  dem::DemSystem dem(ex, dp, init);
  // Lagged forces (cfd/lagged_coupling.hpp): the gas on a second queue.
  const Lanes lanes;
  const bool lag = o.coupling == "lagged";
  cfd::GasSolver gas(lag ? lanes.edge(ex) : ex, g, gp);
  cfd::GasDemCoupling coupling(gas);
  dem::CoupledLoop loop(dem, coupling, substeps);
  std::optional<cfd::LaggedCoupling> lagged;
  if (lag) {
    std::int64_t limit = 0;
    for (std::int64_t id : init.id) limit = std::max(limit, id + 1);
    lagged.emplace(ex, lanes, dem, gas, substeps, limit);
  }
  lanes.fork(ex);
  gas.initialise(dem.view());
  lanes.join(ex);
  ex.synchronize();
  long done = 0;
  auto step = [&] {
    if (lagged)
      lagged->step(done == 0);
    else
      loop.step();
    ++done;
  };

  Result r;
  r.backend = b == Backend::Cuda ? "cuda" : "host";
  r.device = bench::device_name(b);
  r.threads = b == Backend::Host ? threads : 0;
  r.particles = static_cast<long>(init.size());
  r.cells = static_cast<long>(g.cells());
  r.substeps = substeps;
  r.gas_dt = o.gas_dt;
  r.dem_dt = dp.dt;
  r.setup_s = since(t_setup);
  const int steps = b == Backend::Host ? o.host_steps : o.steps;
  r.steps = steps;
  std::fprintf(stderr, "%s: %ld particles, %ld cells, %d DEM sub-steps per gas step; set-up %.1f s\n",
               r.backend.c_str(), r.particles, r.cells, substeps, r.setup_s);
  for (int i = 0; i < o.warmup; ++i) step();
  ex.synchronize();
  // (1) the whole coupled step.
  const dem::DemStats s0 = dem.stats();
  auto t0 = Clock::now();
  for (int i = 0; i < steps; ++i) step();
  ex.synchronize();
  r.step_s = since(t0) / steps;
  const dem::DemStats s1 = dem.stats();
  r.dem_steps = s1.steps - s0.steps;
  r.rebuilds = s1.rebuilds - s0.rebuilds;
  r.reads = s1.status_reads - s0.status_reads;
  r.waits = s1.status_waits - s0.status_waits;
  r.graphs = s1.graph_launches - s0.graph_launches;
  r.graph_steps = s1.graph_steps - s0.graph_steps;
  r.cg_iterations = gas.last_solve().iterations;
  // (2) the split.
  cfd::StepTimes st;
  gas.time_phases(&st);
  double dem_total = 0;
  for (int i = 0; i < steps; ++i) {
    lanes.fork(ex);
    gas.step(dem.view());
    lanes.join(ex);
    ex.synchronize();
    t0 = Clock::now();
    dem.advance(substeps);
    dem.synchronize();
    dem_total += since(t0);
  }
  gas.time_phases(nullptr);
  r.gas_s = st.gas / steps;
  r.void_s = st.void_fraction / steps;
  r.drag_s = st.drag / steps;
  r.dem_s = dem_total / steps;
  std::fprintf(stderr, "%s: %.4g s per gas step (gas %.3g, void fraction %.3g, drag %.3g, DEM %.3g s)\n",
               r.backend.c_str(), r.step_s, r.gas_s, r.void_s, r.drag_s, r.dem_s);
  return r;
}

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--out") o.out = next();
    else if (a == "--particles") o.particles = std::stol(next());
    else if (a == "--steps") o.steps = std::stoi(next());
    else if (a == "--host-steps") o.host_steps = std::stoi(next());
    else if (a == "--warmup") o.warmup = std::stoi(next());
    else if (a == "--gas-dt") o.gas_dt = std::stod(next());
    else if (a == "--backends") o.backends = next();
    else if (a == "--void-fraction") o.deposition = next();
    else if (a == "--pressure-solver") o.pressure = next();
    else if (a == "--dem-graphs") o.dem_graphs = next() != "0";
    else if (a == "--force-coupling") o.coupling = next();
    else if (a == "--host-threads") o.host_threads = std::stoi(next());
    else {
      std::fprintf(stderr,
                   "usage: lbdem_bench_cfd --out DIR [--particles N] [--steps N] [--host-steps N] [--warmup N] "
                   "[--gas-dt S] [--backends cuda,cpuall] [--void-fraction centroid|linear|quadratic] "
                   "[--pressure-solver multigrid|cg] [--dem-graphs 1|0] [--host-threads N] "
                   "[--force-coupling sequential|lagged]\n");
      return 2;
    }
  }
  if (o.coupling != "sequential" && o.coupling != "lagged") {
    std::fprintf(stderr, "--force-coupling %s: valid: sequential, lagged\n", o.coupling.c_str());
    return 2;
  }
  if (o.out.empty() || o.particles < 1 || o.steps < 1 || o.host_steps < 1 || o.warmup < 0 || !(o.gas_dt > 0) ||
      o.host_threads < 0) {
    std::fprintf(stderr, "--out DIR is required; counts must be positive\n");
    return 2;
  }
  try {
    std::vector<Result> res;
    std::vector<std::pair<std::string, double>> bw;
    std::stringstream bs(o.backends);
    std::string tok;
    const int all = o.host_threads > 0 ? o.host_threads : omp_get_num_procs();
    while (std::getline(bs, tok, ',')) {
      if (tok == "cuda") {
        if (!cuda_unavailable_reason().empty()) {
          std::fprintf(stderr, "skipping cuda: %s\n", cuda_unavailable_reason().c_str());
          continue;
        }
        bw.push_back({"cuda", bench::copy_bandwidth(Backend::Cuda, std::size_t(1) << 30)});
        res.push_back(run(o, Backend::Cuda, 0));
      } else if (tok == "cpuall" || tok == "cpu") {
        omp_set_num_threads(all);
        bw.push_back({"host", bench::copy_bandwidth(Backend::Host, std::size_t(1) << 28)});
        res.push_back(run(o, Backend::Host, all));
      } else {
        std::fprintf(stderr, "unknown backend '%s' (valid: cuda, cpuall)\n", tok.c_str());
        return 2;
      }
    }
    if (res.empty()) {
      std::fprintf(stderr, "no backend ran\n");
      return 1;
    }
    const std::string dev = res.front().device;
    std::ostringstream js, md;
    js << "{\n" << bench::json_header("cfd_coupled_step", dev, bw) << ",\n  \"system\": \"Yu et al. 2024 Sec. 5.2: "
       << "0.5 x 0.5 x 1.2 m, 50 x 50 x 120 cells, d = 2.5 mm, U = 0.9 m/s, Gidaspow, void fraction "
       << o.deposition << ", pressure solve " << o.pressure << ", DEM sub-step graphs " << (o.dem_graphs ? "on" : "off")
       << ", forces " << o.coupling << "\",\n  \"pressure_solver\": \"" << o.pressure
       << "\",\n  \"force_coupling\": \"" << o.coupling << "\",\n  \"overlap_launches\": "
       << (std::getenv("LBDEM_OVERLAP_LAUNCHES") && std::strcmp(std::getenv("LBDEM_OVERLAP_LAUNCHES"), "0") == 0 ? "false" : "true")
       << ",\n  \"dem_substep_graphs\": "
       << (o.dem_graphs ? "true" : "false") << ",\n  \"runs\": [\n";
    md << "# CFD-DEM coupled step, Yu et al. 2024 Sec. 5.2 system\n\n"
       << "Device: " << dev << ", commit " << bench::git_commit() << ", " << bench::utc_date() << ". Void fraction "
       << o.deposition << ", Gidaspow drag, pressure solve " << o.pressure << ", DEM sub-step graphs "
       << (o.dem_graphs ? "on" : "off") << ", " << o.coupling << " forces.\n\n"
       << "| backend | threads | particles | cells | sub-steps | s / gas step | s / simulated s | particle-steps/s "
          "| gas | void fraction | drag | DEM | CG iterations |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (std::size_t k = 0; k < res.size(); ++k) {
      const Result& r = res[k];
      const double psps = static_cast<double>(r.particles) * r.substeps / r.step_s;
      js << "    {\"backend\": \"" << r.backend << "\", \"device\": \"" << bench::json_escape(r.device)
         << "\", \"threads\": " << r.threads << ", \"particles\": " << r.particles << ", \"cells\": " << r.cells
         << ", \"dem_substeps\": " << r.substeps << ", \"gas_dt\": " << num(r.gas_dt) << ", \"dem_dt\": "
         << num(r.dem_dt) << ", \"timed_steps\": " << r.steps << ", \"seconds_per_gas_step\": " << num(r.step_s)
         << ", \"seconds_per_simulated_second\": " << num(r.step_s / r.gas_dt)
         << ", \"particle_steps_per_second\": " << num(psps) << ", \"split_seconds_per_gas_step\": {\"gas\": "
         << num(r.gas_s) << ", \"void_fraction\": " << num(r.void_s) << ", \"drag\": " << num(r.drag_s)
         << ", \"dem\": " << num(r.dem_s) << "}, \"cg_iterations\": " << r.cg_iterations
         << ", \"dem_steps\": " << r.dem_steps << ", \"dem_rebuilds\": " << r.rebuilds
         << ", \"dem_report_reads\": " << r.reads << ", \"dem_report_waits\": " << r.waits
         << ", \"dem_graph_launches\": " << r.graphs << ", \"dem_graph_steps\": " << r.graph_steps
         << ", \"setup_seconds\": " << num(r.setup_s) << "}" << (k + 1 < res.size() ? "," : "") << "\n";
      md << "| " << r.backend << " | " << r.threads << " | " << r.particles << " | " << r.cells << " | " << r.substeps
         << " | " << num(r.step_s) << " | " << num(r.step_s / r.gas_dt) << " | " << num(psps) << " | "
         << num(r.gas_s) << " | " << num(r.void_s) << " | " << num(r.drag_s) << " | " << num(r.dem_s) << " | "
         << r.cg_iterations << " |\n";
    }
    js << "  ]";
    const Result* gpu = nullptr;
    const Result* host = nullptr;
    for (const Result& r : res) (r.backend == "cuda" ? gpu : host) = &r;
    if (gpu && host) {
      js << ",\n  \"speedup_gpu_over_host\": " << num(host->step_s / gpu->step_s);
      md << "\nWhole coupled step, GPU over all " << host->threads << " host cores: "
         << num(host->step_s / gpu->step_s) << "x.\n";
    }
    js << "\n}\n";
    md << "\nSplit: wall time of each phase with a wait at its end (the sum exceeds the whole step a little).\n";
    // The results are the point of the run: a folder that cannot be made or
    // a file that cannot be written is an error, not a silent loss.
    std::filesystem::create_directories(o.out);
    for (const auto& [name, text] : {std::pair<std::string, std::string>{"/bench_cfd.json", js.str()},
                                     std::pair<std::string, std::string>{"/bench_cfd.md", md.str()}}) {
      std::ofstream f(o.out + name);
      f << text;
      f.close();
      if (!f) throw std::runtime_error("cannot write " + o.out + name);
    }
    std::printf("%s", md.str().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
