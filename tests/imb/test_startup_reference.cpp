// The start-up-from-rest reference of issue 29 (bench/imb/startup_reference.hpp):
// the Faddeeva function against closed forms and between its two algorithms,
// the closed-form velocity history against its limits and against a direct
// integration of the Maxey-Riley equation, and the periodic-cube model
// against Hasimoto's steady sum.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstdio>

#include "../../bench/imb/startup_reference.hpp"

using namespace lbdem::bench;

// w on the imaginary axis is exp(y^2) erfc(y) (std::erfc, relative error ~
// 1e-15 below y = 6 where exp(y^2) stays moderate); on the real axis
// Re w = exp(-x^2) exactly; w(1 + i) to 16 digits (Abramowitz & Stegun Table
// 7.9 to 6 digits: 0.304744 + 0.208219 i; the 16-digit value from the
// integral representation by adaptive quadrature, Poppe & Wijers 1990's test
// point). The two algorithms (continued fraction, pole-corrected trapezoid)
// agree to 1e-12 on 6 <= |z| <= 8.5 (where both have converged: the
// trapezoid's pole term stays below 1 there).
TEST(StartupReference, FaddeevaW) {
  for (double y : {0.0, 0.1, 0.5, 1.0, 2.0, 4.0, 6.0})
    EXPECT_NEAR(faddeeva_w({0, y}).real() / (std::exp(y * y) * std::erfc(y)), 1.0, 1e-13) << y;
  for (double x : {0.0, 0.3, 0.5, 1.0, 2.5, 5.0})
    EXPECT_NEAR(faddeeva_w({x, 0}).real(), std::exp(-x * x), 1e-14) << x;
  // Im w(x) = 2 Dawson(x) / sqrt(pi): Dawson(1) = 0.5380795069127684.
  EXPECT_NEAR(faddeeva_w({1, 0}).imag(), 2 * 0.5380795069127684 / std::sqrt(M_PI), 1e-14);
  const auto w11 = faddeeva_w({1, 1});
  EXPECT_NEAR(w11.real(), 0.3047442052569126, 1e-14);
  EXPECT_NEAR(w11.imag(), 0.2082189382028316, 1e-14);
  double worst = 0;
  for (double R : {6.0, 7.0, 8.0, 8.5})
    for (int k = 0; k <= 40; ++k) {
      const auto z = std::polar(R, M_PI * k / 40);
      worst = std::max(worst, std::abs(faddeeva_w_fraction(z) - faddeeva_w_trapezoid(z)) / std::abs(faddeeva_w_trapezoid(z)));
    }
  EXPECT_LT(worst, 1e-12);
}

// (i) terminal velocity; (ii) the short-time limit u = F t / (m_p + m_a)
// with its Basset correction (the remainder is O(T^2 / beta^3): at T = 1e-6
// relative 1e-5 at most); (iii) the long-time approach 1 - 1/sqrt(pi T) - (2 beta
// - 1) T^{-3/2} / (2 sqrt(pi)) (remainder O(T^{-5/2}): 1e-9 at T = 1e4, and
// the first correction alone to 2e-6 there); complex roots (r = 2, 8) and real
// roots (r = 0.3).
TEST(StartupReference, Limits) {
  for (double r : {0.3, 2.0, 8.0}) {
    const StartupReference ref(r);
    const double beta = (2 * r + 1) / 9;
    EXPECT_EQ(ref(0.0), 0.0);
    EXPECT_NEAR(ref(1e9), 1.0, 1e-4) << r;  // 1 - 1/sqrt(pi 1e9) = 1 - 1.8e-5
    for (double T : {1e-6, 1e-5}) {
      EXPECT_NEAR(ref(T) / (T / beta), 1.0, 3 * std::sqrt(T) / beta) << r << " " << T;  // leading term alone
      EXPECT_NEAR(ref(T) / ref.short_time(T), 1.0, 10 * T / (beta * beta)) << r << " " << T;
    }
    for (double T : {1e3, 1e4}) {
      EXPECT_NEAR(ref(T), ref.long_time(T), std::pow(T, -2.5) * 10) << r << " " << T;
      EXPECT_NEAR((1 - ref(T)) * std::sqrt(M_PI * T), 1.0, 2 * std::abs(2 * beta - 1) / T + 1e-9) << r << " " << T;
    }
    // Monotone rise from 0 to 1.
    double prev = 0;
    for (double T = 0.01; T < 100; T *= 1.3) {
      const double u = ref(T);
      EXPECT_GT(u, prev) << r << " " << T;
      EXPECT_LT(u, 1.0) << r << " " << T;
      prev = u;
    }
  }
  EXPECT_THROW(StartupReference(0.625), std::invalid_argument);  // the double root
}

