// SI keys of a resolved scene in lattice units (imb/physical_units.hpp).
#include "imb/physical_units.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace lbdem::imb {

PhysicalGrid read_physical_grid(const Config& root, const Config& d, const Config& f, const Config& pc,
                                const Config& t) {
  PhysicalGrid g;
  const double d_si = pc.positive("diameter");
  const double cpd = pc.number_in("cells_per_diameter", 2.0, 1000.0,
                                  "particle diameter in cells, d/l (the first paper uses 10)");
  UnitsRequest ur;
  ur.dx = d_si / cpd;
  ur.rho = f.positive("density");
  ur.nu = f.positive("kinematic_viscosity");
  if (f.has("tau")) ur.tau = f.number("tau");
  if (t.has("dt")) ur.dt = t.positive("dt");
  f.accept("tau");
  t.accept("dt");
  ur.u_ref = 0;  // the particle speeds are checked against the Mach limit by the scene, in lattice units
  ur.where = root.source();
  ur.tau_key = "fluid.tau";
  ur.dt_key = "time.dt";
  const Units U = derive_units(ur);
  g.units = U;
  if (!(U.tau <= 5.0))
    (ur.tau ? f : t).fail(ur.tau ? "tau" : "dt", "gives tau = " + std::to_string(U.tau) +
                                                       ": at most 5 (the lattice viscosity (tau - 1/2)/3 "
                                                       "is too large to resolve); use a smaller time step");
  g.cells_per_diameter = cpd;  // exactly: dx = d / (d/l)
  // domain.cells is not a key here (the scene's finish() refuses it): the
  // grid follows from domain.size and particles.cells_per_diameter.
  const auto size = d.numbers("size", 2, 3);
  for (std::size_t a = 0; a < size.size(); ++a) {
    const double n = size[a] / U.dx;
    const double nr = std::round(n);
    if (!(size[a] > 0) || !(nr >= 1) || !(nr <= double(1 << 20)) || std::abs(n - nr) > 1e-6 * nr)
      d.fail("size", "must be a whole number of cells of dx = particles.diameter / particles.cells_per_diameter = " +
                         std::to_string(U.dx) + " m along each axis (" + std::to_string(n) + " cells along " +
                         std::string(1, char('x' + a)) + "; e.g. " + std::to_string(std::max(1.0, nr) * U.dx) +
                         " m), 1 to 2^20 cells");
    g.cells.push_back(static_cast<long>(nr));
  }
  return g;
}

long read_coupled_steps(const Config& t, const Units& U, bool physical) {
  if (!physical) return t.integer_in("steps", 0, std::numeric_limits<long>::max());
  if (t.has("steps") == t.has("end"))
    t.fail(t.has("steps") ? "end" : "steps", "give exactly one of 'time.steps' (a step count) or 'time.end' (seconds)");
  if (t.has("steps")) return t.integer_in("steps", 0, std::numeric_limits<long>::max());
  const double steps = U.to_lattice_time(t.positive("end"));
  if (!(steps < 1e15)) t.fail("end", "is " + std::to_string(steps) + " time steps of " + std::to_string(U.dt) + " s; at most 1e15");
  return std::max<long>(1, std::lround(steps));
}

}  // namespace lbdem::imb
