// The pressure solvers of the gas (cfd/pressure_solver.hpp).
//  * A variable-coefficient Poisson problem with a known discrete solution
//    (b = A x* for a chosen x*): coefficients k = eps c that jump by 100
//    between a dense "bed" and the freeboard, as the drag makes them, plus
//    ±30 % noise; walls and an inlet (Neumann), a pressure outlet
//    (Dirichlet). Jacobi-PCG and multigrid-PCG, both to tolerance 1e-13 on
//    the scaled residual, reproduce x* to 1e-9 of its range (the operator's
//    condition number, ~1e4 here, times the tolerance) and each other to
//    1e-10; multigrid needs at least 5x fewer iterations.
//  * The same with periodic axes (one of eight cells, one of one cell: the
//    wrap and the self-coupling that cancels).
//  * The gas solver with either solver on a bed of moving particles gives the
//    same pressure to 1e-10 of its range after several steps.
//  * On the device, the CUDA graphs and the one-block coarse levels give the
//    same bits as launching every kernel on its own, and so does the loop of
//    iterations on the device (no host poll) against the host-polled one,
//    converged or stopped by the iteration limit; the test that ends both
//    loops (keep_iterating) is checked on every backend.
//  * Bad input names the key.
#include <array>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "cfd/gas_solver.hpp"
#include "cfd/pressure_solver.hpp"
#include "common/backends.hpp"

using namespace lbdem;
using namespace lbdem::cfd;

namespace {

Index faces(const GasGridView& g, int a) {
  Index n = 1;
  for (int d = 0; d < 3; ++d) n *= g.n[d] + (d == a ? 1 : 0);
  return n;
}

// A pressure system on grid g: walls on the non-periodic x and y faces, an
// inlet (Neumann) at z-, an outlet (Dirichlet, half-cell distance) at z+.
struct System {
  GasGridView g;
  Buffer<double> af[3], x, b;
  std::vector<double> xs;  // the known solution

  System(Backend be, const GasGridView& grid, unsigned seed) : g(grid) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> noise(0.7, 1.3), val(-1, 1);
    const double h = 0.002;
    // k: 1e-2 in the lowest 30 % (a bed), 1 above.
    auto k_at = [&](double z) { return z < 0.3 * g.n[2] ? 1e-2 : 1.0; };
    for (int a = 0; a < 3; ++a) {
      const int m0 = g.n[0] + (a == 0), m1 = g.n[1] + (a == 1), m2 = g.n[2] + (a == 2);
      std::vector<double> c(static_cast<std::size_t>(faces(g, a)), 0.0);
      for (int k = 0; k < m2; ++k)
        for (int j = 0; j < m1; ++j)
          for (int i = 0; i < m0; ++i) {
            const int f[3] = {i, j, k};
            double zc = k + (a == 2 ? 0.0 : 0.5);
            double v = k_at(zc) * noise(rng) / (h * h);
            const bool boundary = f[a] == 0 || f[a] == g.n[a];
            if (boundary) {
              if (g.periodic[a]) {
                if (f[a] == g.n[a]) v = 0;  // the periodic axis's duplicate face
              } else if (a == 2 && f[a] == g.n[a]) {
                v *= 2;  // outlet: Dirichlet at half a cell
              } else {
                v = 0;  // walls, inlet
              }
            }
            c[static_cast<std::size_t>(i + m0 * (j + static_cast<Index>(m1) * k))] = v;
          }
      af[a] = Buffer<double>(be, faces(g, a));
      af[a].copy_from_host(c);
    }
    const Index n = g.cells();
    xs.resize(static_cast<std::size_t>(n));
    for (Index c = 0; c < n; ++c) {
      int i, j, k;
      g.coords(c, i, j, k);
      xs[static_cast<std::size_t>(c)] = 50.0 * (g.n[2] - k) / g.n[2] + std::sin(0.7 * i) * std::cos(0.3 * k) + 0.1 * val(rng);
    }
    x = Buffer<double>(be, n);
    b = Buffer<double>(be, n);
  }
  const double* coef(int a) const { return af[a].data(); }
};

struct Result {
  std::vector<double> x;
  CgReport rep;
};

