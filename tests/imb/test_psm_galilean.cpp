// Galilean invariance of the PSM coupling: a sphere held fixed in a fluid
// driven by a body force g (run A), and the same sphere carried at a constant
// velocity V through a fluid that starts moving at V (run B: A's initial state
// seen from a frame moving at -V), give the same flow relative to the sphere.
// Run B remaps the sphere every step, so the test also covers the moving-
// boundary path (fractions changing each step, solid velocity V in the NEBB
// operator, cells covered and uncovered).
//
// Measure: the superficial relative velocity U = sum over cells of
// (1 - eps)(u - V) / cells (Sangani & Acrivos' mean velocity over the period,
// the solid moving at V) and the drag coefficient K = F / (6 pi mu a U).
// The mean drag alone would not do: at steady state the momentum balance
// makes it equal the injected body force in both runs whatever the flow.
// Both runs are compared at the same times, averaged over an integer number
// of cell crossings of run B (the moving sphere's fractions repeat, up to a
// lattice shift, every 1/|V_i| steps), so the approach to steady state cancels
// between them and the lattice-crossing fluctuation averages out.
//
// Expected difference: the second-order equilibrium of D3Q19 lacks the u^3
// terms, so the viscous stress seen in a frame moving at V is off by a
// relative O(Ma^2) = O(|V|^2 / c_s^2) = O(3 |V|^2); that is our tolerance
// (1.2e-3 for |V| = 0.02, 3.6e-3 for |V| = 0.0346). A second, smaller part:
// the fixed sphere samples one sub-grid position, the moving one averages
// over all of them, and PSM drag depends weakly on the position.
// Measured (host, fp64, table fractions, after 4000 steps, 2 crossings):
//   V = (-0.02, 0, 0):       U_B/U_A - 1 = +5.6e-4 (per step +5.46e-4 ..
//                            +5.74e-4: the crossing fluctuation is +-1.4e-5),
//                            K_B/K_A - 1 = -4.6e-4, transverse U < 1e-6 U_A;
//   V = (-0.02, 0.02, 0.02): U_B/U_A - 1 = +1.37e-3 (+1.33e-3 .. +1.42e-3),
//                            K_B/K_A - 1 = -1.1e-3, transverse U = -1.9e-4 U_A.
// (Exact fractions with the sphere on a lattice-symmetric point gave +1.5e-4
// and -7.2e-4: too slow to remap every step on the host for CI.) The bounds
// leave 2.1x and 2.6x headroom over the measured values. A solid velocity
// left out of the solid operator would make the sphere a fixed obstacle in a
// stream at |V| = 22 U_A: U_B off by O(10).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "imb/fraction_table.hpp"
#include "psm_scene.hpp"

using namespace lbdem;

namespace {

struct Averages {
  std::array<double, 3> U{0, 0, 0};  // superficial relative velocity
  std::array<double, 3> F{0, 0, 0};  // force on the sphere
  double ratio_min = 1e300, ratio_max = -1e300;  // per-step U_B,x / U_A,x over the window
};

// Runs A (V = 0) and B side by side: `transient` steps, then averages over
// `window` steps. Sphere d/l = 8 in a 16^3 periodic box (chi = 0.5), tau 0.6,
// TRT Lambda 3/16, table fractions (the paper's method; cheap to remap).
std::array<Averages, 2> compare(std::array<double, 3> V, long transient, long window) {
  static const imb::FractionTable table = imb::build_fraction_table(3);
  const long L = 16;
  const double a = 4, tau = 0.6, nu = (tau - 0.5) / 3.0;
  // Body force for Re_p = U d / nu = 0.2 with the reference K(0.5) = 2.842.
  const double U0 = 0.2 * nu / (2 * a);
  const double g = 6 * M_PI * nu * a * 2.842 * U0 / double(L * L * L);
  const auto setup = test::psm_box(L, L, L, tau, 3.0 / 16.0, {g, 0, 0});
  imb::PsmOptions opt;
  opt.map.method = imb::FractionMethod::Table;
  opt.map.table = &table;
  const double x0 = 0.5 * L + 0.3;  // off the lattice's symmetry points
  test::PsmSphere fixed{x0, x0, x0, a};
  test::PsmScene A(setup, Backend::Host, 4, {fixed}, opt);
  test::PsmScene B(setup, Backend::Host, 4, {fixed}, opt, V);
  A.map();
  std::array<Averages, 2> avg;
  for (long s = 0; s < transient + window; ++s) {
    test::PsmSphere m = fixed;
    m.x += V[0] * double(s);  // position at this step (not accumulated: no drift from round-off)
    m.y += V[1] * double(s);
    m.z += V[2] * double(s);
    m.vx = V[0];
    m.vy = V[1];
    m.vz = V[2];
    B.set_particles({m});
    B.map();
    if (s >= transient) {
      const auto ua = A.superficial(), ub = B.superficial(V);
      for (int k = 0; k < 3; ++k) {
        avg[0].U[k] += ua[k] / double(window);
        avg[1].U[k] += ub[k] / double(window);
      }
      avg[1].ratio_min = std::min(avg[1].ratio_min, ub[0] / ua[0]);
      avg[1].ratio_max = std::max(avg[1].ratio_max, ub[0] / ua[0]);
    }
    A.step();
    B.step();
    if (s >= transient) {
      const auto fa = A.forces(), fb = B.forces();
      for (int k = 0; k < 3; ++k) {
        avg[0].F[k] += fa[k] / double(window);
        avg[1].F[k] += fb[k] / double(window);
      }
    }
  }
  return avg;
}

void check(std::array<double, 3> V, long period, double tol) {
  const auto r = compare(V, 4000, 2 * period);
  const double ratioU = r[1].U[0] / r[0].U[0];
  const double ratioK = (r[1].F[0] / r[1].U[0]) / (r[0].F[0] / r[0].U[0]);
  std::printf("V = (%g, %g, %g): U_A = %.6e, U_B/U_A - 1 = %+.2e (per step %+.2e .. %+.2e), K_B/K_A - 1 = %+.2e, "
              "transverse U_B/U_A = %+.1e %+.1e, F_B/F_A - 1 = %+.2e\n",
              V[0], V[1], V[2], r[0].U[0], ratioU - 1, r[1].ratio_min - 1, r[1].ratio_max - 1, ratioK - 1,
              r[1].U[1] / r[0].U[0], r[1].U[2] / r[0].U[0], r[1].F[0] / r[0].F[0] - 1);
  EXPECT_GT(r[0].U[0], 0);
  EXPECT_NEAR(ratioU, 1.0, tol);
  EXPECT_NEAR(ratioK, 1.0, tol);
  EXPECT_LT(std::abs(r[1].U[1] / r[0].U[0]), tol);
  EXPECT_LT(std::abs(r[1].U[2] / r[0].U[0]), tol);
}

}  // namespace

// V along -x (against the flow), |V| = 0.02: Ma^2 = 3 |V|^2 = 1.2e-3.
TEST(PsmGalilean, MovingAlongAxis) { check({-0.02, 0, 0}, 50, 1.2e-3); }

// V along a body diagonal, |V| = 0.0346: Ma^2 = 3.6e-3.
TEST(PsmGalilean, MovingAlongDiagonal) { check({-0.02, 0.02, 0.02}, 50, 3.6e-3); }
