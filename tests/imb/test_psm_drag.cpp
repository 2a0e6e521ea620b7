// PSM drag on a fixed sphere in a simple cubic array against Sangani &
// Acrivos (1982), chi = d/L = 0.5 (K = 2.8420, ../shared/REFERENCES.md).
#include <gtest/gtest.h>

#include <cstdio>

#include "../common/backends.hpp"
#include "psm_test_util.hpp"

using namespace lbdem;

TEST(PsmDrag, SanganiAcrivosSeries) { EXPECT_NEAR(test::sangani_acrivos_K(0.5), 2.8420, 5e-4); }

// Measured on this code (host, fp64, exact fractions, NEBB, Noble-Torczynski
// B, TRT Lambda = 3/16): tau 0.6 -> -3.9 %, tau 0.8 -> -5.8 %; B = eps:
// +13 %. The bars (< 3 %, then <= 1.4 %) are NOT reached yet: this
// test guards the current -3.9 % against regressions (bound 5 %) and the sign
// of the force; the calibration work is open (see the closing note).
TEST(PsmDrag, FixedSphereDl10) {
  test::SphereCase c;
  c.diameter = 10;
  c.tau = 0.6;
  c.tolerance = 1e-5;
  const auto r = test::fixed_sphere_drag(c, Backend::Host);
  std::printf("d/l=10 chi=0.5: K = %.4f (ref %.4f), error %+.3f%%, %ld steps, %.1f s\n", r.K, r.K_ref,
              100 * r.rel_error, r.steps, r.seconds);
  EXPECT_GT(r.force, 0);  // drag along the flow
  EXPECT_LT(std::abs(r.rel_error), 0.05);
}
