// PSM drag on a fixed sphere in a simple cubic array (and a disk in a square
// array) against Sangani & Acrivos (1982), through the `fixed_sphere` scene
// driver (cases::run_fixed_sphere). References: ../shared/REFERENCES.md,
// "Flow past a fixed sphere"; the first paper (papers/lbm-imb-dem-mole85-
// xiong.md) Table 1 for the errors to beat.
//
// Settings of the accurate runs: fp64, exact solid fractions, NEBB solid
// operator, Noble-Torczynski weighting B, TRT with tau = 0.52 and Lambda =
// 1e-3, Re_p = 0.2, chi = d/L = 0.5. PSM accuracy improves as Lambda -> 0 and
// tau -> 1/2 (tau 0.6 with the default Lambda 3/16 gives -5.3 % at d/l = 10).
//
// Cost: tau = 0.52 (nu = 1/150) makes the approach to steady state slow (mean
// flow relaxes over (1 - phi) L^3 / (6 pi nu a K) ~ 4000 steps at d/l = 10);
// each d/l = 10 run is 51,000 steps of 20^3 cells (~20-60 s on 2 host cores).
// The steady-state tolerance 1e-4 (estimated remaining relative change of the
// drag) moves K by <= 1e-4 relative (measured: 1e-4 vs 1e-5 differ by 0.009 %
// at d/l = 10), far below every bound here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "cases/fixed_sphere.hpp"
#include "imb/fraction_table.hpp"

using namespace lbdem;

namespace {

cases::FixedSphereSpec accurate_spec(double diameter) {
  cases::FixedSphereSpec s;
  s.dim = 3;
  s.diameter = diameter;
  s.chi = 0.5;
  s.re_p = 0.2;
  s.tau = 0.52;
  s.collision = lbm::CollisionKind::TRT;
  s.magic = 1e-3;
  s.precision = lbm::Precision::FP64;
  s.method = imb::FractionMethod::Exact;
  s.variant = imb::PsmVariant::NEBB;
  s.weight = imb::PsmWeight::NobleTorczynski;
  s.tolerance = 1e-4;
  return s;
}

cases::FixedSphereResult run(const cases::FixedSphereSpec& s, const char* label) {
  const auto r = cases::run_fixed_sphere(s, Backend::Host);
  std::printf("%s d/l=%g chi=%g: K = %.5f (ref %.5f), error %+.3f%%, Re_p %.3f, %ld steps, %.1f s%s\n", label,
              s.diameter, s.chi, r.K, r.K_ref, 100 * r.rel_error, r.re_p, r.steps, r.seconds,
              r.converged ? "" : " (NOT converged)");
  return r;
}

}  // namespace

// (a) Sangani & Acrivos (1982) Eq. 60, 31-term series: K(0.5) = 2.8420 as
// tabulated in REFERENCES.md (4 digits given, so 5e-4).
TEST(PsmDrag, SanganiAcrivosSeries) {
  EXPECT_NEAR(cases::sangani_acrivos_K(0.5), 2.8420, 5e-4);
  EXPECT_DOUBLE_EQ(cases::sangani_acrivos_K(0.0), 1.0);  // Stokes drag of an isolated sphere
}

// (b) + (c) one sweep (the d/l = 10 run serves both: it is the expensive one).
// (b) the bar at d/l = 10: |error| < 1.43 %, half the first paper's
//     2.868 % (Table 1, d/l = 10, Re_p = 0.2). Measured: -0.144 % (K = 2.83793
//     vs 2.84202), 51,000 steps.
// (c) the error falls as the sphere is resolved. Measured: d/l = 6: -3.540 %,
//     8: -1.131 %, 10: -0.144 % (an effective-radius offset that shrinks with
//     d/l; tau and Lambda set it). Against the paper's Table 1 (6.953, 4.352,
//     2.868 % at d/l = 6, 8, 10): below half of it at d/l = 8 and 10 (2.176 and
//     1.434 % bars, ~2x and ~10x headroom). At d/l = 6 half the paper would be
//     3.477 % and we measure 3.540 %: that bar is NOT met at these settings
//     (tau 0.52, Lambda 1e-3; a smaller tau - 1/2 or Lambda would be needed),
//     so d/l = 6 is held to the paper's own 6.953 % (we are at 0.51 of it).
TEST(PsmDrag, FixedSphereResolutionSweep) {
  const double dl[3] = {6, 8, 10};
  const double paper[3] = {6.953e-2, 4.352e-2, 2.868e-2};  // Table 1 relative errors
  const double fraction_of_paper[3] = {1.0, 0.5, 0.5};     // see above for d/l = 6
  double err[3];
  for (int i = 0; i < 3; ++i) {
    const auto r = run(accurate_spec(dl[i]), "exact");
    ASSERT_TRUE(r.converged);
    EXPECT_GT(r.force, 0);  // drag along the flow
    // The momentum the solid term takes equals what the body force gives the
    // fluid at steady state (to the steady-state tolerance).
    EXPECT_NEAR(r.exchange / r.balance, 1.0, 5e-4);
    EXPECT_NEAR(r.re_p, 0.2, 0.02);  // the body force was set for Re_p = 0.2 from K_ref
    err[i] = r.rel_error;
    EXPECT_LT(std::abs(err[i]), fraction_of_paper[i] * paper[i]) << "d/l = " << dl[i];
  }
  EXPECT_LT(std::abs(err[2]), 0.0143) << "issue bar at d/l = 10";
  EXPECT_LT(std::abs(err[1]), std::abs(err[0]));
  EXPECT_LT(std::abs(err[2]), std::abs(err[1]));
}

