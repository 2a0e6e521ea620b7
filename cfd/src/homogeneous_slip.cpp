// The Wen-Yu homogeneous slip (cfd/homogeneous_slip.hpp).
#include "cfd/homogeneous_slip.hpp"

#include <cmath>

#include "cfd/drag.hpp"

namespace lbdem::cfd {

namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

double wen_yu_drag(double phi, double d, double rho_f, double mu, double w) {
  const double eps = 1.0 - phi;
  const double re = eps * rho_f * d * w / mu;
  return 3 * kPi * mu * d * eps * w * drag_wen_yu(phi, re);
}

double wen_yu_slip(double phi, double d, double rho_f, double mu, double net_weight) {
  if (!(net_weight > 0) || !(phi >= 0 && phi < 1) || !(mu > 0) || !(d > 0)) return 0;
  // The drag grows monotonically with w: bracket from the Stokes limit (an
  // upper bound, the inertial factor being >= 1) and bisect.
  double hi = net_weight * std::pow(1 - phi, 2.65) / (3 * kPi * mu * d), lo = 0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (wen_yu_drag(phi, d, rho_f, mu, mid) < net_weight ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace lbdem::cfd
