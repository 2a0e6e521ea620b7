#pragma once
// The pressure equation of the gas solver (cfd/gas_solver.hpp) and its two
// solvers.
//
// The operator, on cell c of the gas grid, with one coefficient per face
// (a[f] = eps_f c_f / h^2, c = dt / (rho (1 + dt beta / (eps rho))), set by
// the predictor):
//
//   (A x)_c = sum over the six faces f of c:  a[f] (x_c - x_nb(f)),
//
// x_nb = 0 across a non-periodic boundary face (a pressure outlet carries
// a[f] > 0 there: Dirichlet, its value moved to the right-hand side; walls
// and inlets carry a[f] = 0: Neumann), periodic axes wrap. A is symmetric
// positive definite whenever one face is an outlet.
//
// Solvers (`gas.pressure_solver.type`):
//  * cg: conjugate gradients preconditioned by the diagonal (Jacobi);
//  * multigrid: conjugate gradients preconditioned by one geometric multigrid
//    V-cycle: cell-centred coarsening by two along each axis that allows it,
//    piecewise-constant transfer (restriction = transpose of prolongation),
//    coarse face coefficients the sum of the fine ones they cover over the
//    coarsening factor normal to the face (the coarse grid's own
//    discretisation of div(k grad p): the aggregation Galerkin operator
//    P^T A P halved, never less than half of it, so the V-cycle stays a
//    convergent symmetric positive definite preconditioner), red-black
//    Gauss-Seidel smoothing (one red-then-black sweep before the coarse
//    correction, its adjoint black-then-red after it: a symmetric cycle, as
//    CG requires), a symmetric Gauss-Seidel sweep on the coarsest grid (one
//    cell where every axis coarsens that far: exact).
// Both stop on the same measure: the diagonally scaled residual
// r^T D^-1 r <= tol^2 b^T D^-1 b (D the diagonal, counting every face), so
// the choice changes the cost and not what "converged" means.
//
// All scalars stay on the device; iterations after convergence are skipped
// there by a flag. The host reads that flag every `poll_every` iterations, or
// (multigrid on the device, `device_loop`) never: a CUDA graph's WHILE node
// repeats `poll_every` iterations until the flag or the iteration limit
// stops it, so a solve needs no host synchronisation.
#include <array>
#include <string>
#include <vector>

#include "cfd/gas_grid.hpp"
#include "core/buffer.hpp"
#include "core/hd.hpp"

namespace lbdem::cfd {

enum class PressureSolverKind { Cg, Multigrid };

const char* to_string(PressureSolverKind k);
// "cg" or "multigrid"; anything else throws ConfigError naming `key`.
PressureSolverKind parse_pressure_solver(const std::string& key, const std::string& value);

struct PressureSolverParams {
  PressureSolverKind kind = PressureSolverKind::Cg;
  int max_iterations = 2000;
  double tolerance = 1e-10;  // on r^T D^-1 r, relative to b^T D^-1 b (square root)
  // How often (iterations) the host asks the device whether the solve has
  // converged; multigrid asks first at the last solve's iteration count.
  int poll_every = 25;
  // Multigrid: coarsening stops at this many cells or fewer (or where no axis
  // can be halved); the coarsest grid takes `coarse_sweeps` symmetric
  // Gauss-Seidel sweeps (on one cell: the exact solution). Coarsening to one
  // cell costs nothing on the device (the coarse levels share one kernel) and
  // keeps the serial coarsest solve to a single update.
  int coarsest_cells = 1;
  int coarse_sweeps = 1;
  // Multigrid on the device, fewer launches: the start of a solve and the
  // iterations between two polls run as CUDA graphs (captured once; the kernels read every scalar
  // from device memory, so a replay is the same work as launching them one
  // by one), and the V-cycle's levels of at most 1024 cells in one kernel of
  // one block. Off: every kernel launched on its own (the same arithmetic).
  bool graphs = true;
  // Multigrid on the device with `graphs`: the iterations' loop on the device
  // (a conditional WHILE node around a chunk of `poll_every` iterations, CUDA
  // 12.4+), no host read per solve. The iterations and their bits are those of
  // the host-polled loop: both stop at the first chunk end where
  // keep_iterating() is false, and the chunks the host loop runs past
  // convergence change nothing (every kernel returns at once once the solve is
  // done). The environment variable LBDEM_PRESSURE_DEVICE_LOOP=0 turns it off
  // (the host-polled loop, for comparison).
  bool device_loop = true;
};

// Whether the multigrid CG goes on after a chunk of iterations, from the
// solver's device-held flag `done` (1 once converged) and the iterations
// taken: the test of the host-polled loop and of the device loop alike.
LBDEM_HD inline bool keep_iterating(double done, double iterations, int max_iterations) {
  return done == 0 && iterations < static_cast<double>(max_iterations);
}

struct CgReport {
  int iterations = 0;
  double residual = 0;  // final sqrt(r^T D^-1 r / b^T D^-1 b)
  bool converged = false;
};

// Grid sizes of the multigrid hierarchy for grid g (level 0 first). Throws
// ConfigError naming `key` where multigrid cannot run on g: a periodic axis
// with an odd number of cells other than one (no red-black ordering).
std::vector<std::array<int, 3>> multigrid_levels(const GasGridView& g, int coarsest_cells,
                                                 const std::string& key = "gas.pressure_solver.type");

class PressureSolver {
 public:
  PressureSolver(const Exec& ex, const GasGridView& g, const PressureSolverParams& p);
  ~PressureSolver();
  PressureSolver(const PressureSolver&) = delete;
  PressureSolver& operator=(const PressureSolver&) = delete;

