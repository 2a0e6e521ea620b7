// LBM throughput benchmark: MLUPS for D2Q9/D3Q19 x fp32/fp64/fp16s/fp16c x
// AA/two-lattice on periodic boxes, against the device copy bandwidth measured
// in the same run, with the Taylor-Green error of each run beside its speed.
//
//   lbdem_bench_lbm [--out FILE.json] [--quick] [--host-only] [--sizes3d 256,512] [--sizes2d 4096,8192]
//                   [--lattices D3Q19,D2Q9] [--precisions fp32,fp64,fp16s,fp16c] [--streaming aa,two_lattice]
//
// Bytes counted per cell and step: every population read once and written
// once, 2 Q sizeof(T) with T the storage type (both schemes; the two-lattice
// scheme needs twice the memory, not more traffic per step).
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "core/buffer.hpp"
#include "lbm/solver.hpp"

using namespace lbdem;
using namespace lbdem::lbm;

namespace {

constexpr double kPi = 3.14159265358979323846;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Result {
  std::string backend, lattice, precision, streaming;
  long nx, ny, nz;
  int threads;
  double mlups, bytes_per_cell, gbs, fraction, tg_error, seconds_per_step;
};

Result run_one(Backend b, LatticeKind lk, Precision p, StreamKind sk, long N, int steps, int repeats, double copy_bw) {
  LbmSetup s;
  s.lattice = lk;
  s.precision = p;
  s.streaming = sk;
  s.collision = CollisionKind::BGK;
  s.tau = 0.6;
  const bool d3 = lk == LatticeKind::D3Q19;
  s.domain.global = s.domain.local = {N, N, d3 ? N : 1};
  auto solver = make_lbm_solver(s, b);
  const std::size_t cells = static_cast<std::size_t>(N) * N * (d3 ? N : 1);
  // Taylor-Green initial state: the error after the timed steps is reported
  // beside the speed (same code path, same precision).
  std::vector<std::uint8_t> flags(cells, 0);
  std::vector<double> rho(cells), u(3 * cells);
  const double U0 = 0.01, k = 2 * kPi / static_cast<double>(N), nu = (s.tau - 0.5) / 3;
#pragma omp parallel for
  for (long z = 0; z < (d3 ? N : 1); ++z)
    for (long y = 0; y < N; ++y)
      for (long x = 0; x < N; ++x) {
        const std::size_t i = static_cast<std::size_t>(x + N * (y + N * z));
        const double X = k * (x + 0.5), Y = k * (y + 0.5);
        u[3 * i] = -U0 * std::cos(X) * std::sin(Y);
        u[3 * i + 1] = U0 * std::sin(X) * std::cos(Y);
        u[3 * i + 2] = 0;
        rho[i] = 1.0 - 3.0 * U0 * U0 / 4 * (std::cos(2 * X) + std::cos(2 * Y));
      }
  solver->initialize(flags, rho, u);
  solver->step(4);  // warm-up
  solver->synchronize();
  std::vector<double> t;
  for (int r = 0; r < repeats; ++r) {
    if (b == Backend::Cuda) {
#if defined(LBDEM_HAVE_CUDA)
      cudaEvent_t e0, e1;
      LBDEM_CUDA_CHECK(cudaEventCreate(&e0));
      LBDEM_CUDA_CHECK(cudaEventCreate(&e1));
      LBDEM_CUDA_CHECK(cudaEventRecord(e0));
      solver->step(steps);
      LBDEM_CUDA_CHECK(cudaEventRecord(e1));
      LBDEM_CUDA_CHECK(cudaEventSynchronize(e1));
      float ms = 0;
      LBDEM_CUDA_CHECK(cudaEventElapsedTime(&ms, e0, e1));
      t.push_back(ms * 1e-3 / steps);
      cudaEventDestroy(e0);
      cudaEventDestroy(e1);
#endif
    } else {
      auto t0 = std::chrono::steady_clock::now();
      solver->step(steps);
      t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / steps);
    }
  }
  const double sps = median(t);
  // Error against the analytic 2D decay (the 3D box carries the 2D vortex,
  // uniform in z: an exact Navier-Stokes solution too).
  solver->macroscopic(rho, u);
  const long T = solver->steps_done();
  const double decay = std::exp(-2 * nu * k * k * static_cast<double>(T));
  double num = 0, den = 0;
#pragma omp parallel for reduction(+ : num, den)
  for (long z = 0; z < (d3 ? N : 1); ++z)
    for (long y = 0; y < N; ++y)
      for (long x = 0; x < N; ++x) {
        const std::size_t i = static_cast<std::size_t>(x + N * (y + N * z));
        const double X = k * (x + 0.5), Y = k * (y + 0.5);
        const double ua = -U0 * std::cos(X) * std::sin(Y) * decay, va = U0 * std::sin(X) * std::cos(Y) * decay;
        num += (u[3 * i] - ua) * (u[3 * i] - ua) + (u[3 * i + 1] - va) * (u[3 * i + 1] - va) + u[3 * i + 2] * u[3 * i + 2];
        den += ua * ua + va * va;
      }
  Result r;
  r.backend = to_string(b);
  r.lattice = to_string(lk);
  r.precision = to_string(p);
  r.streaming = to_string(sk);
  r.nx = N;
  r.ny = N;
  r.nz = d3 ? N : 1;
  r.threads = b == Backend::Host ? omp_get_max_threads() : 0;
  r.seconds_per_step = sps;
  r.mlups = static_cast<double>(cells) / sps / 1e6;
  r.bytes_per_cell = solver->bytes_per_cell_step();
  r.gbs = r.bytes_per_cell * static_cast<double>(cells) / sps / 1e9;
  r.fraction = r.gbs * 1e9 / copy_bw;
  r.tg_error = std::sqrt(num / den);
  return r;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> v;
  std::stringstream ss(s);
  std::string tok;
  while (std::getline(ss, tok, ','))
    if (!tok.empty()) v.push_back(tok);
  return v;
}

