#include "imb/coupled_checks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <string>
#include <span>

#include "core/error.hpp"
#include "dem/contact.hpp"

namespace lbdem::imb {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.6g", v + 0.0);  // + 0.0: no "-0"
  return b;
}
std::string vec(const double* v) {
  std::string s("(");  // appended piecewise: GCC 12 warns (-Wrestrict, a false positive) on "(" + std::string
  for (int a = 0; a < 3; ++a) {
    s += num(v[a]);
    s += a < 2 ? ", " : ")";
  }
  return s;
}
const char* axis(int a) { return a == 0 ? "x" : a == 1 ? "y" : "z"; }

// Drag on a sphere of diameter d at speed u (Schiller-Naumann; Newton regime above Re = 1000).
double sphere_drag(double d, double rho_f, double nu, double u) {
  if (!(u > 0)) return 0;
  const double re = u * d / nu;
  const double cd = re < 1000 ? 24.0 / re * (1.0 + 0.15 * std::pow(re, 0.687)) : 0.44;
  return cd * 0.5 * rho_f * u * u * 0.25 * kPi * d * d;
}

double sphere_volume(double r) { return 4.0 / 3.0 * kPi * r * r * r; }

double norm3(const double* v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

// Terminal speeds of every particle at viscosity nu; the largest, and whose.
double max_settling(const dem::HostParticles& p, double rho_f, double nu, double g, std::int64_t* id) {
  double best = 0;
  if (id) *id = -1;
  if (!(g > 0)) return 0;
  for (std::size_t i = 0; i < p.r.size(); ++i) {
    const double u = terminal_speed(2 * p.r[i], p.mass[i], rho_f, nu, g);
    if (u > best) {
      best = u;
      if (id) *id = p.id.empty() ? static_cast<std::int64_t>(i) : p.id[i];
    }
  }
  return best;
}

std::size_t index_of(const dem::HostParticles& p, std::int64_t id) {
  for (std::size_t i = 0; i < p.id.size(); ++i)
    if (p.id[i] == id) return i;
  return static_cast<std::size_t>(id);
}

}  // namespace