Result solve(const Exec& ex, System& s, PressureSolverKind kind, double tol, bool graphs = true,
             bool device_loop = true, int max_iterations = 5000) {
  PressureSolverParams p;
  p.kind = kind;
  p.graphs = graphs;
  p.device_loop = device_loop;
  p.tolerance = tol;
  p.max_iterations = max_iterations;
  p.poll_every = 5;
  PressureSolver ps(ex, s.g, p);
  const double* af[3] = {s.coef(0), s.coef(1), s.coef(2)};
  s.x.copy_from_host(s.xs);
  ps.apply(af, s.x.data(), s.b.data());  // b = A x*
  s.x.fill_zero();
  ps.solve(af, s.b.data(), s.x.data());
  Result r;
  r.rep = ps.last_report();
  r.x = s.x.to_vector();
  std::printf("[ pressure ] %s %dx%dx%d: %d levels, %d iterations, residual %.2e, %d launches per iteration\n",
              to_string(kind), s.g.n[0], s.g.n[1], s.g.n[2], ps.levels(), r.rep.iterations, r.rep.residual,
              ps.launches_per_iteration());
  return r;
}

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}
double range(const std::vector<double>& a) {
  const auto [lo, hi] = std::minmax_element(a.begin(), a.end());
  return *hi - *lo;
}

class Pressure : public ::testing::TestWithParam<Backend> {};

void check_known_solution(const Exec& ex, const GasGridView& g, int min_ratio) {
  System s(ex.backend(), g, 7);
  const double tol = 1e-13;
  const Result cg = solve(ex, s, PressureSolverKind::Cg, tol);
  const Result mg = solve(ex, s, PressureSolverKind::Multigrid, tol);
  ASSERT_TRUE(cg.rep.converged);
  ASSERT_TRUE(mg.rep.converged);
  EXPECT_LE(cg.rep.residual, tol);
  EXPECT_LE(mg.rep.residual, tol);
  const double R = range(s.xs);
  EXPECT_LT(max_abs_diff(cg.x, s.xs), 1e-9 * R);
  EXPECT_LT(max_abs_diff(mg.x, s.xs), 1e-9 * R);
  EXPECT_LT(max_abs_diff(mg.x, cg.x), 1e-10 * R);
  EXPECT_GE(cg.rep.iterations, min_ratio * mg.rep.iterations)
      << "cg " << cg.rep.iterations << " multigrid " << mg.rep.iterations;
}

TEST_P(Pressure, VariableCoefficientPoissonKnownSolution) {
  const Exec ex(GetParam());
  GasGridView g;
  g.n[0] = 22; g.n[1] = 5; g.n[2] = 100;  // Mueller's bed grid
  g.h = 0.002;
  check_known_solution(ex, g, 5);
}

TEST_P(Pressure, PeriodicAxesKnownSolution) {
  const Exec ex(GetParam());
  GasGridView g;
  g.n[0] = 8; g.n[1] = 1; g.n[2] = 40;
  g.periodic[0] = g.periodic[1] = true;
  g.h = 0.002;
  check_known_solution(ex, g, 3);
}