  // Solves A x = b for the face coefficients af[0..2] (face boxes of
  // (n_a + 1) x the other extents, x-fastest, face i the lower face of cell
  // i), x holding the initial guess. Asynchronous on the device apart from the
  // polls.
  void solve(const double* const af[3], const double* b, double* x);
  // y = A x.
  void apply(const double* const af[3], const double* x, double* y);
  // Synchronises and reads the last solve's report.
  CgReport last_report() const;
  const PressureSolverParams& params() const { return p_; }
  int levels() const { return static_cast<int>(lv_.size()) + 1; }
  // Kernel launches per iteration and per solve outside the iterations (the
  // device's cost on these small grids is mostly launches).
  int launches_per_iteration() const;

  struct Level {  // a coarse level of the multigrid hierarchy
    GasGridView g;
    int r[3];  // coarsening factor from the finer level
    Buffer<double> af[3], dg, b, x;
  };

 private:
  void init_multigrid();
  void solve_cg(const double* const af[3], const double* b, double* x);
  void solve_mg(const double* const af[3], const double* b, double* x);
  void setup_mg(const Exec& ex, const double* const af[3]);
  void start_mg(const Exec& ex, const double* const af[3], const double* b, double* x);
  void vcycle(const Exec& ex, const double* const af[3], const double* b, double* x);
  void dot(const Exec& ex, const double* u, const double* w, const double* diag, int stage);
  void iterate_mg(const Exec& ex, const double* const af[3], double* x, int count);
  void run_graph(int k, const double* const af[3], const double* b, double* x, int chunk);
  void release_graph() noexcept;

  Exec ex_;
  GasGridView g_;
  PressureSolverParams p_;
  Buffer<double> r_, z_, d_, Ad_, diag_, part1_, part2_, scal_;
  Index parts1_ = 1, parts2_ = 1;
  // Multigrid: level 0's true diagonal (faces to the cell itself left out),
  // the coarse levels.
  Buffer<double> dg0_;
  std::vector<Level> lv_;
  Buffer<unsigned int> ticket_;  // one-launch dot products on the device
  int expected_iterations_ = 0;
  int tail_ = 0;  // the first level of the V-cycle's one-block kernel (device)
  // Bytes of shared memory of that kernel when its levels are copied there
  // (0: it reads them in global memory). LBDEM_PRESSURE_TAIL_SHARED=0 keeps
  // them in global memory (the same bits; for comparison).
  int tail_shared_bytes_ = 0;
  // Restrict's fine residuals on the levels above the tail (device, graphs on):
  // one kernel over the fine cells, then the coarse sums (the same bits as one
  // kernel over the coarse cells, which leaves most of the GPU idle).
  Buffer<double> rs_;
  // The device's CUDA graphs (0: the start of a solve, 1: `poll_every`
  // iterations, 2: those iterations in a device-side loop), the stream they
  // were captured on, and the pointers each was captured with (unused by a
  // build without CUDA).
  [[maybe_unused]] void* graph_exec_[3] = {nullptr, nullptr, nullptr};
  [[maybe_unused]] void* cap_stream_ = nullptr;
  [[maybe_unused]] const void* graph_key_[3][5] = {};
  bool device_loop_ = false;  // device_loop in effect (multigrid, CUDA, graphs, not turned off)
};

}  // namespace lbdem::cfd
