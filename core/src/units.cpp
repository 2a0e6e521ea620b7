#include "core/units.hpp"

#include <cmath>
#include <sstream>

#include "core/error.hpp"

namespace lbdem {

namespace {
std::string g(double v) {
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}
}  // namespace

Units derive_units(const UnitsRequest& r) {
  Units u;
  u.dx = r.dx;
  u.rho = r.rho;
  if (r.tau && r.dt)
    throw ConfigError(r.where + ": give either '" + r.tau_key + "' or '" + r.dt_key + "', not both (one follows from the other)");
  if (r.tau) {
    u.tau = *r.tau;
    if (!(u.tau > 0.5))
      throw ConfigError(r.where + ": key '" + r.tau_key + "' = " + g(u.tau) +
                        ": must be > 0.5 (lattice viscosity (tau-1/2)/3 must be positive); 0.55..2 is typical");
    u.dt = u.nu_lattice() * r.dx * r.dx / r.nu;
  } else if (r.dt) {
    u.dt = *r.dt;
    u.tau = 0.5 + 3.0 * r.nu * u.dt / (r.dx * r.dx);
    if (!(u.tau > 0.5 + 1e-9))
      throw ConfigError(r.where + ": key '" + r.dt_key + "' = " + g(u.dt) + " s gives tau = " + g(u.tau) +
                        ": must give tau > 0.5; increase dt");
  } else {
    throw ConfigError(r.where + ": missing '" + r.tau_key + "' (or '" + r.dt_key + "'): one of them sets the time step");
  }
  const double ma = u.mach(r.u_ref);
  if (ma > r.max_mach) {
    // Ma scales with dt: the largest dt (and tau) meeting the limit.
    const double dt_ok = r.max_mach / 1.7320508075688772 * r.dx / r.u_ref;
    const double tau_ok = 0.5 + 3.0 * r.nu * dt_ok / (r.dx * r.dx);
    throw ConfigError(r.where + ": lattice Mach number " + g(ma) + " (reference speed " + g(r.u_ref) +
                      " m/s, dt = " + g(u.dt) + " s, tau = " + g(u.tau) + ") exceeds the limit " + g(r.max_mach) +
                      ": the run would be inaccurate or unstable. Reduce '" + r.tau_key + "' to at most " +
                      g(tau_ok) + " (dt <= " + g(dt_ok) + " s), or refine the grid");
  }
  return u;
}

}  // namespace lbdem
