// PSM drag on a fixed sphere in a simple cubic array (and a disk in a square
// array) against Sangani & Acrivos (1982), through the `fixed_sphere` scene
// driver (imb::run_fixed_sphere). References: ../shared/REFERENCES.md,
// "Flow past a fixed sphere"; the first paper (papers/lbm-imb-dem-mole85-
// xiong.md) Table 1 for the errors to beat.
//
// Settings of the accurate runs (bench/imb/NOTES.md, "Fixed-sphere drag: host
// study"): fp64, exact solid fractions, NEBB solid operator, Noble-Torczynski
// weighting B, TRT with tau = 0.52 and Lambda = 1e-4, Re_p = 0.2, chi = d/L =
// 0.5, sphere centre on a cell centre (offset 0.5), fluid started from the
// Stokes estimate. The PSM drag rises as Lambda -> 0 and tau -> 1/2 (tau 0.6
// with the TRT default Lambda 3/16 gives -5.3 % at d/l = 10); Re_p = 0.2
// against 0.01 moves K by 3.5e-5 relative (inertia is not what we measure).
//
// Cost: tau = 0.52 (nu = 1/150) makes the approach to steady state slow: the
// mean flow relaxes as exp(-t / T), T = 0.094 L^2 / nu (measured; ratio of
// successive drag changes constant to 4 digits), e.g. 5,600 steps at d/l = 10.
// The steady-state tolerance 1e-4 (estimated remaining relative change of the
// drag) moves K by <= 1e-4 relative, far below every bound here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "imb/fixed_sphere.hpp"
#include "imb/fraction_table.hpp"

using namespace lbdem;

namespace {

imb::FixedSphereSpec accurate_spec(double diameter) {
  imb::FixedSphereSpec s;
  s.dim = 3;
  s.diameter = diameter;
  s.chi = 0.5;
  s.re_p = 0.2;
  s.tau = 0.52;
  s.collision = lbm::CollisionKind::TRT;
  s.magic = 1e-4;
  s.precision = lbm::Precision::FP64;
  s.method = imb::FractionMethod::Exact;
  s.variant = imb::PsmVariant::NEBB;
  s.weight = imb::PsmWeight::NobleTorczynski;
  s.offset = 0.5;  // centre on a cell centre (L/2 is a cell corner)
  s.start = imb::FixedSphereSpec::Start::Estimate;
  s.tolerance = 1e-4;
  return s;
}

imb::FixedSphereResult run(const imb::FixedSphereSpec& s, const char* label) {
  const auto r = imb::run_fixed_sphere(s, Backend::Host);
  std::printf("%s d/l=%g chi=%g: K = %.5f (ref %.5f), error %+.3f%%, Re_p %.3f, %ld steps, %.1f s%s\n", label,
              s.diameter, s.chi, r.K, r.K_ref, 100 * r.rel_error, r.re_p, r.steps, r.seconds,
              r.converged ? "" : " (NOT converged)");
  return r;
}

}  // namespace

// (a) Sangani & Acrivos (1982) Eq. 60, 31-term series: K(0.5) = 2.8420 as
// tabulated in REFERENCES.md (4 digits given, so 5e-4).
TEST(PsmDrag, SanganiAcrivosSeries) {
  EXPECT_NEAR(imb::sangani_acrivos_K(0.5), 2.8420, 5e-4);
  EXPECT_DOUBLE_EQ(imb::sangani_acrivos_K(0.0), 1.0);  // Stokes drag of an isolated sphere
}

// (b) + (c) one sweep, d/l = 4, 6, 8, 10 (8^3 ... 20^3 cells).
// (b) the bar at every d/l: |error| <= half the first paper's Table 1
//     error (Re_p = 0.2): 8.00, 3.48, 2.18, 1.43 %. Measured (tolerance
//     1e-6): -7.77, -2.43, -0.98, -0.02 %. The d/l = 4 margin is thin (0.23 %
//     of K) and holds for this sphere position only: centred on a cell corner
//     it is -11.8 % (test below); Lambda = 1e-3 gives -8.03 % (missed).
// (c) the error falls as the sphere is resolved (monotone over 4 ... 10; it
//     crosses zero between 10 and 12 and is +0.29 % at 12, +0.49 % at 16,
//     +0.61 % at 20: a positive O(1/d) effective-radius excess, see NOTES).
TEST(PsmDrag, FixedSphereResolutionSweep) {
  const double dl[4] = {4, 6, 8, 10};
  const double paper[4] = {15.99e-2, 6.953e-2, 4.352e-2, 2.868e-2};  // Table 1 relative errors
  double err[4];
  for (int i = 0; i < 4; ++i) {
    const auto r = run(accurate_spec(dl[i]), "exact");
    ASSERT_TRUE(r.converged);
    EXPECT_GT(r.force, 0);  // drag along the flow
    // The momentum the solid term takes equals what the body force gives the
    // fluid at steady state (to the steady-state tolerance).
    EXPECT_NEAR(r.exchange / r.balance, 1.0, 5e-4);
    // The body force was set for Re_p = 0.2 from K_ref: Re_p K / K_ref = 0.2.
    EXPECT_NEAR(r.re_p * r.K / r.K_ref, 0.2, 1e-9);
    err[i] = r.rel_error;
    EXPECT_LE(std::abs(err[i]), 0.5 * paper[i]) << "issue bar (half the paper) at d/l = " << dl[i];
  }
  for (int i = 1; i < 4; ++i) EXPECT_LT(std::abs(err[i]), std::abs(err[i - 1])) << "d/l = " << dl[i];
}