// (d) The first paper's table-lookup fractions (its Eq. 6) and the linear ramp
// at d/l = 10, otherwise as above. Measured (tolerance 1e-4): table -0.179 %
// (K = 2.83693), linear +0.104 % (K = 2.84499); exact -0.144 %. At chi = 0.5
// the drag per unit velocity goes as a^2.52 (d ln(a K)/d ln a from the
// series), so 0.1 % of K is a 0.002-cell shift of the effective radius: the
// table sits 0.0007 cells inside the exact result, the ramp 0.005 outside.
// Bound 0.5 % (a 0.01-cell shift): 2.8x and 4.8x the measured magnitudes, a
// third of the 1.43 % bar. It fails if a method loses or gains solid
// volume at the percent level (a ramp on R instead of R_eff: +1/(4R^2) = 1 %
// volume, ~ +0.8 % drag) or if the table were read at the wrong radius.
class PsmDragFractionMethod : public ::testing::TestWithParam<imb::FractionMethod> {};

TEST_P(PsmDragFractionMethod, Dl10WithinHalfPercent) {
  static const imb::FractionTable table = imb::build_fraction_table(3);
  auto s = accurate_spec(10);
  s.method = GetParam();
  s.table = &table;
  const auto r = run(s, imb::to_string(GetParam()));
  ASSERT_TRUE(r.converged);
  EXPECT_LT(std::abs(r.rel_error), 0.005);
}

INSTANTIATE_TEST_SUITE_P(Methods, PsmDragFractionMethod,
                         ::testing::Values(imb::FractionMethod::Table, imb::FractionMethod::Linear),
                         [](const ::testing::TestParamInfo<imb::FractionMethod>& i) {
                           return std::string(imb::to_string(i.param));
                         });

// (e) 2D: a disk in a square array (D2Q9) against Sangani & Acrivos (1982,
// cylinders), F / (4 pi mu U) = 1 / (-ln(c)/2 - 0.738 + c - 0.887 c^2 +
// 2.038 c^3), c the area fraction. At d/L = 0.3 (c = 0.068-0.071 once L is
// rounded to whole cells) the first omitted term is O(c^4) ~ 2.5e-5 against
// K^-1 ~ 0.65: the reference is good to ~1e-4, so no smaller chi is needed.
// Same accurate settings as in 3D (tau 0.52, Lambda 1e-3, exact fractions).
// Measured (this test, tolerance 1e-4):
//               disk centre on a cell centre   on a cell corner
//   d/l = 5  (L = 17):      +0.162 %               -2.077 %
//   d/l = 10 (L = 33):      +0.092 %               +0.608 %
// (also measured, centre on a cell centre, chi = 0.3: d/l = 6: -1.46 %,
// 8: -0.24 %, 12: +0.34 %, 20: +0.41 %; Re_p = 0.02 instead of 0.2 moves
// d/l = 10 by 0.03 %, so inertia is not the cause).
// So in 2D the error at one position is NOT monotone in d/l, and levels off
// near +0.4 % up to d/l = 20. Our reading: with tau -> 1/2 the
// Noble-Torczynski weight B = eps (tau - 1/2) / ((1 - eps) + tau - 1/2) is ~0
// unless eps ~ 1, so the solid acts through the staircase of (nearly) covered
// cells; a disk has only ~3 d interface cells (a sphere ~3 d^2, which average
// the staircase out: the 3D sweep above is monotone). What does fall with d/l
// is the dependence on the position and with it the worst case. Asserted:
//  - the worst error over the two positions falls from d/l = 5 to 10
//    (2.08 % -> 0.61 %);
//  - the spread between the positions falls at least 2x (first order in 1/d
//    would be 2x; measured 2.24 % -> 0.52 %);
//  - at d/l = 10 both positions are within 1 % (measured <= 0.61 %), a third
//    of the first paper's 3D figure at that resolution.
TEST(PsmDrag, DiskInSquareArray2D) {
  double worst[2] = {0, 0}, spread[2] = {0, 0};
  const double dl[2] = {5, 10};
  for (int i = 0; i < 2; ++i) {
    double e[2];
    for (int pos = 0; pos < 2; ++pos) {
      auto s = accurate_spec(dl[i]);
      s.dim = 2;
      s.chi = 0.3;
      s.offset = pos == 0 ? 0.0 : 0.5;  // L odd: L/2 is a cell centre; + 0.5 a cell corner
      const auto r = run(s, pos == 0 ? "disk on cell centre" : "disk on cell corner");
      ASSERT_TRUE(r.converged);
      const double L = std::round(dl[i] / 0.3);  // the driver's period
      ASSERT_EQ(std::lround(L) % 2, 1);
      EXPECT_NEAR(r.K_ref, cases::sangani_acrivos_cylinders(M_PI * 0.25 * dl[i] * dl[i] / (L * L)), 1e-12);
      e[pos] = r.rel_error;
    }
    worst[i] = std::max(std::abs(e[0]), std::abs(e[1]));
    spread[i] = std::abs(e[0] - e[1]);
    if (i == 1) {
      EXPECT_LT(std::abs(e[0]), 0.01);
      EXPECT_LT(std::abs(e[1]), 0.01);
    }
  }
  EXPECT_LT(worst[1], worst[0]);
  EXPECT_LT(spread[1], 0.5 * spread[0]);
}
