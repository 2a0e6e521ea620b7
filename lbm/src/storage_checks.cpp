#include "lbm/storage_checks.hpp"

#include <cmath>
#include <cstdio>

namespace lbdem::lbm {

namespace {

constexpr double kPi = 3.14159265358979323846;
// Above this estimated steady velocity error the case gets a warning.
constexpr double kMaxSteadyError = 1e-2;
// tau - 1/2 below this: the rounding noise is hardly damped.
constexpr double kMinTauMinusHalf = 0.05;
// Runs at least this long get the mass-conservation warning.
constexpr double kLongRunSteps = 1e5;

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", v);
  return b;
}

}  // namespace

double storage_unit_roundoff(Precision p) {
  switch (p) {
    case Precision::FP16S: return std::ldexp(1.0, -11);
    case Precision::FP16C: return std::ldexp(1.0, -12);
    case Precision::FP32: return std::ldexp(1.0, -24);
    case Precision::FP64: break;
  }
  return std::ldexp(1.0, -53);
}

double steady_storage_error(Precision p, double length, double nu) {
  return storage_unit_roundoff(p) * length * length / (4 * kPi * kPi * nu);
}

std::vector<std::string> storage_warnings(const LbmSetup& s, double u_ref, double length, double steps) {
  std::vector<std::string> w;
  if (s.precision != Precision::FP16S && s.precision != Precision::FP16C) return w;
  const bool c = s.precision == Precision::FP16C;
  const std::string head = std::string("precision: ") + to_string(s.precision) + ": ";
  const std::string better = c ? "use precision: fp32" : "use precision: fp16c (half the rounding error) or fp32";
  const double nu = (s.tau - 0.5) / 3.0;
  const double e = steady_storage_error(s.precision, length, nu);
  if (e > kMaxSteadyError)
    w.push_back(head + "a steady or slowly varying flow stalls where the change per step of a population falls below "
                "its 16-bit spacing; expected velocity error about " + num(100 * e) + " % (u16 L^2 / (4 pi^2 nu), L = " +
                num(length) + " cells, nu = " + num(nu) + "); " + better + ", or raise tau");
  const double u_normal = 12.0 * std::ldexp(1.0, -14);  // 3 w u = 2^-14 at w = 1/36
  if (u_ref > 0 && u_ref < u_normal) {
    const double spacing = std::ldexp(1.0, c ? -25 : -24) * 12.0;  // subnormal spacing / (3 w)
    w.push_back(head + "the reference speed " + num(u_ref) + " (lattice units, Mach " + num(u_ref * std::sqrt(3.0)) +
                ") is below " + num(u_normal) + ", where the velocity part of the populations is under the smallest "
                "normal 16-bit value: velocities are resolved only to " + num(spacing) + " (" +
                num(100 * spacing / u_ref) + " % of the reference speed); raise the lattice speed (a larger time step) "
                "or use precision: fp32");
  }
  if (s.tau - 0.5 < kMinTauMinusHalf)
    w.push_back(head + "tau = " + num(s.tau) + " is close to 1/2: the collision hardly damps the rounding noise of the "
                "16-bit stores (each step keeps " + num(std::abs(1 - 1 / s.tau)) + " of a perturbation); " + better +
                ", or raise tau above " + num(0.5 + kMinTauMinusHalf));
  if (steps >= kLongRunSteps)
    w.push_back(head + "a run of " + num(steps) + " steps: 16-bit rounding of the stores does not conserve mass in "
                "steps where the flow changes; watch the mass change in the diagnostics or use precision: fp32");
  return w;
}

}  // namespace lbdem::lbm