// Sphere position: the first paper does not say where its sphere sits. With
// the centre on a cell corner (offset 0) the staircase of nearly covered cells
// differs: measured (tolerance 1e-6) d/l = 4: -11.81 % (issue bar 8.00 %:
// missed, within the paper's own 15.99 %), d/l = 6: -3.37 % (bar 3.48 %: met).
// From d/l = 8 on the two positions differ by < 0.1 % (8: 0.05, 10: 0.01,
// 16: 0.02 % at Lambda 1e-3). Asserted: d/l 6 meets the bar at the corner
// too, d/l 4 is within the paper's error, and the position sensitivity
// falls from d/l 4 to 6 (3.8 -> 0.94 % of K).
TEST(PsmDrag, FixedSphereOnCellCorner) {
  double centre[2], corner[2];
  const double dl[2] = {4, 6};
  for (int i = 0; i < 2; ++i) {
    auto s = accurate_spec(dl[i]);
    centre[i] = run(s, "cell centre").rel_error;
    s.offset = 0.0;
    const auto r = run(s, "cell corner");
    ASSERT_TRUE(r.converged);
    corner[i] = r.rel_error;
  }
  EXPECT_LT(std::abs(corner[0]), 15.99e-2);
  EXPECT_LE(std::abs(corner[1]), 0.5 * 6.953e-2);
  EXPECT_LT(std::abs(corner[1] - centre[1]), 0.5 * std::abs(corner[0] - centre[0]));
}

// (d) The first paper's table-lookup fractions (its Eq. 6) and the linear ramp
// at d/l = 10, otherwise as above. Measured (tolerance 1e-4): table -0.018 %
// (K = 2.84150), linear +0.335 % (K = 2.85153); exact -0.001 %. At chi = 0.5
// the drag per unit velocity goes as a^2.52 (d ln(a K)/d ln a from the
// series), so 0.1 % of K is a 0.002-cell shift of the effective radius: the
// table sits 0.0004 cells inside the exact result, the ramp 0.007 outside.
// Bound 0.5 % (a 0.01-cell shift): 1.5x the ramp's measured magnitude, a
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
// Same accurate settings as in 3D (tau 0.52, Lambda 1e-4, exact fractions).
// Measured (this test, tolerance 1e-4):
//               disk centre on a cell centre   on a cell corner
//   d/l = 5  (L = 17):      +0.317 %               -1.982 %
//   d/l = 10 (L = 33):      +0.161 %               +0.706 %
// (Lambda 1e-3: +0.162 / -2.077 % and +0.092 / +0.608 %; also measured at
// Lambda 1e-3, centre on a cell centre, chi = 0.3: d/l = 6: -1.46 %,
// 8: -0.24 %, 12: +0.34 %, 20: +0.41 %; Re_p = 0.02 instead of 0.2 moves
// d/l = 10 by 0.03 %, so inertia is not the cause).
// So in 2D the error at one position is NOT monotone in d/l, and levels off
// near +0.4 % up to d/l = 20 (the 3D sweep does the same: monotone from
// d/l 4 to 10, then +0.3 to +0.6 % from 12 to 20). Our reading: with tau ->
// 1/2 the Noble-Torczynski weight B = eps (tau - 1/2) / ((1 - eps) + tau -
// 1/2) is ~0 unless eps ~ 1, so the solid acts through the staircase of
// (nearly) covered cells, whose hydrodynamic size is a few hundredths of a
// cell above the nominal one. What does fall with d/l is the dependence on
// the position and with it the worst case. Asserted:
//  - the worst error over the two positions falls from d/l = 5 to 10
//    (1.98 % -> 0.71 %);
//  - the spread between the positions falls at least 2x (first order in 1/d
//    would be 2x; measured 2.30 % -> 0.55 %);
//  - at d/l = 10 both positions are within 1 % (measured <= 0.71 %), a third
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
      EXPECT_NEAR(r.K_ref, imb::sangani_acrivos_cylinders(M_PI * 0.25 * dl[i] * dl[i] / (L * L)), 1e-12);
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
