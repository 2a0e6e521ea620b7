// The wall-correction references of issue 29's wall cases
// (bench/imb/wall_references.hpp) against independent values: Brenner's own
// table and the series' limits; Haberman & Sayre's closed form against
// Bohlin's series for a sphere on the axis of a tube.
#include <gtest/gtest.h>

#include <cmath>

#include "../../bench/imb/wall_references.hpp"

using lbdem::bench::brenner_lambda;
using lbdem::bench::haberman_sayre_K;

// Brenner (1961) Table 1: lambda = 3.0360 at alpha = 1 (h/a = cosh 1) and
// 1.4129 at alpha = 2 (4 digits: within 1e-4). Near contact lambda -> a/(h - a)
// (lubrication; the next term is O(ln(a/(h - a)))): within 1 % at h - a =
// 1e-3 a. Far away lambda = 1 + 9a/(8h) + O((a/h)^2): within 2 (a/h)^2.
TEST(WallReferences, BrennerSeries) {
  EXPECT_NEAR(brenner_lambda(std::cosh(1.0)), 3.0360, 1e-4);
  EXPECT_NEAR(brenner_lambda(std::cosh(2.0)), 1.4129, 1e-4);
  EXPECT_NEAR(brenner_lambda(1.001) * 1e-3, 1.0, 0.01);
  for (double h : {10.0, 30.0, 100.0}) EXPECT_NEAR(brenner_lambda(h), 1 + 9 / (8 * h), 2 / (h * h)) << h;
  // Monotone: the closer the wall, the larger the drag.
  double prev = 1;
  for (double h : {50.0, 10.0, 3.0, 1.5, 1.1, 1.01}) {
    const double l = brenner_lambda(h);
    EXPECT_GT(l, prev) << h;
    prev = l;
  }
}

// Bohlin (1960) series for the same problem, K = 1 / (1 - 2.10444 k + 2.08877 k^3
// - 0.94813 k^5 - 1.372 k^6 + 3.87 k^8 - 4.19 k^10), k = d/D: the two agree
// within 0.1 % to k = 0.3 (both fits of the same reflections; Haberman &
// Sayre's is quoted to k ~ 0.8), and K -> 1 + 2.105 k as k -> 0.
TEST(WallReferences, HabermanSayreAgainstBohlin) {
  for (double k : {0.05, 0.1, 0.2, 0.3}) {
    const double k3 = k * k * k, k5 = k3 * k * k, k6 = k3 * k3, k8 = k5 * k3, k10 = k5 * k5;
    const double bohlin = 1 / (1 - 2.10444 * k + 2.08877 * k3 - 0.94813 * k5 - 1.372 * k6 + 3.87 * k8 - 4.19 * k10);
    EXPECT_NEAR(haberman_sayre_K(k) / bohlin, 1.0, 1e-3) << k;
  }
  EXPECT_NEAR((haberman_sayre_K(1e-4) - 1) / 1e-4, 2.105, 1e-3);
}