// (iv) Direct integration of the Maxey-Riley equation with the history
// integral (product integration, startup_brute_force) at density ratios 2 and
// 8 (and 0.3: real roots): first order in h, so the Richardson value 2 u(h/2)
// - u(h) has an error O(h^2); the measured difference between u(h) and
// u(h/2) bounds u(h)'s own error (the errors halve with h): the closed form
// must lie within 1e-4 of the Richardson value over T in (0, 10] (h = 1e-3),
// and the plain u(h/2) within 1.5 times the step-halving difference (1 for an
// exactly first-order error).
TEST(StartupReference, MatchesDirectIntegration) {
  for (double r : {0.3, 2.0, 8.0}) {
    const StartupReference ref(r);
    const double h = 1e-3;
    const auto a = startup_brute_force(r, 10, h);
    const auto b = startup_brute_force(r, 10, h / 2);
    double worst_rich = 0, worst_ratio = 0;
    for (std::size_t k = 1; k < a.size(); ++k) {
      const double T = double(k) * h, exact = ref(T);
      worst_rich = std::max(worst_rich, std::abs(2 * b[2 * k] - a[k] - exact));
      const double diff = std::abs(a[k] - b[2 * k]);
      if (diff > 1e-6) worst_ratio = std::max(worst_ratio, std::abs(b[2 * k] - exact) / diff);
    }
    EXPECT_LT(worst_rich, 1e-4) << r;
    std::printf("r %g: Richardson error %.2e, u(h/2) error over the halving difference <= %.2f\n", r, worst_rich, worst_ratio);
    EXPECT_LT(worst_ratio, 1.5) << r;
  }
}

// The periodic-cube model: at short times it is the unbounded sphere plus
// the images' share F t / (3 rho V) (the kernel's 1/(3V)); at long times the
// velocity in the frame of zero momentum tends to Hasimoto's leading term,
// 1 - 2.8373 a / L (the Oseen lattice sum), to O(phi) (Hasimoto's next term is
// + phi: within 3 phi here); the kernel's two series agree at their switch.
TEST(StartupReference, PeriodicModel) {
  const double ell = 20, e3 = ell * ell * ell, phi = 4 * M_PI / 3 / e3;
  const double Tsw = ell * ell / (4 * M_PI);
  EXPECT_NEAR(periodic_kernel(ell, Tsw * (1 - 1e-9)) / periodic_kernel(ell, Tsw * (1 + 1e-9)), 1.0, 1e-8);
  EXPECT_NEAR(periodic_kernel(ell, 1.0) * 3 * e3, 1.0, 4 * phi);  // 3 / (1 - phi) - 2
  const double r = 2, h = 0.05;
  const auto v = startup_periodic(r, ell, 300, h);
  const StartupReference ref(r);
  {  // short times in a smaller cube (a larger share): the share 2 pi T / ell^3, to O(phi) of u
    const double l2 = 12, p2 = 4 * M_PI / 3 / (l2 * l2 * l2), h2 = 0.005;
    const auto vs = startup_periodic(r, l2, 4, h2);
    for (double T : {1.0, 2.0, 4.0}) {
      const auto k = static_cast<std::size_t>(std::lround(T / h2));
      const double share = 2 * M_PI * T / (l2 * l2 * l2);
      EXPECT_NEAR(vs[k] - ref(T), share, 2 * p2 * ref(T) + 2e-4) << T << ": share " << share;
    }
  }
  const auto k = static_cast<std::size_t>(std::lround(300 / h));
  const double lab = v[k] - 6 * M_PI * 300 / e3 / (1 + (r - 1) * phi);
  EXPECT_NEAR(lab, 1 - 2.837297 / ell, 3 * phi);
  // and steady: the last 100 t_nu change it by < 1e-4
  const auto k2 = static_cast<std::size_t>(std::lround(200 / h));
  EXPECT_NEAR(lab, v[k2] - 6 * M_PI * 200 / e3 / (1 + (r - 1) * phi), 1e-4);
}
