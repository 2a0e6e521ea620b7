// Taylor-Green vortex (Taylor & Green 1937): 2D periodic, k = 2 pi / N,
//   u = -U0 cos kx sin ky e^{-2 nu k^2 t}, v = U0 sin kx cos ky e^{-2 nu k^2 t},
//   p = -rho U0^2/4 (cos 2kx + cos 2ky) e^{-4 nu k^2 t}.
// Cell centres at x = i + 1/2. Relative L2 velocity error at t = 1/(2 nu k^2).
#include <gtest/gtest.h>

#include <cmath>

#include "../common/backends.hpp"
#include "lbm_test_util.hpp"

using namespace lbdem;
using namespace lbdem::lbm;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Returns the relative L2 error of the velocity field after `t_end` (rounded
// to whole steps; the analytic solution is evaluated at that step).
double taylor_green_error(long N, double tau, double U0, Backend b, CollisionKind ck = CollisionKind::BGK,
                          Precision p = Precision::FP64, StreamKind sk = StreamKind::AA) {
  auto s = test::make_scene(LatticeKind::D2Q9, N, N, 1);
  s.setup.collision = ck;
  s.setup.tau = tau;
  s.setup.precision = p;
  s.setup.streaming = sk;
  const double k = 2 * kPi / N, nu = (tau - 0.5) / 3.0;
  for (long y = 0; y < N; ++y)
    for (long x = 0; x < N; ++x) {
      const double X = x + 0.5, Y = y + 0.5;
      const auto i = test::cell_index(s, x, y, 0);
      s.u[3 * i] = -U0 * std::cos(k * X) * std::sin(k * Y);
      s.u[3 * i + 1] = U0 * std::sin(k * X) * std::cos(k * Y);
      const double pr = -U0 * U0 / 4 * (std::cos(2 * k * X) + std::cos(2 * k * Y));
      s.rho[i] = 1.0 + 3.0 * pr;
    }
  const long steps = std::lround(1.0 / (2 * nu * k * k));
  auto solver = test::start(s, b);
  solver->step(steps);
  std::vector<double> rho, u;
  solver->macroscopic(rho, u);
  const double decay = std::exp(-2 * nu * k * k * steps);
  double num = 0, den = 0;
  for (long y = 0; y < N; ++y)
    for (long x = 0; x < N; ++x) {
      const double X = x + 0.5, Y = y + 0.5;
      const auto i = test::cell_index(s, x, y, 0);
      const double ua = -U0 * std::cos(k * X) * std::sin(k * Y) * decay;
      const double va = U0 * std::sin(k * X) * std::cos(k * Y) * decay;
      num += (u[3 * i] - ua) * (u[3 * i] - ua) + (u[3 * i + 1] - va) * (u[3 * i + 1] - va);
      den += ua * ua + va * va;
    }
  return std::sqrt(num / den);
}

class TaylorGreen : public ::testing::TestWithParam<Backend> {};

TEST_P(TaylorGreen, SecondOrderConvergence) {
  const double e8 = taylor_green_error(8, 0.8, 1e-3, GetParam());
  const double e16 = taylor_green_error(16, 0.8, 1e-3, GetParam());
  const double e32 = taylor_green_error(32, 0.8, 1e-3, GetParam());
  const double o1 = std::log2(e8 / e16), o2 = std::log2(e16 / e32);
  std::printf("Taylor-Green L2 errors: N=8 %.4e  N=16 %.4e  N=32 %.4e  orders %.3f %.3f\n", e8, e16, e32, o1, o2);
  EXPECT_GE(o1, 1.9);
  EXPECT_LE(o1, 2.1);
  EXPECT_GE(o2, 1.9);
  EXPECT_LE(o2, 2.1);
  // Reference values (REFERENCES.md, derived): 8.65e-2, 2.12e-2, 5.28e-3. 3%
  // covers the rounding of t to whole steps.
  EXPECT_NEAR(e8, 8.65e-2, 0.03 * 8.65e-2);
  EXPECT_NEAR(e16, 2.12e-2, 0.03 * 2.12e-2);
  EXPECT_NEAR(e32, 5.28e-3, 0.03 * 5.28e-3);
}

TEST_P(TaylorGreen, Fp32StaysCloseToFp64) {
  // Shifted fp32 storage: the fp32 run must be as accurate as fp64 to within
  // a small fraction of the discretisation error itself.
  const double e64 = taylor_green_error(32, 0.8, 1e-2, GetParam(), CollisionKind::TRT, Precision::FP64);
  const double e32 = taylor_green_error(32, 0.8, 1e-2, GetParam(), CollisionKind::TRT, Precision::FP32);
  EXPECT_NEAR(e32, e64, 0.02 * e64);
}

INSTANTIATE_TEST_SUITE_P(Backends, TaylorGreen, ::testing::ValuesIn(test::backends()), test::backend_name);

}  // namespace
