// lbdem_bench_scaling: fluid-only steps per second on N ranks (one per GPU, or
// CPU ranks on the host backend), run under mpirun. One JSON object per run
// on stdout (rank 0), with the time per step split into
//   compute  - the overlapped step's kernels (outer slabs, inner box) without
//              any exchange,
//   serial   - whole step, then the whole exchange (nothing hidden),
//   overlap  - the production step (outer, send, inner, receive),
// so that exposed communication = overlap - compute and total communication
// = serial - compute. The one-rank run is the plain solver step.
//
//   mpirun -np 2 lbdem_bench_scaling --grid 512 512 512 --precision fp32 --transport auto
//   mpirun -np 2 lbdem_bench_scaling --per-rank 512 512 512   (weak scaling: stacked along z)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "halo/comm.hpp"
#include "halo/decomposition.hpp"
#include "halo/device.hpp"
#include "halo/transport.hpp"
#include "lbm/halo_exchange.hpp"
#include "lbm/solver.hpp"

using namespace lbdem;

namespace {

struct Args {
  std::array<long, 3> cells{256, 256, 256};
  bool weak = false;
  lbm::Precision precision = lbm::Precision::FP32;
  lbm::StreamKind streaming = lbm::StreamKind::AA;
  std::string transport = "auto";
  std::string backend = "auto";
  long steps = 200, warmup = 20;
  std::array<int, 3> dims{0, 0, 0};
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr,
               "lbdem_bench_scaling: %s\n"
               "usage: lbdem_bench_scaling [--grid NX NY NZ | --per-rank NX NY NZ] [--precision fp32|fp64]\n"
               "       [--streaming aa|two_lattice] [--transport auto|host_mpi|device_mpi|nccl]\n"
               "       [--backend cuda|cpu|auto] [--steps N] [--warmup N] [--dims A B C]\n",
               why);
  std::exit(2);
}

Args parse(int argc, char** argv) {
  Args a;
  auto need = [&](int i, int k) {
    if (i + k >= argc) usage((std::string(argv[i]) + " needs " + std::to_string(k) + " values").c_str());
  };
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--grid" || k == "--per-rank") {
      need(i, 3);
      for (int j = 0; j < 3; ++j) a.cells[static_cast<std::size_t>(j)] = std::atol(argv[i + 1 + j]);
      a.weak = k == "--per-rank";
      i += 3;
    } else if (k == "--dims") {
      need(i, 3);
      for (int j = 0; j < 3; ++j) a.dims[static_cast<std::size_t>(j)] = std::atoi(argv[i + 1 + j]);
      i += 3;
    } else if (k == "--precision") {
      need(i, 1);
      a.precision = std::string(argv[++i]) == "fp64" ? lbm::Precision::FP64 : lbm::Precision::FP32;
    } else if (k == "--streaming") {
      need(i, 1);
      a.streaming = std::string(argv[++i]) == "two_lattice" ? lbm::StreamKind::TwoLattice : lbm::StreamKind::AA;
    } else if (k == "--transport") {
      need(i, 1);
      a.transport = argv[++i];
    } else if (k == "--backend") {
      need(i, 1);
      a.backend = argv[++i];
    } else if (k == "--steps") {
      need(i, 1);
      a.steps = std::atol(argv[++i]);
    } else if (k == "--warmup") {
      need(i, 1);
      a.warmup = std::atol(argv[++i]);
    } else {
      usage(("unknown argument " + k).c_str());
    }
  }
  for (long c : a.cells)
    if (c < 2) usage("cells must be >= 2 per axis");
  return a;
}

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

}  // namespace

int run(int argc, char** argv);

int main(int argc, char** argv) {
  // A refusal (a transport that cannot run here, a grid too small for the
  // ranks) ends every rank with one line, not an abort trace.
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    const halo::Comm& comm = halo::Comm::world();
    if (comm.root()) std::fprintf(stderr, "lbdem_bench_scaling: %s\n", e.what());
    if (comm.distributed()) comm.abort(2);
    return 2;
  }
}

