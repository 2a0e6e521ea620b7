// DEM throughput benchmark.
//
//   lbdem_bench_dem --out FILE.json [--sizes 100000,1000000,10000000]
//                   [--host-sizes 100000,1000000] [--quick] [--backends cuda,cpu1,cpuall]
//
// For every backend (CUDA when usable; the host with one thread and with all
// threads), every size (dense random packing, solid fraction 0.5, periodic,
// random velocities), frictionless and frictional, and both force paths:
// particle-steps per second of the full step, and the time of each phase
// alone (neighbour rebuild, force evaluation, integration), medians of
// repeats after warm-up (CUDA events on the GPU). Bytes each per-step kernel
// must move (a model, below) are compared with the copy bandwidth measured in
// the same run. Prints a markdown table and writes JSON.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "core/buffer.hpp"
#include "core/error.hpp"
#include "dem/contact.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"

using namespace lbdem;
using namespace lbdem::dem;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Times f() on a backend [s]: CUDA events around it on the device (after a
// synchronisation), the steady clock on the host.
double time_once(Backend b, const std::function<void()>& f) {
#if defined(LBDEM_HAVE_CUDA)
  if (b == Backend::Cuda) {
    cudaEvent_t e0, e1;
    LBDEM_CUDA_CHECK(cudaEventCreate(&e0));
    LBDEM_CUDA_CHECK(cudaEventCreate(&e1));
    LBDEM_CUDA_CHECK(cudaDeviceSynchronize());
    LBDEM_CUDA_CHECK(cudaEventRecord(e0));
    f();
    LBDEM_CUDA_CHECK(cudaEventRecord(e1));
    LBDEM_CUDA_CHECK(cudaEventSynchronize(e1));
    float ms = 0;
    LBDEM_CUDA_CHECK(cudaEventElapsedTime(&ms, e0, e1));
    LBDEM_CUDA_CHECK(cudaEventDestroy(e0));
    LBDEM_CUDA_CHECK(cudaEventDestroy(e1));
    return 1e-3 * ms;
  }
#endif
  (void)b;
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double median_time(Backend b, int reps, const std::function<void()>& f) {
  std::vector<double> t;
  for (int r = 0; r < reps; ++r) t.push_back(time_once(b, f));
  return median(t);
}

struct Setup {
  DemParams params;
  HostParticles particles;
};

// Dense random packing: d = 1 mm glass-like spheres, solid fraction 0.5,
// periodic cube; random speeds of ~1e-3 d per step.
Setup make_setup(long n, unsigned seed) {
  const double r = 0.5e-3, phi = 0.5;
  const double L = std::cbrt(n * 4.0 / 3.0 * kPi * r * r * r / phi);
  RandomPackingSpec s;
  s.lo = {0, 0, 0};
  s.hi = {L, L, L};
  s.periodic = {true, true, true};
  s.solid_fraction = phi;
  s.r_min = s.r_max = r;
  s.density = 2500;
  s.seed = seed;
  Setup st;
  st.particles = random_packing(s);
  DemParams& p = st.params;
  p.lo = s.lo;
  p.hi = s.hi;
  p.periodic = {true, true, true};
  p.material.stiffness = 1000;
  p.material.restitution = 0.9;
  p.material.friction = 0.3;
  p.material.wall_stiffness = 1000;
  p.skin = 0.1 * 2 * r;
  p.dt = 0;  // set per friction flag
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> N(0, 1);
  st.params.friction = false;
  const double dt = min_collision_time(p, st.particles) / 50;
  const double v = 1e-3 * 2 * r / dt;
  for (auto& x : st.particles.v) x = Vec3d{N(rng), N(rng), N(rng)} * (v / std::sqrt(3.0));
  return st;
}

struct Result {
  std::string backend;
  int threads = 0;
  long n = 0;
  bool friction = false;
  std::string path;
  double pps = 0;            // particle-steps per second, full step
  double t_step = 0;         // s per step
  double t_force = 0, t_integrate = 0, t_rebuild = 0;  // s per call
  double rebuild_interval = 0;  // steps per rebuild in the timed run
  double t_neigh_step = 0;      // rebuild time amortised per step
  double mean_nb = 0;
  double bytes_per_ps = 0;   // model bytes per particle-step (forces + integration)
  double achieved_bw = 0;    // model bytes / measured (force + integrate) time
  double copy_bw = 0;
};

// Compulsory traffic per particle-step, assuming neighbour data come from
// cache (sorted order) and every own record is read/written once.
// Records are 32 B (Real4), list entries 4 B, histories 24 B.
double bytes_model(bool friction, ForcePath path, double nb, double contacts) {
  double integ = friction ? 416 : 256;  // KickDrift: see dem/src/kernels.hpp
  double force = 0;
  if (path == ForcePath::Particle) {
    force = 64 + 4 + 32 + 4 * nb;  // own pos+vel, count, force out, list
    if (friction) force += 32 + 32 + 24 * nb + 24 * contacts;  // omega, torque, histories
  } else {
    force = 64 + 4 + 32 + 4 * nb + 4 + 12;       // PairInit + scan
    force += 4 + 4 + 32 + 4 * nb + 8 * contacts / 2;  // PairFill
    force += contacts / 2 * (8 + 4 + 2 * 64 + 2 * 2 * 32);  // PairForce: pair, slot, both records, 2 atomic RMW
    if (friction) force += 32 + 32 + contacts / 2 * (48 + 2 * 32 + 2 * 2 * 32) + 24 * nb / 2;
  }
  return integ + force;
}

Result run_one(Backend b, int threads, const Setup& st, bool friction, ForcePath path, bool quick, double copy_bw) {
  DemParams p = st.params;
  p.friction = friction;
  p.path = path;
  p.dt = min_collision_time(p, st.particles) / 50;
  DemSystem sys(Exec(b), p, st.particles);
  const Index n = sys.size();
  sys.advance(quick ? 3 : 10);  // warm-up (allocations, caches)
  sys.synchronize();
  Result r;
  r.backend = to_string(b);
  r.threads = threads;
  r.n = n;
  r.friction = friction;
  r.path = to_string(path);
  r.copy_bw = copy_bw;
  // Full steps: aim at ~1.5 s of measurement (0.3 s quick).
  const double t5 = time_once(b, [&] { sys.advance(5); }) / 5;
  const long steps = std::clamp<long>(static_cast<long>((quick ? 0.3 : 1.5) / std::max(t5, 1e-9)), 10, 1000);
  const long rb0 = sys.stats().rebuilds;
  std::vector<double> ts;
  long total_steps = 0;
  for (int rep = 0; rep < 3; ++rep) {
    ts.push_back(time_once(b, [&] { sys.advance(steps); }) / steps);
    total_steps += steps;
  }
  r.t_step = median(ts);
  r.pps = n / r.t_step;
  const long rbs = sys.stats().rebuilds - rb0;
  r.rebuild_interval = rbs > 0 ? static_cast<double>(total_steps) / rbs : static_cast<double>(total_steps);
  const int reps = b == Backend::Cuda ? 21 : (quick ? 3 : 5);
  r.t_force = median_time(b, reps, [&] { sys.bench_forces(); });
  r.t_integrate = median_time(b, reps, [&] { sys.bench_integrate(); });
  r.t_rebuild = median_time(b, std::max(3, reps / 3), [&] { sys.bench_rebuild(); });
  r.t_neigh_step = rbs > 0 ? r.t_rebuild * rbs / total_steps : 0.0;
  const DemStats s = sys.stats();
  r.mean_nb = s.mean_neighbours;
  // Contacts per particle (both directions) from the current state.
  const double contacts = 2.0 * static_cast<double>(sys.contact_pairs().size()) / static_cast<double>(n);
  r.bytes_per_ps = bytes_model(friction, path, r.mean_nb, contacts);
  r.achieved_bw = r.bytes_per_ps * n / (r.t_force + r.t_integrate);
  return r;
}

std::vector<long> parse_sizes(const std::string& s) {
  std::vector<long> v;
  std::stringstream ss(s);
  std::string tok;
  while (std::getline(ss, tok, ',')) v.push_back(std::stol(tok));
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out, sizes_s = "100000,1000000,10000000", host_sizes_s, backends_s = "cuda,cpu1,cpuall";
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) { std::fprintf(stderr, "%s needs a value\n", a.c_str()); std::exit(2); }
      return argv[++i];
    };
    if (a == "--out") out = next();
    else if (a == "--sizes") sizes_s = next();
    else if (a == "--host-sizes") host_sizes_s = next();
    else if (a == "--backends") backends_s = next();
    else if (a == "--quick") quick = true;
    else {
      std::fprintf(stderr,
                   "usage: lbdem_bench_dem --out FILE.json [--sizes N,N,...] [--host-sizes N,...] [--quick] "
                   "[--backends cuda,cpu1,cpuall]\n");
      return 2;
    }
  }
  if (out.empty()) { std::fprintf(stderr, "--out FILE.json is required\n"); return 2; }
  if (quick && sizes_s == "100000,1000000,10000000") sizes_s = "100000";
  const std::vector<long> sizes = parse_sizes(sizes_s);
  // The host runs stop at 1e6 unless asked (1e7 frictional needs ~20 GB and minutes per configuration).
  std::vector<long> host_sizes;
  if (!host_sizes_s.empty()) host_sizes = parse_sizes(host_sizes_s);
  else for (long s : sizes) if (s <= 1000000) host_sizes.push_back(s);

  struct Be { std::string name; Backend b; int threads; };
  std::vector<Be> bes;
  const int all = omp_get_num_procs();
  std::stringstream bs(backends_s);
  std::string tok;
  while (std::getline(bs, tok, ',')) {
    if (tok == "cuda") {
      if (cuda_unavailable_reason().empty()) bes.push_back({"cuda", Backend::Cuda, 0});
      else std::fprintf(stderr, "skipping cuda: %s\n", cuda_unavailable_reason().c_str());
    } else if (tok == "cpu1") bes.push_back({"cpu1", Backend::Host, 1});
    else if (tok == "cpuall") bes.push_back({"cpuall", Backend::Host, all});
    else { std::fprintf(stderr, "unknown backend '%s'\n", tok.c_str()); return 2; }
  }

  std::vector<Result> results;
  std::vector<std::pair<std::string, double>> copy_bws;
  std::string gpu_name;
  try {
    for (const Be& be : bes) {
      if (be.b == Backend::Host) omp_set_num_threads(be.threads);
      const double cbw = bench::copy_bandwidth(be.b, quick ? (std::size_t{1} << 27) : (std::size_t{1} << 30));
      copy_bws.push_back({be.name, cbw});
      if (be.b == Backend::Cuda) gpu_name = bench::device_name(be.b);
      std::fprintf(stderr, "[%s] copy bandwidth %.1f GB/s\n", be.name.c_str(), cbw * 1e-9);
      for (long n : (be.b == Backend::Cuda ? sizes : host_sizes)) {
        const Setup st = make_setup(n, 17);
        for (bool fr : {false, true})
          for (ForcePath path : {ForcePath::Particle, ForcePath::Pair}) {
            Result r = run_one(be.b, be.b == Backend::Cuda ? 0 : be.threads, st, fr, path, quick, cbw);
            r.backend = be.name;
            std::fprintf(stderr, "[%s] n=%ld friction=%d %s: %.3e particle-steps/s\n", be.name.c_str(), r.n, fr,
                         r.path.c_str(), r.pps);
            results.push_back(r);
          }
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }

  // Markdown table.
  const std::string cpu_name = bench::device_name(Backend::Host);
  std::printf("\nDEM throughput (commit %s; CPU: %s%s%s)\n\n", bench::git_commit().c_str(), cpu_name.c_str(),
              gpu_name.empty() ? "" : "; GPU: ", gpu_name.c_str());
  for (auto& [k, v] : copy_bws) std::printf("copy bandwidth %-7s %8.1f GB/s\n", k.c_str(), v * 1e-9);
  std::printf("\n| backend | N | friction | path | particle-steps/s | step [ms] | force [ms] | integrate [ms] | "
              "rebuild [ms] | steps/rebuild | neigh/step [ms] | nbrs | model B/p-step | %% of copy BW |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Result& r : results)
    std::printf("| %s | %ld | %s | %s | %.3e | %.3f | %.3f | %.3f | %.3f | %.1f | %.3f | %.1f | %.0f | %.0f |\n",
                r.backend.c_str(), r.n, r.friction ? "yes" : "no", r.path.c_str(), r.pps, 1e3 * r.t_step,
                1e3 * r.t_force, 1e3 * r.t_integrate, 1e3 * r.t_rebuild, r.rebuild_interval, 1e3 * r.t_neigh_step,
                r.mean_nb, r.bytes_per_ps, 100 * r.achieved_bw / r.copy_bw);
  // Speed-ups of the GPU against all host cores, per part.
  for (const Result& g : results) {
    if (g.backend != "cuda") continue;
    for (const Result& h : results)
      if (h.backend == "cpuall" && h.n == g.n && h.friction == g.friction && h.path == g.path)
        std::printf("speed-up cuda/cpuall N=%ld friction=%d %s: step %.1fx, force %.1fx, integrate %.1fx, rebuild %.1fx\n",
                    g.n, g.friction, g.path.c_str(), h.t_step / g.t_step, h.t_force / g.t_force,
                    h.t_integrate / g.t_integrate, h.t_rebuild / g.t_rebuild);
  }

  std::ofstream js(out);
  if (!js) { std::fprintf(stderr, "cannot write %s\n", out.c_str()); return 1; }
  js << "{\n" << bench::json_header("lbdem_bench_dem", gpu_name.empty() ? cpu_name : gpu_name, copy_bws)
     << ",\n  \"cpu\": \"" << bench::json_escape(cpu_name) << "\",\n  \"gpu\": \"" << bench::json_escape(gpu_name)
     << "\",\n  \"host_threads_all\": " << all << ",\n  \"quick\": " << (quick ? "true" : "false")
     << ",\n  \"results\": [\n";
  for (std::size_t i = 0; i < results.size(); ++i) {
    const Result& r = results[i];
    js << "    {\"backend\": \"" << r.backend << "\", \"threads\": " << r.threads << ", \"n\": " << r.n
       << ", \"friction\": " << (r.friction ? "true" : "false") << ", \"path\": \"" << r.path
       << "\", \"particle_steps_per_s\": " << r.pps << ", \"t_step_s\": " << r.t_step
       << ", \"t_force_s\": " << r.t_force << ", \"t_integrate_s\": " << r.t_integrate
       << ", \"t_rebuild_s\": " << r.t_rebuild << ", \"steps_per_rebuild\": " << r.rebuild_interval
       << ", \"t_neighbour_per_step_s\": " << r.t_neigh_step << ", \"mean_neighbours\": " << r.mean_nb
       << ", \"model_bytes_per_particle_step\": " << r.bytes_per_ps << ", \"achieved_Bps\": " << r.achieved_bw
       << ", \"fraction_of_copy_bandwidth\": " << r.achieved_bw / r.copy_bw << "}"
       << (i + 1 < results.size() ? ",\n" : "\n");
  }
  js << "  ]\n}\n";
  std::printf("\nwrote %s\n", out.c_str());
  return 0;
}