double terminal_speed(double d, double m, double rho_f, double nu, double g) {
  const double w = (m - rho_f * sphere_volume(0.5 * d)) * g;
  if (!(w > 0) || !(nu > 0)) return 0;
  // Drag grows monotonically with u: bisect on [0, hi].
  double lo = 0, hi = w / (3 * kPi * rho_f * nu * d);  // Stokes speed: an upper bound
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (sphere_drag(d, rho_f, nu, mid) < w ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

CoupledScales coupled_scales(const lbm::LbmSetup& fluid, const dem::DemParams& dem, const dem::HostParticles& p,
                             const CoupledParams& cp) {
  CoupledScales s;
  s.nu = (fluid.tau - 0.5) / 3.0;
  for (std::size_t i = 0; i < p.r.size(); ++i) {
    const double v[3] = {p.v[i].x, p.v[i].y, p.v[i].z};
    double sp = norm3(v);
    if (i < p.w.size()) {
      const double w[3] = {p.w[i].x, p.w[i].y, p.w[i].z};
      sp += norm3(w) * p.r[i];
    }
    if (sp > s.particle_speed) {
      s.particle_speed = sp;
      s.fastest_id = p.id.empty() ? static_cast<std::int64_t>(i) : p.id[i];
    }
  }
  s.settling_speed = max_settling(p, cp.fluid_density, s.nu, norm3(cp.gravity.data()), &s.settling_id);
  for (int k = 0; k < fluid.boundaries.count; ++k)
    if (fluid.boundaries.kind[k] == lbm::BoundaryKind::Velocity)
      s.wall_speed = std::max(s.wall_speed, norm3(fluid.boundaries.u[k]));
  s.u_ref = std::max({s.particle_speed, s.settling_speed, s.wall_speed});
  s.mach = s.u_ref * std::sqrt(3.0);
  s.cell_reynolds = s.nu > 0 ? s.u_ref / s.nu : std::numeric_limits<double>::infinity();
  s.collision_time = dem::min_collision_time(dem, p);
  if (std::isfinite(s.collision_time) && s.collision_time > 0) {
    // In double first: absurdly stiff contacts ask for more sub-steps than an int holds (then refused below).
    const double need = std::ceil(dem.min_steps_per_collision / s.collision_time - 1e-9);
    s.min_substeps = need >= static_cast<double>(std::numeric_limits<int>::max())
                         ? std::numeric_limits<int>::max()
                         : std::max(1, static_cast<int>(need));
  }
  return s;
}

CoupledScales check_coupled_setup(const lbm::LbmSetup& fluid, const dem::DemParams& dem, const dem::HostParticles& p,
                                  const CoupledParams& cp, const CoupledLimits& lim, const halo::Comm* comm) {
  const int dim = fluid.lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  const CoupledKeys& k = cp.keys;
  // 1. Consistency.
  if (cp.dem_substeps < 1)
    throw ConfigError(k.dem_substeps + " = " + std::to_string(cp.dem_substeps) +
                      ": the DEM needs at least one step per fluid step; use 1 or more");
  if (!(std::abs(dem.dt * cp.dem_substeps - 1.0) <= 1e-9))
    throw ConfigError(k.dem_dt + " = " + num(dem.dt) + " (lattice units) with " + k.dem_substeps + " = " +
                      std::to_string(cp.dem_substeps) + ": the DEM sub-steps must span one fluid step (dt_fluid = 1); use " +
                      k.dem_dt + " = 1/" + std::to_string(cp.dem_substeps) + " = " + num(1.0 / cp.dem_substeps));
  {
    const double gd[3] = {dem.gravity.x, dem.gravity.y, dem.gravity.z};
    const double scale = std::max(norm3(gd), norm3(cp.gravity.data()));
    for (int a = 0; a < 3; ++a)
      if (std::abs(gd[a] - cp.gravity[static_cast<std::size_t>(a)]) > 1e-12 * scale)
        throw ConfigError(k.gravity + " = " + vec(cp.gravity.data()) + " differs from " + k.dem_gravity + " = " +
                          vec(gd) + ": the particles' weight comes from the DEM and their buoyancy from the coupling, "
                          "so both must be the same vector; set " + k.gravity + " = " + vec(gd));
  }
  for (int a = 0; a < dim; ++a) {
    const auto i = static_cast<std::size_t>(a);
    const std::string ax = std::string("[") + axis(a) + "]";
    if (fluid.domain.periodic[i] != dem.periodic[i])
      throw ConfigError("domain.periodic" + ax + " = " + (fluid.domain.periodic[i] ? "true" : "false") + " but " +
                        k.dem_periodic + ax + " = " + (dem.periodic[i] ? "true" : "false") +
                        ": the fluid's particle images and the DEM's must wrap on the same axes; set both to " +
                        (dem.periodic[i] ? "true" : "false"));
    if (!fluid.domain.periodic[i]) continue;
    const double n = static_cast<double>(fluid.domain.global[i]);
    if (std::abs(dem.lo[i]) > 1e-9 || std::abs(dem.hi[i] - n) > 1e-9)
      throw ConfigError(k.dem_lo + ax + ", " + k.dem_hi + ax + " = " + num(dem.lo[i]) + ", " + num(dem.hi[i]) +
                        ": on a periodic axis the DEM box must be the lattice's, [0, " + num(n) +
                        ") in lattice units (particles wrap at the same length in the fluid and in the DEM); use " +
                        k.dem_lo + ax + " = 0, " + k.dem_hi + ax + " = " + num(n));
  }
  if (!(fluid.tau > 0.5))
    throw ConfigError("fluid.tau = " + num(fluid.tau) + ": must be > 0.5 (viscosity (tau - 1/2)/3 > 0)");

  // Light particles: the explicit coupling diverges.
  for (std::size_t i = 0; i < p.r.size(); ++i) {
    const double ratio = p.mass[i] / (sphere_volume(p.r[i]) * cp.fluid_density);
    if (ratio < lim.min_density_ratio)
      throw ConfigError("particles: particle id " + std::to_string(p.id.empty() ? static_cast<std::int64_t>(i) : p.id[i]) +
                        " has density ratio rho_s/rho_f = " + num(ratio) + " below " + num(lim.min_density_ratio) +
                        ": the explicit PSM coupling (the force of one fluid step held over the next DEM sub-steps) "
                        "diverges for particles much lighter than the fluid they displace (measured: 0.3 blows up "
                        "within 100 steps, 0.4 at tau 1.5); use particles at least " + num(lim.min_density_ratio) +
                        " times as dense as the fluid");
  }

  CoupledScales s = coupled_scales(fluid, dem, p, cp);

  // 2. DEM sub-steps against the shortest contact.
  if (cp.dem_substeps < s.min_substeps)
    throw ConfigError(k.dem_substeps + " = " + std::to_string(cp.dem_substeps) + " gives a DEM time step of " +
                      num(1.0 / cp.dem_substeps) + " (lattice units) but the shortest contact lasts t_c = " +
                      num(s.collision_time) + " and needs at least " + num(dem.min_steps_per_collision) +
                      " DEM steps; use " + k.dem_substeps + " >= " + std::to_string(s.min_substeps) + " (with " +
                      k.dem_dt + " = 1/" + std::to_string(s.min_substeps) + ") or soften the contacts (" + k.stiffness +
                      ")");

  // 3. Velocity scale: Mach number and cell Reynolds number.
  const double u_mach = lim.max_mach / std::sqrt(3.0);
  if (s.mach > lim.max_mach) {
    std::string what;
    if (s.u_ref == s.particle_speed) {
      what = "particles: particle id " + std::to_string(s.fastest_id) + " starts at speed |v| + |w| r = " +
             num(s.particle_speed) + " (lattice units)";
    } else if (s.u_ref == s.settling_speed) {
      what = k.gravity + " = " + vec(cp.gravity.data()) + ": particle id " + std::to_string(s.settling_id) +
             " would settle at about " + num(s.settling_speed) + " relative to the fluid (Schiller-Naumann terminal speed)";
    } else {
      what = "fluid.boundaries: a velocity boundary moves at " + num(s.wall_speed);
    }
    std::string fix = "keep every velocity below " + num(u_mach) + " (lattice units), i.e. choose a smaller lattice time step";
    if (s.u_ref == s.settling_speed) {
      const std::size_t i = index_of(p, s.settling_id);
      const double d = 2 * p.r[i];
      const double w_unit = p.mass[i] - cp.fluid_density * sphere_volume(p.r[i]);
      const double g_max = sphere_drag(d, cp.fluid_density, s.nu, u_mach) / w_unit;
      fix = "use |gravity| <= " + num(g_max) + " (lattice units; it scales with dt^2), or a larger viscosity";
    }
    throw ConfigError(what + ": Mach number u sqrt(3) = " + num(s.mach) + " exceeds " + num(lim.max_mach) +
                      ", beyond which the weakly compressible LBM with PSM diverges (measured: a sphere at Ma 0.43 "
                      "blows up within 200 steps); " + fix);
  }
  if (s.cell_reynolds > lim.max_cell_reynolds) {
    // Smallest tau that passes; settling speeds fall as the viscosity rises.
    auto re_at = [&](double tau) {
      const double nu = (tau - 0.5) / 3.0;
      const double u = std::max({s.particle_speed, s.wall_speed,
                                 max_settling(p, cp.fluid_density, nu, norm3(cp.gravity.data()), nullptr)});
      return u / nu;
    };
    double lo = fluid.tau, hi = fluid.tau;
    while (re_at(hi) > lim.max_cell_reynolds && hi < 1e6) hi = 0.5 + 2 * (hi - 0.5);
    for (int it = 0; it < 100; ++it) {
      const double mid = 0.5 * (lo + hi);
      (re_at(mid) > lim.max_cell_reynolds ? lo : hi) = mid;
    }
    const std::string source = s.u_ref == s.particle_speed
                                   ? "the initial speed of particle id " + std::to_string(s.fastest_id)
                                   : s.u_ref == s.settling_speed
                                         ? "the settling speed of particle id " + std::to_string(s.settling_id) +
                                               " under " + k.gravity
                                         : "a velocity boundary";
    throw ConfigError("fluid.tau = " + num(fluid.tau) + " (nu = " + num(s.nu) + "): with the velocity scale u = " +
                      num(s.u_ref) + " (" + source + ") the cell Reynolds number u dx / nu = " + num(s.cell_reynolds) +
                      " exceeds " + num(lim.max_cell_reynolds) +
                      "; the flow is not resolved on the lattice and the PSM-LBM diverges (measured: tau 0.501 with a "
                      "sphere at u 0.035, cell Reynolds 105); use fluid.tau >= " + num(hi) +
                      " or velocities below " + num(lim.max_cell_reynolds * s.nu));
  }

  // 4. Net force in a fully periodic domain.
  bool fully_periodic = fluid.boundaries.count == 0;
  for (int a = 0; a < dim; ++a) fully_periodic = fully_periodic && fluid.domain.periodic[static_cast<std::size_t>(a)];
  if (fully_periodic) {
    double total = 1;
    for (int a = 0; a < dim; ++a) total *= static_cast<double>(fluid.domain.global[static_cast<std::size_t>(a)]);
    double weight[3] = {0, 0, 0}, scale = 0;
    const double g[3] = {cp.gravity[0], cp.gravity[1], cp.gravity[2]};
    const double fb[3] = {dem.body_force.x, dem.body_force.y, dem.body_force.z};
    for (std::size_t i = 0; i < p.r.size(); ++i) {
      const double r = p.r[i];
      // The DEM's mass (its gravity's; a sphere's also in 2D) and the buoyancy's
      // volume (2D: the disk's area), as balancing_body_force.
      const double v = dim == 3 ? sphere_volume(r) : kPi * r * r;
      const double m = p.mass[i];
      for (int a = 0; a < 3; ++a) weight[a] += (m - cp.fluid_density * v) * g[a] + fb[a];
      scale += std::abs(m - cp.fluid_density * v) * norm3(g) + norm3(fb);
    }
    double solid_mass = 0;
    for (double m : p.mass) solid_mass += m;
    if (comm) {  // every rank's particles (each rank holds its own)
      double v[5] = {weight[0], weight[1], weight[2], scale, solid_mass};
      comm->sum(std::span<double>(v, 5));
      for (int a = 0; a < 3; ++a) weight[a] = v[a];
      scale = v[3];
      solid_mass = v[4];
    }
    // Fluid and particles together receive the body force on every cell
    // (PsmOptions::body_force_on_solid, which CoupledSolver turns on).
    double net[3], fix[3];
    for (int a = 0; a < 3; ++a) {
      net[a] = weight[a] + fluid.body_force[static_cast<std::size_t>(a)] * total;
      fix[a] = -weight[a] / total;
    }
    scale += norm3(fluid.body_force.data()) * total;
    if (scale > 0 && norm3(net) > lim.max_force_imbalance * scale) {
      const double mass = cp.fluid_density * total + solid_mass;
      throw ConfigError(k.body_force + " = " + vec(fluid.body_force.data()) +
                        " does not balance the particles' net weight in this fully periodic domain: the net force " +
                        vec(net) + " accelerates the whole system by " + num(norm3(net) / mass) +
                        " per step without bound (Mach limit reached after about " +
                        num(u_mach / (norm3(net) / mass)) + " steps); use " + k.body_force + " = " + vec(fix) +
                        " (balancing_body_force(), first paper Sec. 2)");
    }
  }
  return s;
}

}  // namespace lbdem::imb
