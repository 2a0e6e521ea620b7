// The reader of a case file's `gas` section (cfd/gas_reader.hpp).
#include "cfd/gas_reader.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "core/error.hpp"
#include "core/run_checks.hpp"

namespace lbdem::cfd {

namespace {

const char* const kFaceNames[6] = {"x_lo", "x_hi", "y_lo", "y_hi", "z_lo", "z_hi"};

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.6g", v + 0.0);
  return b;
}
Vec3d vec3(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

}  // namespace

void read_gas(const Config& gs, const std::array<double, 3>& lo, const std::array<double, 3>& hi, Backend backend,
              GasSection& c) {
  GasParams& p = c.gas;
  p.rho = gs.positive("density");
  p.mu = gs.positive("viscosity");
  const double h = gs.positive("cell_size");
  double cells = 1;
  for (int a = 0; a < 3; ++a) {
    const double L = hi[static_cast<std::size_t>(a)] - lo[static_cast<std::size_t>(a)];
    const double n = std::round(L / h);
    if (!(n >= 1) || !(n < 1e9) || std::fabs(n * h - L) > 1e-6 * L)
      gs.fail("cell_size", "cubic cells must fill the box: the box is " + num(L) + " m along " +
                               std::string(1, "xyz"[a]) + " (domain.lo, domain.hi), " + num(L / h) +
                               " cells of this size; choose a size that divides every side");
    c.grid.n[a] = static_cast<int>(n);
    c.grid.origin[a] = lo[static_cast<std::size_t>(a)];
    cells *= n;
  }
  c.grid.h = h;
  // Device memory of the gas: 3 x 3 face arrays, ~20 cell arrays and the
  // fixed-point accumulators, in doubles.
  check_memory(gs, backend, cells * 8 * 36, cells * 8 * 8, gs.full_key("cell_size"), num(cells) + " gas cells",
               "use larger cells");
  p.dt = gs.positive("dt");
  p.drag = parse_drag_law(gs.full_key("drag"),
                               gs.choice("drag", "gidaspow", {"gidaspow", "wen_yu", "di_felice", "beetstra", "tenneti"}));
  p.deposition = parse_deposition(gs.full_key("void_fraction"),
                                       gs.choice("void_fraction", "linear", {"centroid", "linear", "quadratic"}));
  p.min_gas_fraction = gs.number_in("min_gas_fraction", 0.2, 0.01, 0.99,
                                    "floor of the gas fraction used by the gas equations and the drag");
  c.lagged_forces = gs.choice("force_coupling", "sequential", {"sequential", "lagged"}) == "lagged";
  c.initial_velocity = vec3(gs.numbers("initial_velocity", {0, 0, 0}, 3, 3));
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(c.initial_velocity[a]) || std::fabs(c.initial_velocity[a]) * p.dt > 0.5 * h)
      gs.fail("initial_velocity", "each component must be finite with |u| gas.dt / gas.cell_size <= 1/2");
  {
    const Config b = gs.section("boundaries");
    for (int s = 0; s < 6; ++s) {
      FaceBC& f = p.faces[static_cast<std::size_t>(s)];
      const std::string name = kFaceNames[s];
      if (!b.has(name)) {
        f.kind = FaceKind::NoSlipWall;
        continue;
      }
      const Config fc = b.section(name);
      f.kind = parse_face_kind(fc.full_key("type"),
                                    fc.choice("type", {"periodic", "no_slip", "free_slip", "inlet", "outlet"}));
      if (f.kind == FaceKind::Inlet) {
        f.inflow = fc.number_in("velocity", 0.0, 1e4, "superficial speed into the domain [m/s]");
        if (const auto pc = fc.optional_section("patch")) {
          f.patch = true;
          const auto plo = pc->numbers("lo", 2, 2), phi = pc->numbers("hi", 2, 2);
          int t = 0;
          for (int a = 0; a < 3; ++a) {
            if (a == s / 2) continue;
            const auto k = static_cast<std::size_t>(a);
            if (!(plo[static_cast<std::size_t>(t)] < phi[static_cast<std::size_t>(t)]) ||
                plo[static_cast<std::size_t>(t)] < lo[k] || phi[static_cast<std::size_t>(t)] > hi[k])
              pc->fail("hi", "the patch [lo, hi] along the face's two other axes (x, y, z order) must be a non-empty "
                             "rectangle inside the face (domain.lo, domain.hi)");
            f.patch_lo[t] = plo[static_cast<std::size_t>(t)];
            f.patch_hi[t] = phi[static_cast<std::size_t>(t)];
            ++t;
          }
          f.patch_inflow = pc->number_in("velocity", 0.0, 1e4, "superficial speed into the domain [m/s]");
          // The patch must cover at least one face centre, or it has no effect.
          int covered = 1;
          t = 0;
          for (int a = 0; a < 3; ++a) {
            if (a == s / 2) continue;
            int m = 0;
            for (int i = 0; i < c.grid.n[a] && i < 1000000; ++i) {
              const double x = lo[static_cast<std::size_t>(a)] + (i + 0.5) * h;
              if (x >= f.patch_lo[t] && x <= f.patch_hi[t]) ++m;
            }
            covered *= m;
            ++t;
          }
          if (covered == 0)
            pc->fail("hi", "the patch covers no gas-cell face centre (cells of " + num(h) +
                               " m, gas.cell_size): make it larger or the cells smaller");
          pc->finish();
        }
      } else if (f.kind == FaceKind::Outlet) {
        f.pressure = fc.number_in("pressure", 0.0, -1e9, 1e9, "gauge pressure at the outlet [Pa]");
      }
      fc.finish();
    }
    b.finish();
    for (int a = 0; a < 3; ++a) {
      const bool plo = p.faces[static_cast<std::size_t>(2 * a)].kind == FaceKind::Periodic;
      const bool phi = p.faces[static_cast<std::size_t>(2 * a + 1)].kind == FaceKind::Periodic;
      if (plo != phi)
        b.fail(plo ? kFaceNames[2 * a + 1] : kFaceNames[2 * a],
               std::string("a periodic axis needs both faces periodic (") + kFaceNames[2 * a] + " and " +
                   kFaceNames[2 * a + 1] + ")");
      c.grid.periodic[a] = plo;
    }
  }
  if (const auto ps = gs.optional_section("pressure_solver")) {
    p.pressure_solver = parse_pressure_solver(ps->full_key("type"), ps->choice("type", "cg", {"cg", "multigrid"}));
    p.cg_tolerance = ps->number_in("tolerance", 1e-10, 1e-15, 1e-2,
                                   "sqrt(r^T D^-1 r / b^T D^-1 b), D the diagonal: the same measure for cg and multigrid");
    p.cg_max_iterations = static_cast<int>(ps->integer_in("max_iterations", 2000, 1, 1000000));
    p.cg_poll_every = static_cast<int>(ps->integer_in("poll_every", 25, 1, 100000));
    p.pressure_graphs = ps->boolean("graphs", true);
    ps->finish();
  }
  gs.finish();
  // GasParams' own checks (an outlet, the time step's limits), naming the keys read above.
  const std::string solver = gs.full_key("pressure_solver");
  validate(p, c.grid,
           {.rho = gs.full_key("density"), .mu = gs.full_key("viscosity"), .dt = gs.full_key("dt"),
            .min_gas_fraction = gs.full_key("min_gas_fraction"), .cg_max_iterations = solver + ".max_iterations",
            .cg_tolerance = solver + ".tolerance", .cg_poll_every = solver + ".poll_every",
            .pressure_solver = solver + ".type", .boundaries = gs.full_key("boundaries")},
           gs.source());
}