// On the device the multigrid's iterations run as CUDA graphs and its coarse
// levels in one kernel of one block: the same functors in the same order as
// launching each kernel on its own, so the same bits (on the host both are the
// plain loop).
TEST_P(Pressure, LaunchSavingsGiveTheSameBits) {
  const Exec ex(GetParam());
  GasGridView g;
  g.n[0] = 22; g.n[1] = 5; g.n[2] = 100;
  g.h = 0.002;
  System s(ex.backend(), g, 11);
  const Result fused = solve(ex, s, PressureSolverKind::Multigrid, 1e-12, true);
  const Result plain = solve(ex, s, PressureSolverKind::Multigrid, 1e-12, false);
  ASSERT_TRUE(fused.rep.converged);
  EXPECT_EQ(fused.rep.iterations, plain.rep.iterations);
  EXPECT_EQ(fused.x, plain.x);
  // The one-block tail of the V-cycle (on the device: in shared memory) from
  // level 0 (a grid of at most 1,024 cells) and from level 2 (Link's bed).
  // The host has no tail (its fused and plain paths are one path).
  for (const auto& n : {std::array<int, 3>{10, 6, 16}, std::array<int, 3>{30, 10, 128}}) {
    if (!ex.on_device()) break;
    GasGridView h = g;
    for (int a = 0; a < 3; ++a) h.n[a] = n[static_cast<std::size_t>(a)];
    System t(ex.backend(), h, 13);
    const Result tf = solve(ex, t, PressureSolverKind::Multigrid, 1e-12, true);
    const Result tp = solve(ex, t, PressureSolverKind::Multigrid, 1e-12, false);
    ASSERT_TRUE(tf.rep.converged) << n[0] << "x" << n[1] << "x" << n[2];
    EXPECT_EQ(tf.rep.iterations, tp.rep.iterations);
    EXPECT_EQ(tf.x, tp.x) << n[0] << "x" << n[1] << "x" << n[2];
  }
  // The host-polled loop of graphs (polls every poll_every = 5 iterations,
  // past convergence by up to 4 no-op iterations) against the device loop.
  const Result polled = solve(ex, s, PressureSolverKind::Multigrid, 1e-12, true, false);
  EXPECT_EQ(polled.rep.iterations, fused.rep.iterations);
  EXPECT_EQ(polled.x, fused.x);
  // Stopped by the limit before converging (3, not a multiple of poll_every:
  // on the device both loops run one whole chunk of 5), both ways the same
  // bits and count.
  const Result cut_dev = solve(ex, s, PressureSolverKind::Multigrid, 1e-12, true, true, 3);
  const Result cut_host = solve(ex, s, PressureSolverKind::Multigrid, 1e-12, true, false, 3);
  EXPECT_FALSE(cut_dev.rep.converged);
  EXPECT_EQ(cut_dev.rep.iterations, cut_host.rep.iterations);
  EXPECT_EQ(cut_dev.x, cut_host.x);
}

// The test after each chunk of iterations, shared by the host-polled loop and
// the device loop: on while not converged and below the limit.
TEST(PressureLoop, KeepIteratingStopsAtConvergenceOrTheLimit) {
  EXPECT_TRUE(keep_iterating(0, 0, 1));
  EXPECT_TRUE(keep_iterating(0, 9, 10));
  EXPECT_FALSE(keep_iterating(0, 10, 10));
  EXPECT_FALSE(keep_iterating(0, 12, 10));
  EXPECT_FALSE(keep_iterating(1, 3, 10));
  EXPECT_FALSE(keep_iterating(1, 0, 10));
}

TEST(PressureLevels, CoarsensEachAxisThatAllows) {
  GasGridView g;
  g.n[0] = 22; g.n[1] = 5; g.n[2] = 100;
  const auto l = multigrid_levels(g, 16);
  ASSERT_EQ(l.size(), 5u);
  EXPECT_EQ(l[1], (std::array<int, 3>{11, 3, 50}));
  EXPECT_EQ(l[2], (std::array<int, 3>{6, 2, 25}));
  EXPECT_EQ(l[4], (std::array<int, 3>{2, 1, 7}));
  // A periodic axis halves only to an even length or to one cell.
  g.n[0] = 12; g.periodic[0] = true;
  const auto p = multigrid_levels(g, 1);
  EXPECT_EQ(p[1][0], 6);
  EXPECT_EQ(p[2][0], 6);
}

TEST(PressureLevels, BadInputNamesKey) {
  try {
    parse_pressure_solver("gas.pressure_solver.type", "jacobi");
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("gas.pressure_solver.type"), std::string::npos) << m;
    EXPECT_NE(m.find("jacobi"), std::string::npos) << m;
    EXPECT_NE(m.find("multigrid"), std::string::npos) << m;
  }
  EXPECT_EQ(parse_pressure_solver("k", "cg"), PressureSolverKind::Cg);
  EXPECT_EQ(parse_pressure_solver("k", "multigrid"), PressureSolverKind::Multigrid);
  GasGridView g;
  g.n[0] = 5; g.n[1] = 1; g.n[2] = 10;
  g.periodic[0] = true;
  GasParams p;
  p.faces[0].kind = p.faces[1].kind = FaceKind::Periodic;
  p.faces[5].kind = FaceKind::Outlet;
  p.pressure_solver = PressureSolverKind::Multigrid;
  try {
    validate(p, g);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("gas.pressure_solver"), std::string::npos) << m;
    EXPECT_NE(m.find("5 cells"), std::string::npos) << m;
  }
  p.pressure_solver = PressureSolverKind::Cg;
  EXPECT_NO_THROW(validate(p, g));
}

