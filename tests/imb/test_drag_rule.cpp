// One drag rule for every tau (bench/imb/NOTES.md, "One rule for every tau"):
// the wall rule's weighting parameter t(tau) (imb::psm_wall_weight_t) and the
// TRT Lambda by d/l and tau (imb::psm_magic_auto), checked as formulas and on
// the fixed sphere in a simple cubic array (chi 0.5, Re_p 0.2, exact
// fractions, fp64, NEBB, sphere centre on a cell centre) against Sangani &
// Acrivos (1982); the bar is half the first paper's Table 1 error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "imb/fixed_sphere.hpp"
#include "imb/drag_error.hpp"
#include "imb/psm.hpp"

using namespace lbdem;

namespace {

double rule_error(double d, double tau) {
  imb::FixedSphereSpec s;
  s.dim = 3;
  s.diameter = d;
  s.chi = 0.5;
  s.re_p = 0.2;
  s.tau = tau;
  s.collision = lbm::CollisionKind::TRT;
  s.magic = imb::psm_magic_auto(d, tau);
  s.precision = lbm::Precision::FP64;
  s.method = imb::FractionMethod::Exact;
  s.variant = imb::PsmVariant::NEBB;
  s.weight = imb::PsmWeight::NobleTorczynskiWall;
  s.offset = 0.5;
  s.tolerance = 1e-5;
  const auto r = imb::run_fixed_sphere(s, Backend::Host);
  EXPECT_TRUE(r.converged) << "d/l " << d << " tau " << tau;
  std::printf("d/l %g tau %g Lambda %.3g: K = %.5f, error %+.3f%% (bar %.2f%%), %ld steps\n", d, tau, s.magic, r.K,
              100 * r.rel_error, 100 * imb::psm_drag_bar(d), r.steps);
  return r.rel_error;
}

}  // namespace

// t = m / (1 - 2m)^(3/2), m = tau - 1/2: values at a few tau, t -> m as
// tau -> 1/2, and B -> eps (the largest weight of the NT form) at tau = 1.
TEST(DragRule, WeightParameterValues) {
  const double cases_[][2] = {{0.52, 0.02 / std::pow(0.96, 1.5)},
                              {0.6, 0.1 / std::pow(0.8, 1.5)},
                              {0.8, 0.3 / std::pow(0.4, 1.5)},
                              {0.9, 0.4 / std::pow(0.2, 1.5)}};
  for (const auto& c : cases_) EXPECT_NEAR(imb::psm_wall_weight_t(c[0]), c[1], 1e-12 * c[1]) << c[0];
  EXPECT_NEAR(imb::psm_wall_weight_t(0.52), 0.0212629, 1e-7);
  EXPECT_NEAR(imb::psm_wall_weight_t(0.8), 1.185854, 1e-6);
  EXPECT_NEAR(imb::psm_wall_weight_t(0.5001) / 1e-4, 1.0, 4e-4);
  // tau = 1 and above: finite, B within 1e-4 of eps, never above it.
  for (double tau : {1.0, 1.2, 3.0}) {
    const double t = imb::psm_wall_weight_t(tau);
    ASSERT_TRUE(std::isfinite(t)) << tau;
    for (double eps : {0.1, 0.5, 0.9, 1.0}) {
      const double B = imb::psm_weight(eps, t, imb::PsmWeight::NobleTorczynskiWall);
      EXPECT_LE(B, eps) << tau << " " << eps;
      EXPECT_GT(B, eps - 1e-4) << tau << " " << eps;
    }
  }
  // The float kernels get t as float: B must stay finite and <= 1 there too.
  const float tf = static_cast<float>(imb::psm_wall_weight_t(1.0));
  EXPECT_LE(imb::psm_weight(0.999f, tf, imb::PsmWeight::NobleTorczynskiWall), 1.0f);
}