int read_bed_dem(const Config& root, double gas_dt, double rmin, const dem::HostParticles& particles,
                 dem::DemParams& p) {
  int substeps = 1;
  const auto dc = root.optional_section("dem");
  p.skin = 0.2 * rmin;
  p.path = dem::ForcePath::Particle;
  const double tc = dem::min_collision_time(p, particles);
  std::string key = "dem.steps_per_collision";
  const int given = (dc && dc->has("substeps")) + (dc && dc->has("dt")) + (dc && dc->has("steps_per_collision"));
  if (given > 1) dc->fail("substeps", "give one of dem.substeps, dem.dt, dem.steps_per_collision");
  if (dc && dc->has("substeps")) {
    substeps = static_cast<int>(dc->integer_in("substeps", 1, 1000000));
    key = "dem.substeps";
  } else if (dc && dc->has("dt")) {
    // The largest DEM step that divides the gas step and is not above dem.dt.
    const double n = std::ceil(gas_dt / dc->positive("dt") - 1e-9);
    if (!(n <= 1e6)) dc->fail("dt", "needs more than 1e6 DEM sub-steps per gas step (gas.dt / dem.dt)");
    substeps = static_cast<int>(std::max(1.0, n));
    key = "dem.dt";
  } else {
    const double spc = dc ? dc->number_in("steps_per_collision", 50.0, 5.0, 1e6) : 50.0;
    p.min_steps_per_collision = std::min(spc, p.min_steps_per_collision);
    const double n = std::isfinite(tc) ? std::ceil(gas_dt * spc / tc) : 1.0;
    if (!(n <= 1e6))
      throw ConfigError(root.source() + ": " + key + ": gas.dt = " + num(gas_dt) + " s over t_c / " + num(spc) +
                        " (t_c = " + num(tc) + " s from material.stiffness and the radii) needs " + num(n) +
                        " DEM sub-steps per gas step (at most 1e6): lower gas.dt or soften the contacts");
    substeps = static_cast<int>(std::max(1.0, n));
  }
  if (dc) {
    p.skin = dc->positive("skin", p.skin);
    p.path = dc->choice("force_path", "particle", {"particle", "pair"}) == "pair" ? dem::ForcePath::Pair
                                                                               : dem::ForcePath::Particle;
    // Threads per particle of the contact-force kernel on the GPU (DemParams::force_lanes).
    const long lanes = dc->integer_in("force_lanes", 1, 1, 16);
    if (lanes != 1 && lanes != 2 && lanes != 4 && lanes != 8 && lanes != 16)
      dc->fail("force_lanes", "give 1, 2, 4, 8 or 16 (threads per particle of the GPU's contact-force kernel)");
    p.force_lanes = static_cast<int>(lanes);
    dc->finish();
  }
  p.dt = gas_dt / substeps;
  try {
    dem::check_time_step(p, particles, key);
  } catch (const ConfigError& e) {
    throw ConfigError(root.source() + ": " + e.what() + " (DEM dt = gas.dt / sub-steps)");
  }
  return substeps;
}

}  // namespace lbdem::cfd
