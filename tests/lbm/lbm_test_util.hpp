#pragma once
// Small scene builders for the LBM tests (lattice units throughout).
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "lbm/solver.hpp"

namespace lbdem::test {

struct Scene {
  lbm::LbmSetup setup;
  std::vector<std::uint8_t> flags;
  std::vector<double> rho, u;
};

inline Scene make_scene(lbm::LatticeKind lk, long nx, long ny, long nz) {
  Scene s;
  s.setup.lattice = lk;
  s.setup.domain.global = s.setup.domain.local = {nx, ny, nz};
  const auto n = static_cast<std::size_t>(nx * ny * nz);
  s.flags.assign(n, 0);
  s.rho.assign(n, 1.0);
  s.u.assign(3 * n, 0.0);
  return s;
}

inline std::size_t cell_index(const Scene& s, long x, long y, long z) {
  const auto& d = s.setup.domain.local;
  return static_cast<std::size_t>(x + d[0] * (y + d[1] * z));
}

// Marks the layers y = 0 and y = ny-1 as boundary `id_lo`/`id_hi` (1-based).
inline void add_y_walls(Scene& s, int id_lo, int id_hi) {
  const auto& d = s.setup.domain.local;
  for (long z = 0; z < d[2]; ++z)
    for (long x = 0; x < d[0]; ++x) {
      s.flags[cell_index(s, x, 0, z)] = static_cast<std::uint8_t>(id_lo);
      s.flags[cell_index(s, x, d[1] - 1, z)] = static_cast<std::uint8_t>(id_hi);
    }
}

inline int add_boundary(Scene& s, lbm::BoundaryKind k, std::array<double, 3> u = {0, 0, 0}, double rho = 1.0) {
  auto& bt = s.setup.boundaries;
  const int i = bt.count++;
  bt.kind[i] = k;
  for (int a = 0; a < 3; ++a) bt.u[i][a] = u[static_cast<std::size_t>(a)];
  bt.rho[i] = rho;
  return i + 1;
}

inline void randomize(Scene& s, double drho, double du, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (auto& r : s.rho) r = 1.0 + drho * uni(rng);
  for (auto& v : s.u) v = du * uni(rng);
  if (s.setup.lattice == lbm::LatticeKind::D2Q9)
    for (std::size_t i = 0; i < s.rho.size(); ++i) s.u[3 * i + 2] = 0;
}

inline std::unique_ptr<lbm::LbmSolver> start(const Scene& s, Backend b) {
  auto solver = lbm::make_lbm_solver(s.setup, b);
  solver->initialize(s.flags, s.rho, s.u);
  return solver;
}

inline double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

}  // namespace lbdem::test