// Lambda auto: the study's setting as tau -> 1/2 (1e-4 below d/l 16, 3e-2
// from 16), the table's nodes, interpolation between them, clamping.
TEST(DragRule, LambdaAuto) {
  for (double d : {4.0, 6.0, 8.0, 10.0, 12.0, 15.9}) EXPECT_NEAR(imb::psm_magic_auto(d, 0.52), 1e-4, 1e-12) << d;
  for (double d : {4.0, 10.0}) EXPECT_NEAR(imb::psm_magic_auto(d, 0.505), 1e-4, 1e-12) << d;
  for (double d : {16.0, 30.0, 50.0}) EXPECT_NEAR(imb::psm_magic_auto(d, 0.52), 3e-2, 1e-12) << d;
  using imb::detail::kMagicD, imb::detail::kMagicTau, imb::detail::kMagicTable;
  using imb::detail::kMagicRows, imb::detail::kMagicCols;
  for (int i = 0; i < kMagicRows; ++i)
    for (int j = 0; j < kMagicCols; ++j)
      EXPECT_NEAR(imb::psm_magic_auto(kMagicD[i], kMagicTau[j]), kMagicTable[i][j], 1e-12 * kMagicTable[i][j])
          << kMagicD[i] << " " << kMagicTau[j];
  // Between nodes: within the range of the four corners.
  for (double d : {5.0, 7.0, 9.0, 12.0, 18.0, 25.0, 40.0})
    for (double tau : {0.55, 0.65, 0.75, 0.85, 0.95, 1.1, 1.4}) {
      int i = 0, j = 0;
      while (kMagicD[i + 1] < d) ++i;
      while (kMagicTau[j + 1] < tau) ++j;
      double lo = 1e9, hi = 0;
      for (int a : {i, i + 1})
        for (int b : {j, j + 1}) {
          lo = std::min(lo, kMagicTable[a][b]);
          hi = std::max(hi, kMagicTable[a][b]);
        }
      const double L = imb::psm_magic_auto(d, tau);
      EXPECT_GE(L, lo * (1 - 1e-12)) << d << " " << tau;
      EXPECT_LE(L, hi * (1 + 1e-12)) << d << " " << tau;
    }
  // Clamped at the table's edges: d/l above 50 takes the d/l 50 row, tau above 1.5 the tau 1.5 column.
  EXPECT_NEAR(imb::psm_magic_auto(80, 0.8), imb::psm_magic_auto(50, 0.8), 1e-15);
  EXPECT_NEAR(imb::psm_magic_auto(8, 2.0), imb::psm_magic_auto(8, 1.5), 1e-15);
  // t's excess does not fade with d/l: Lambda grows with d/l at every tau of 0.6-1.25 from d/l 10.
  for (double tau : {0.6, 0.8, 1.0, 1.25})
    for (int i = 3; i + 1 < kMagicRows; ++i)
      EXPECT_LT(imb::psm_magic_auto(kMagicD[i], tau), imb::psm_magic_auto(kMagicD[i + 1], tau)) << tau;
}

// The rule on the host at d/l 4: drag within the bar at two tau where the
// previous rule (t = m / (1 - 1.75 m), Lambda 1e-4) missed it (-8.86 and
// -11.50 %). Measured: -6.74 % (tau 0.6, Lambda 1.2e-4), -6.85 % (0.8, 0.011).
TEST(DragRule, HostDl4WithinBar) {
  for (double tau : {0.6, 0.8}) {
    const double e = rule_error(4, tau);
    EXPECT_LE(std::abs(e), imb::psm_drag_bar(4)) << "tau " << tau;
  }
}

// The same at d/l 6, at tau 0.8 and 1 (Lambda auto 0.080 and 0.062).
// Measured: -2.17 and -1.84 % (bar 3.48).
TEST(DragRule, HostDl6WithinBar) {
  for (double tau : {0.8, 1.0}) {
    const double e = rule_error(6, tau);
    EXPECT_LE(std::abs(e), imb::psm_drag_bar(6)) << "tau " << tau;
  }
}

// Above tau 1 (B = eps, the weighting's limit) d/l 10 takes Lambda 0.024 at
// tau 1.25 (bench/imb/NOTES.md, "Lambda to d/l 50 and tau 1.5"): within the
// bar at tau 1.25 and at the shipped suspensions' tau 1.2386 (Lambda auto
// 0.026), where the tau 1 row's Lambda 0.21 gave -3.36 % and -3.2 %.
// Measured (host): -0.07 % and +0.02 % (bar 1.43).
TEST(DragRule, HostDl10AboveTau1WithinBar) {
  for (double tau : {1.25, 1.2386}) {
    const double e = rule_error(10, tau);
    EXPECT_LE(std::abs(e), imb::psm_drag_bar(10)) << "tau " << tau;
  }
}
