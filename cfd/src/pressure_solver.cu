// The pressure solvers of the gas (cfd/pressure_solver.hpp): Jacobi- and multigrid-preconditioned conjugate
// gradients, every scalar on the device. This file: names, set-up, dispatch, report; the Jacobi-preconditioned
// CG is pressure_pcg.cu, the multigrid V-cycle and its CG pressure_multigrid.cu.
#include "cfd/pressure_solver.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "pressure_common.hpp"

namespace lbdem::cfd {

const char* to_string(PressureSolverKind k) {
  switch (k) {
    case PressureSolverKind::Cg: return "cg";
    case PressureSolverKind::Multigrid: return "multigrid";
  }
  return "?";
}

PressureSolverKind parse_pressure_solver(const std::string& key, const std::string& value) {
  for (PressureSolverKind k : {PressureSolverKind::Cg, PressureSolverKind::Multigrid})
    if (value == to_string(k)) return k;
  throw ConfigError(key + " = '" + value +
                    "': unknown pressure solver (valid: cg (Jacobi-preconditioned conjugate gradients), multigrid "
                    "(conjugate gradients with a multigrid V-cycle))");
}

std::vector<std::array<int, 3>> multigrid_levels(const GasGridView& g, int coarsest_cells, const std::string& key) {
  static const char* axis[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a)
    if (g.periodic[a] && g.n[a] > 1 && g.n[a] % 2 != 0)
      throw ConfigError(key + " = multigrid: the periodic axis " + axis[a] + " has " + std::to_string(g.n[a]) +
                        " cells; multigrid needs an even number (or one) along periodic axes (red-black "
                        "ordering): change the cell size or the domain, or use cg");
  std::vector<std::array<int, 3>> out{{g.n[0], g.n[1], g.n[2]}};
  std::array<int, 3> n{g.n[0], g.n[1], g.n[2]};
  while (static_cast<long long>(n[0]) * n[1] * n[2] > coarsest_cells) {
    std::array<int, 3> m = n;
    bool any = false;
    for (int a = 0; a < 3; ++a) {
      if (n[a] < 2) continue;
      // A periodic axis halves only to an even length or to one cell, so
      // that red-black ordering holds on the coarse grid too.
      if (g.periodic[a] && !(n[a] == 2 || n[a] % 4 == 0)) continue;
      m[a] = (n[a] + 1) / 2;
      any = true;
    }
    if (!any) break;
    out.push_back(m);
    n = m;
  }
  return out;
}

PressureSolver::PressureSolver(const Exec& ex, const GasGridView& g, const PressureSolverParams& p)
    : ex_(ex), g_(g), p_(p) {
  const Backend b = ex.backend();
  const Index nc = g.cells();
  for (Buffer<double>* x : {&r_, &z_, &d_, &Ad_, &diag_}) *x = Buffer<double>(b, nc);
  // Zeroed on the solver's queue, which (a second queue, lagged forces) does
  // not wait for memsets on the legacy default stream.
  d_.fill_zero(ex);
  parts1_ = std::min<Index>(nc, 4096);
  parts2_ = std::min<Index>(parts1_, 64);
  // Pairs (multigrid) use twice the slots; the device's one-launch dot its
  // block sums.
  part1_ = Buffer<double>(b, std::max<Index>(2 * parts1_, 512));
  part2_ = Buffer<double>(b, 2 * parts2_);
  scal_ = Buffer<double>(b, slot::kCount);
  scal_.fill_zero(ex);
  if (p_.kind == PressureSolverKind::Multigrid) init_multigrid();
  const char* env = std::getenv("LBDEM_PRESSURE_DEVICE_LOOP");
  device_loop_ = p_.kind == PressureSolverKind::Multigrid && ex.on_device() && p_.graphs && p_.device_loop &&
                 p_.max_iterations >= 1 && !(env && std::strcmp(env, "0") == 0);
}

PressureSolver::~PressureSolver() { release_graph(); }

int PressureSolver::launches_per_iteration() const {
  const int dot = ex_.on_device() && p_.kind == PressureSolverKind::Multigrid ? 1 : 3;
  if (p_.kind == PressureSolverKind::Cg) return 3 + 2 * dot;
  const int top = ex_.on_device() && p_.graphs ? tail_ : static_cast<int>(lv_.size());
  return 3 + 2 * dot + 4 * top + 1;
}

void PressureSolver::apply(const double* const af[3], const double* x, double* y) {
  for_each(ex_, g_.cells(), ApplyA{level_view(g_, af), x, y, nullptr});
}

void PressureSolver::solve(const double* const af[3], const double* b, double* x) {
  if (p_.kind == PressureSolverKind::Cg) {
    for_each(ex_, g_.cells(), JacobiDiag{level_view(g_, af), diag_.data()});
    solve_cg(af, b, x);
  } else {
    solve_mg(af, b, x);
  }
}

CgReport PressureSolver::last_report() const {
  ex_.synchronize();
  const std::vector<double> s = scal_.to_vector();
  CgReport r;
  r.iterations = static_cast<int>(s[slot::kIterations]);
  r.residual = std::sqrt(std::max(0.0, s[slot::kResidual]));
  r.converged = s[slot::kDone] != 0;
  return r;
}

}  // namespace lbdem::cfd
