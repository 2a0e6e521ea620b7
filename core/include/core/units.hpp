#pragma once
// Physical units in, lattice units inside.
//
// A case gives the cell size dx [m], the fluid's kinematic viscosity nu
// [m^2/s] and density rho [kg/m^3], and either the relaxation time tau or the
// time step dt [s]. The missing one follows from nu_lattice = (tau - 1/2)/3 =
// nu dt / dx^2. A reference speed U [m/s] (the fastest flow the case
// expects) gives the lattice Mach number Ma = (U dt/dx) / cs, cs = 1/sqrt(3).
// Cases with tau <= 1/2 (negative viscosity) or Ma above the limit
// (compressibility error ~ Ma^2, instability) are refused, naming the key and
// what to change.
#include <optional>
#include <string>

namespace lbdem {

struct Units {
  double dx = 1;   // m per lattice length
  double dt = 1;   // s per step
  double rho = 1;  // kg/m^3 per lattice density unit
  double tau = 1;  // relaxation time (lattice)
  double nu_lattice() const { return (tau - 0.5) / 3.0; }
  double to_lattice_velocity(double u) const { return u * dt / dx; }
  double to_si_velocity(double u) const { return u * dx / dt; }
  double to_lattice_acceleration(double a) const { return a * dt * dt / dx; }
  // Pressure deviation from p0: p = cs^2 (rho - 1) rho_si dx^2/dt^2.
  double to_si_pressure(double drho) const { return drho / 3.0 * rho * dx * dx / (dt * dt); }
  double mach(double u_si) const { return to_lattice_velocity(u_si) * 1.7320508075688772; }
  // Mass unit: the fluid mass of one cell, rho dx^3 [kg] (lattice fluid density 1).
  double dm() const { return rho * dx * dx * dx; }
  double to_lattice_length(double x) const { return x / dx; }
  double to_lattice_time(double t) const { return t / dt; }
  double to_lattice_density(double r) const { return r / rho; }
  double to_lattice_mass(double m) const { return m / dm(); }
  // A spring constant k [N/m = kg/s^2] in lattice units: k dt^2 / dm.
  double to_lattice_stiffness(double k) const { return k * dt * dt / dm(); }
  double to_lattice_angular_velocity(double w) const { return w * dt; }
  // Lattice units: every conversion above is the identity, bitwise.
  static Units lattice() { return Units{}; }
};

struct UnitsRequest {
  double dx = 0;
  double nu = 0;
  double rho = 0;
  std::optional<double> tau;
  std::optional<double> dt;
  double u_ref = 0;         // m/s, for the Mach check
  double max_mach = 0.3;
  std::string where;        // file and section, for messages
  std::string tau_key = "collision.tau";
  std::string dt_key = "time.dt";
};

// Throws ConfigError naming the key, the value and the valid range.
Units derive_units(const UnitsRequest& r);

}  // namespace lbdem