std::vector<long> parse_list(const std::string& s) {
  std::vector<long> v;
  std::stringstream ss(s);
  std::string tok;
  while (std::getline(ss, tok, ','))
    if (!tok.empty()) v.push_back(std::stol(tok));
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = "bench_lbm.json";
  bool quick = false, host_only = false;
  std::vector<long> s3 = {256, 512}, s2 = {4096, 8192}, h3 = {128}, h2 = {1024};
  std::vector<LatticeKind> lattices = {LatticeKind::D3Q19, LatticeKind::D2Q9};
  std::vector<Precision> precisions = {Precision::FP32, Precision::FP64, Precision::FP16S, Precision::FP16C};
  std::vector<StreamKind> streams = {StreamKind::AA, StreamKind::TwoLattice};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) { std::fprintf(stderr, "error: %s needs a value\n", a.c_str()); std::exit(2); }
      return argv[++i];
    };
    if (a == "--out") out = next();
    else if (a == "--quick") quick = true;
    else if (a == "--host-only") host_only = true;
    else if (a == "--sizes3d") s3 = parse_list(next());
    else if (a == "--sizes2d") s2 = parse_list(next());
    else if (a == "--host-sizes3d") h3 = parse_list(next());
    else if (a == "--host-sizes2d") h2 = parse_list(next());
    else if (a == "--lattices" || a == "--precisions" || a == "--streaming") {
      const std::string v = next();
      try {
        if (a == "--lattices") {
          lattices.clear();
          for (const auto& t : split(v)) {
            if (t != "D3Q19" && t != "D2Q9") throw std::invalid_argument("lattice '" + t + "': valid are D3Q19, D2Q9");
            lattices.push_back(t == "D3Q19" ? LatticeKind::D3Q19 : LatticeKind::D2Q9);
          }
        } else if (a == "--precisions") {
          precisions.clear();
          for (const auto& t : split(v)) precisions.push_back(precision_from_string(t));
        } else {
          streams.clear();
          for (const auto& t : split(v)) {
            if (t != "aa" && t != "two_lattice") throw std::invalid_argument("streaming '" + t + "': valid are aa, two_lattice");
            streams.push_back(t == "aa" ? StreamKind::AA : StreamKind::TwoLattice);
          }
        }
      } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s %s: %s\n", a.c_str(), v.c_str(), e.what());
        return 2;
      }
    }
    else { std::fprintf(stderr, "error: unknown option '%s' (valid: --out --quick --host-only --sizes3d --sizes2d --host-sizes3d --host-sizes2d --lattices --precisions --streaming)\n", a.c_str()); return 2; }
  }
  if (quick) { s3 = {64}; s2 = {256}; h3 = {32}; h2 = {128}; }
  std::vector<Result> res;
  std::vector<std::pair<std::string, double>> bw;
  const bool gpu = !host_only && cuda_unavailable_reason().empty();
  const std::string device = bench::device_name(gpu ? Backend::Cuda : Backend::Host);
  auto sweep = [&](Backend b, const std::vector<long>& n3, const std::vector<long>& n2, double copy) {
    for (LatticeKind lk : lattices)
      for (Precision p : precisions)
        for (StreamKind sk : streams)
          for (long N : (lk == LatticeKind::D3Q19 ? n3 : n2)) {
            LbmSetup probe;
            probe.lattice = lk;
            probe.precision = p;
            probe.streaming = sk;
            probe.domain.local = probe.domain.global = {N, N, lk == LatticeKind::D3Q19 ? N : 1};
            // rho/u staging on the device and host for the error check.
            const std::size_t need = lbm_memory_estimate(probe);
            if (need > backend_free_bytes(b) * 0.95) {
              std::printf("skip %s %s %s %s N=%ld: needs %.1f GiB\n", to_string(b), to_string(lk), to_string(p),
                          to_string(sk), N, need / 1073741824.0);
              continue;
            }
            const int steps = b == Backend::Cuda ? 20 : 6;
            Result r = run_one(b, lk, p, sk, N, steps, b == Backend::Cuda ? 7 : 3, copy);
            std::printf("%-4s %-5s %-5s %-11s %5ldx%ldx%ld  %9.1f MLUPS  %7.1f GB/s  %5.1f%% of copy  TG err %.3e\n",
                        r.backend.c_str(), r.lattice.c_str(), r.precision.c_str(), r.streaming.c_str(), r.nx, r.ny,
                        r.nz, r.mlups, r.gbs, 100 * r.fraction, r.tg_error);
            std::fflush(stdout);
            res.push_back(r);
          }
  };
  if (gpu) {
    const double c = bench::copy_bandwidth(Backend::Cuda, std::size_t(4) << 30);
    bw.push_back({"cuda", c});
    std::printf("device %s: copy bandwidth %.1f GB/s (read + write)\n", device.c_str(), c / 1e9);
    sweep(Backend::Cuda, s3, s2, c);
  }
  const double hc = bench::copy_bandwidth(Backend::Host, std::size_t(1) << 30);
  bw.push_back({"cpu", hc});
  std::printf("host (%d threads): copy bandwidth %.1f GB/s (read + write)\n", omp_get_max_threads(), hc / 1e9);
  sweep(Backend::Host, h3, h2, hc);

  std::ofstream js(out);
  js << "{\n" << bench::json_header("lbdem_bench_lbm", device, bw) << ",\n  \"host_threads\": " << omp_get_max_threads()
     << ",\n  \"quick\": " << (quick ? "true" : "false") << ",\n  \"runs\": [\n";
  for (std::size_t i = 0; i < res.size(); ++i) {
    const auto& r = res[i];
    js << "    {\"backend\": \"" << r.backend << "\", \"lattice\": \"" << r.lattice << "\", \"precision\": \"" << r.precision
       << "\", \"streaming\": \"" << r.streaming << "\", \"cells\": [" << r.nx << ", " << r.ny << ", " << r.nz
       << "], \"mlups\": " << r.mlups << ", \"bytes_per_cell_step\": " << r.bytes_per_cell << ", \"GBs\": " << r.gbs
       << ", \"fraction_of_copy\": " << r.fraction << ", \"taylor_green_rel_l2\": " << r.tg_error << "}"
       << (i + 1 < res.size() ? "," : "") << "\n";
  }
  js << "  ]\n}\n";
  std::printf("\n| backend | lattice | precision | streaming | cells | MLUPS | GB/s | %% of copy | TG rel. L2 error |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (auto& r : res)
    std::printf("| %s | %s | %s | %s | %ldx%ldx%ld | %.1f | %.1f | %.1f | %.2e |\n", r.backend.c_str(), r.lattice.c_str(),
                r.precision.c_str(), r.streaming.c_str(), r.nx, r.ny, r.nz, r.mlups, r.gbs, 100 * r.fraction, r.tg_error);
  return 0;
}
