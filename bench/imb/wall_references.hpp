#pragma once
// Published wall corrections of the Stokes drag on a sphere, the references of
// issue 29's wall cases (a sphere moving toward a plane wall, a sphere on the
// axis of a tube). F = 6 pi mu a U times the factor.
#include <cmath>

namespace lbdem::bench {

// Brenner (1961, Chem. Eng. Sci. 16, 242), Eq. 2.19: a sphere of radius a whose
// centre is at distance h > a from a plane no-slip wall, moving along the wall
// normal in a fluid at rest (exact Stokes solution in bispherical
// coordinates):
//   lambda = (4/3) sinh(alpha) sum_{n>=1} n(n+1) / ((2n-1)(2n+3)) *
//            [ (2 sinh((2n+1) alpha) + (2n+1) sinh(2 alpha)) /
//              (4 sinh^2((n+1/2) alpha) - (2n+1)^2 sinh^2(alpha)) - 1 ],
//   alpha = arccosh(h / a).
// The terms fall like e^{-(2n-1) alpha}... slowly near contact (alpha -> 0):
// summed until a term is below 1e-14 of the sum (at most 100000 terms).
inline double brenner_lambda(double h_over_a) {
  const double al = std::acosh(h_over_a);
  const double s1 = std::sinh(al), s2 = std::sinh(2 * al);
  double sum = 0;
  for (int n = 1; n <= 100000; ++n) {
    const double k = 2.0 * n + 1;
    const double sh = std::sinh((n + 0.5) * al);
    const double num = 2 * std::sinh(k * al) + k * s2;
    const double den = 4 * sh * sh - k * k * s1 * s1;
    const double term = double(n) * (n + 1) / ((2.0 * n - 1) * (2.0 * n + 3)) * (num / den - 1);
    sum += term;
    if (std::abs(term) < 1e-14 * std::abs(sum) || !std::isfinite(num)) break;
  }
  return 4.0 / 3.0 * s1 * sum;
}

// Haberman & Sayre (1958, David Taylor Model Basin Rep. 1143): a sphere of
// diameter d moving along the axis of a long tube of diameter D at rest, the
// fluid at rest far away (no net flow through the tube), k = d / D < 1:
//   K = (1 - 0.75857 k^5) / (1 - 2.1050 k + 2.0865 k^3 - 1.7068 k^5 + 0.72603 k^6).
// For small k it is Faxen's / Bohlin's series, K = 1 + 2.1050 k + O(k^2).
inline double haberman_sayre_K(double k) {
  const double k2 = k * k, k3 = k2 * k, k5 = k3 * k2, k6 = k3 * k3;
  return (1 - 0.75857 * k5) / (1 - 2.1050 * k + 2.0865 * k3 - 1.7068 * k5 + 0.72603 * k6);
}

}  // namespace lbdem::bench