int run(int argc, char** argv) {
  const Args a = parse(argc, argv);
  const halo::Comm& comm = halo::Comm::world();
  const Backend backend = resolve_backend(a.backend);
  if (backend == Backend::Cuda) halo::select_device(comm);
  const int N = comm.size();

  // Whole grid: given (strong), or per-rank cells stacked along z (weak).
  std::array<long, 3> global = a.cells;
  std::array<int, 3> dims = a.dims;
  if (a.weak) {
    if (dims == std::array<int, 3>{0, 0, 0}) dims = {1, 1, N};
    for (int ax = 0; ax < 3; ++ax) global[static_cast<std::size_t>(ax)] *= dims[static_cast<std::size_t>(ax)];
  }
  lbm::LbmSetup s;
  s.lattice = lbm::LatticeKind::D3Q19;
  s.precision = a.precision;
  s.streaming = a.streaming;
  s.tau = 0.6;
  s.domain = Grid::whole(global);
  const halo::Decomposition dec = halo::decompose(s.domain, N, dims, "--dims");
  s.domain = N > 1 ? dec.piece(s.domain, comm.rank()) : s.domain;

  // A periodic box in slow uniform motion: the kernels do the work of any
  // fluid cell; ghost cells flagged as ghosts.
  const GridView g = s.domain.view();
  const auto n = static_cast<std::size_t>(g.n);
  std::vector<std::uint8_t> flags(n, 0);
  const CellBox o = s.domain.owned();
  for (int z = 0; z < g.nz; ++z)
    for (int y = 0; y < g.ny; ++y)
      for (int x = 0; x < g.nx; ++x) {
        const bool own = x >= o.lo[0] && x < o.lo[0] + o.ext[0] && y >= o.lo[1] && y < o.lo[1] + o.ext[1] &&
                         z >= o.lo[2] && z < o.lo[2] + o.ext[2];
        if (!own) flags[static_cast<std::size_t>(g.index(x, y, z))] = lbm::kGhostFlag;
      }
  std::vector<double> rho(n, 1.0), u(3 * n, 0.0);
  for (std::size_t i = 0; i < n; ++i) u[3 * i] = 0.01;
  auto solver = lbm::make_lbm_solver(s, backend);
  solver->initialize(flags, rho, u);
  flags.clear();
  flags.shrink_to_fit();
  rho = {};
  u = {};

  std::unique_ptr<halo::Transport> tr;
  std::unique_ptr<lbm::FluidHalo> fh;
  if (N > 1) {
    tr = halo::make_transport(halo::parse_transport(a.transport, "--transport"), comm, backend);
    fh = std::make_unique<lbm::FluidHalo>(*solver, dec, comm.rank(), *tr);
    fh->fill();
  }

  // Time `steps` steps in a mode; the slowest rank's time counts.
  auto run = [&](lbm::FluidHalo::Mode mode, long steps) {
    if (fh) fh->set_mode(mode);
    comm.barrier();
    solver->synchronize();
    comm.barrier();
    const double t0 = now();
    if (fh) fh->step(steps);
    else solver->step(steps);
    solver->synchronize();
    const double dt = now() - t0;
    comm.barrier();
    return comm.max(dt) / static_cast<double>(steps);
  };
  using M = lbm::FluidHalo::Mode;
  run(M::Overlap, a.warmup);
  const double t_overlap = run(M::Overlap, a.steps);
  const double t_compute = fh ? run(M::ComputeOnly, a.steps) : t_overlap;
  const double t_serial = fh ? run(M::Serial, a.steps) : t_overlap;
  const double t_overlap2 = fh ? run(M::Overlap, a.steps) : t_overlap;  // drift check
  const double t_step = std::min(t_overlap, t_overlap2);

  const double cells = static_cast<double>(global[0]) * global[1] * global[2];
  const double mlups = cells / t_step / 1e6;
  const double bw = comm.root() ? bench::copy_bandwidth(backend, std::size_t{1} << 30) : 0;
  const double bytes_cell = solver->bytes_per_cell_step();
  const double per_rank_bw = cells / N * bytes_cell / t_step;
  const long halo_bytes = fh ? static_cast<long>(fh->times().bytes_per_step) : 0;
  const long max_halo = comm.max(halo_bytes);
  const int messages = fh ? fh->times().messages : 0;
  if (comm.root()) {
    std::printf("{\"benchmark\": \"scaling\", \"device\": \"%s\", \"date\": \"%s\", \"commit\": \"%s\", "
                "\"ranks\": %d, \"dims\": [%d, %d, %d], \"mode\": \"%s\", \"grid\": [%ld, %ld, %ld], "
                "\"precision\": \"%s\", \"streaming\": \"%s\", \"backend\": \"%s\", \"transport\": \"%s\", "
                "\"steps\": %ld, \"t_step_s\": %.6e, \"t_compute_s\": %.6e, \"t_serial_s\": %.6e, "
                "\"exposed_comm_s\": %.6e, \"comm_s\": %.6e, \"mlups\": %.1f, \"halo_bytes_per_rank\": %ld, "
                "\"messages_per_rank\": %d, \"copy_bandwidth_GBs\": %.1f, \"fraction_of_copy_bw\": %.4f}\n",
                bench::json_escape(bench::device_name(backend)).c_str(), bench::utc_date().c_str(),
                bench::git_commit().c_str(), N, dec.dims[0], dec.dims[1], dec.dims[2], a.weak ? "weak" : "strong",
                global[0], global[1], global[2], lbm::to_string(a.precision), lbm::to_string(a.streaming),
                to_string(backend), tr ? halo::to_string(tr->kind()) : "none", a.steps, t_step, t_compute, t_serial,
                t_step - t_compute, t_serial - t_compute, mlups, max_halo, messages, bw / 1e9,
                bw > 0 ? per_rank_bw / bw : 0.0);
    std::fflush(stdout);
  }
  return 0;
}