// Particles in a bed, moving, uploaded for each step.
struct Bed {
  Backend b;
  std::vector<dem::Real4> pos, vel;
  Buffer<dem::Real4> dpos, dvel, dforce;
  Bed(Backend be, const GasGridView& g, int count, unsigned seed) : b(be) {
    std::mt19937 rng(seed);
    const double r = 0.6e-3;
    std::uniform_real_distribution<double> ux(r, g.n[0] * g.h - r), uy(r, g.n[1] * g.h - r),
        uz(r, 0.4 * g.n[2] * g.h), uv(-0.2, 0.2);
    for (int i = 0; i < count; ++i) {
      pos.push_back(dem::Real4{ux(rng), uy(rng), uz(rng), r});
      vel.push_back(dem::Real4{uv(rng), uv(rng), uv(rng), 0});
    }
    dpos = Buffer<dem::Real4>(be, count);
    dvel = Buffer<dem::Real4>(be, count);
    dforce = Buffer<dem::Real4>(be, count);
  }
  dem::ParticleView upload() {
    dpos.copy_from_host(pos);
    dvel.copy_from_host(vel);
    dem::ParticleView v;
    v.pos_r = dpos.data();
    v.vel_im = dvel.data();
    v.ext_force = dforce.data();
    v.n = static_cast<Index>(pos.size());
    return v;
  }
  void move(double dt) {
    for (std::size_t i = 0; i < pos.size(); ++i) {
      pos[i].x += dt * vel[i].x;
      pos[i].y += dt * vel[i].y;
      pos[i].z += dt * vel[i].z;
    }
  }
};

TEST_P(Pressure, GasStepMultigridEqualsCg) {
  const Exec ex(GetParam());
  GasGridView g;
  g.n[0] = 10; g.n[1] = 4; g.n[2] = 30;
  g.h = 0.002;
  GasParams p;
  p.rho = 1.225;
  p.mu = 1.8e-5;
  p.dt = 1.5e-4;
  p.deposition = Deposition::Linear;
  for (int s = 0; s < 4; ++s) p.faces[static_cast<std::size_t>(s)].kind = FaceKind::NoSlipWall;
  p.faces[4].kind = FaceKind::Inlet;
  p.faces[4].inflow = 0.6;
  p.faces[5].kind = FaceKind::Outlet;
  p.cg_tolerance = 1e-13;
  p.cg_poll_every = 3;
  GasParams q = p;
  q.pressure_solver = PressureSolverKind::Multigrid;
  GasSolver cg(ex, g, p), mg(ex, g, q);
  Bed bed(ex.backend(), g, 600, 3);
  int it_cg = 0, it_mg = 0;
  for (int step = 0; step < 5; ++step) {
    const dem::ParticleView v = bed.upload();
    cg.step(v);
    mg.step(v);
    it_cg += cg.last_solve().iterations;
    it_mg += mg.last_solve().iterations;
    ASSERT_TRUE(cg.last_solve().converged);
    ASSERT_TRUE(mg.last_solve().converged);
    bed.move(p.dt);
  }
  const std::vector<double> pc = cg.pressure().to_vector(), pm = mg.pressure().to_vector();
  const double R = range(pc);
  EXPECT_GT(R, 1.0);  // a bed's pressure drop: tens of Pa
  EXPECT_LT(max_abs_diff(pc, pm), 1e-10 * R) << max_abs_diff(pc, pm) / R;
  std::printf("[ pressure ] gas steps: cg %d, multigrid %d iterations over 5 steps\n", it_cg, it_mg);
  EXPECT_GE(it_cg, 3 * it_mg);
}

INSTANTIATE_TEST_SUITE_P(All, Pressure, ::testing::ValuesIn(lbdem::test::backends()), lbdem::test::backend_name);

}  // namespace
