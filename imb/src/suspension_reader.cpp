// The particles section of the resolved particle scene (imb/suspension_reader.hpp).
#include "imb/suspension_reader.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "core/run_checks.hpp"
#include "dem/grid_box.hpp"
#include "dem/init.hpp"
#include "dem/packing.hpp"
#include "dem/particle_checks.hpp"
#include "imb/coupled_checks.hpp"
#include "imb/coupled_memory.hpp"
#include "lbm/fluid_checks.hpp"

namespace lbdem::imb {

using checks::axis_name;
using checks::num;
using checks::vec;
using dem::kDemDeviceBytesPerParticle;
using dem::kDemHostBytesPerParticle;

SuspensionParticles read_suspension_particles(const Config& root, const Config& pc, const FluidBox& box,
                                              const SuspensionContext& ctx) {
  SuspensionParticles c;
  const Units& U = *ctx.units;
  const lbm::LbmSetup& s = *ctx.fluid;
  const int dim = box.dim;
  const auto& periodic = box.periodic;
  const auto& cells = box.cells;
  c.density_ratio = ctx.physical ? U.to_lattice_density(pc.positive("density"))
                                 : pc.number_in("density_ratio", 1.0, 1e-3, 1e6, "solid / fluid density");
  if (ctx.physical && !(c.density_ratio >= 1e-3 && c.density_ratio <= 1e6))
    pc.fail("density", "gives a solid / fluid density ratio of " + std::to_string(c.density_ratio) +
                           " (fluid.density " + std::to_string(U.rho) + " kg/m^3): valid 1e-3 to 1e6");
  const double diam = ctx.physical ? ctx.diameter : pc.number_in("diameter", 1.0, 1e4, "particle diameter in cells");
  c.diameter = diam;
  const auto v0 = pc.numbers("velocity", {0, 0, 0}, 3, 3);
  const auto w0 = pc.numbers("angular_velocity", {0, 0, 0}, 3, 3);
  const Vec3d v0l{U.to_lattice_velocity(v0[0]), U.to_lattice_velocity(v0[1]), U.to_lattice_velocity(v0[2])};
  const Vec3d w0l{U.to_lattice_angular_velocity(w0[0]), U.to_lattice_angular_velocity(w0[1]),
                  U.to_lattice_angular_velocity(w0[2])};
  const bool held = pc.boolean("held", false);  // position and rotation prescribed (infinite mass)
  const std::string init = pc.choice("init", {"list", "random"});
  const auto seed = static_cast<std::uint64_t>(pc.integer_in("seed", 1, 0, std::numeric_limits<long>::max()));
  // Random initial velocities of this magnitude (the first paper's v_s0, Sec. 2).
  const double random_speed = U.to_lattice_velocity(pc.number_in("random_speed", 0.0, 0.0, 1e300));
  if (random_speed * std::sqrt(3.0) > ctx.max_mach)
    pc.fail("random_speed", "is " + std::to_string(random_speed) + " cells per step, a lattice Mach number of " +
                                std::to_string(random_speed * std::sqrt(3.0)) + " above fluid.max_mach = " +
                                std::to_string(ctx.max_mach) + "; use a smaller speed (the first paper: 5e-3 in lattice units)");
  const double r = 0.5 * diam;
  // Mass of a solid sphere of density rho_s (lattice units: fluid density 1).
  const double rho_s = held ? 1e300 : c.density_ratio;
  // SI positions are measured from the fluid box's corner; the lattice ones
  // from the grid's, whose closed axes start with a wall layer.
  auto position = [&](double x, int a) {
    return ctx.physical ? U.to_lattice_length(x) + double(box.lo[static_cast<std::size_t>(a)]) : x;
  };
  if (init == "list") {
    for (const Config& it : pc.sequence("list")) {
      const auto x = it.numbers("position", dim, 3);
      c.particles.add({position(x[0], 0), position(x[1], 1), dim == 3 ? position(x[2], 2) : 0.5}, r,
                      held ? 1e300 / (4.0 / 3.0 * M_PI * r * r * r) : rho_s, v0l, w0l);
      it.finish();
    }
  } else {
    dem::RandomPackingSpec rs;
    for (int a = 0; a < 3; ++a) {
      const auto k = static_cast<std::size_t>(a);
      rs.lo[k] = double(box.lo[k]);
      rs.hi[k] = double(box.hi[k]);
    }
    rs.periodic = periodic;
    double vbox = 1;
    for (int a = 0; a < dim; ++a) vbox *= double(cells[static_cast<std::size_t>(a)]);
    const double vp = dim == 3 ? 4.0 / 3.0 * M_PI * r * r * r : M_PI * r * r;
    if (pc.has("count") == pc.has("solid_fraction"))
      pc.fail(pc.has("count") ? "count" : "solid_fraction",
              "give exactly one of particles.solid_fraction (of the box) or particles.count");
    long count = 0;
    if (pc.has("count")) {
      count = pc.integer_in("count", 1, 1000000000L);
      rs.solid_fraction = double(count) * vp / vbox;  // lround(phi V / V_p) gives count back
      if (!(rs.solid_fraction <= 0.6))
        pc.fail("count", "fills " + std::to_string(rs.solid_fraction) + " of the box; at most 0.6");
    } else {
      rs.solid_fraction = pc.number_in("solid_fraction", 1e-4, 0.6, "solid volume fraction of the box");
      count = std::lround(rs.solid_fraction * vbox / vp);
    }
    rs.r_min = rs.r_max = r;
    rs.density = rho_s;
    rs.seed = seed;
    // particles.packing: lattice (the default: one lattice over the box, every
    // rank packs every particle) or blocks (dem/block_packing.hpp: the same
    // particles whatever the rank count, each rank packing only its own).
    const bool blocks = pc.choice("packing", "lattice", {"lattice", "blocks"}) == "blocks";
    if (blocks) {
      if (dim == 3)
        check_particles_random(root, ctx.keys, pc, s, rs.lo, rs.hi, rs.periodic, rs.solid_fraction, r, ctx.backend);
      else check_particles_memory(root, ctx.keys, s, double(count), ctx.backend);
      dem::BlockPackingSpec bs;
      bs.dim = dim;
      bs.lo = rs.lo;
      bs.hi = rs.hi;
      bs.periodic = rs.periodic;
      bs.count = count;
      bs.radius = r;
      bs.density = rho_s;
      bs.speed = random_speed;
      bs.velocity = v0l;
      bs.angular_velocity = w0l;
      bs.seed = seed;
      bs.displace = !ctx.validate_only;
      c.blocks = bs;
    } else if (dim == 3) {
      check_particles_random(root, ctx.keys, pc, s, rs.lo, rs.hi, rs.periodic, rs.solid_fraction, r, ctx.backend);
      rs.displace = !ctx.validate_only;  // lbdem check: lattice sites (dem/init.hpp)
      c.particles = dem::random_packing(rs);
    } else {
      check_particles_memory(root, ctx.keys, s, double(count), ctx.backend);
      c.particles = dem::random_disks(rs.lo, rs.hi, rs.periodic, count, r, rho_s, seed,
                                      pc.full_key(pc.has("count") ? "count" : "solid_fraction"));
    }
    for (Index i = 0; i < c.particles.size(); ++i) {
      c.particles.v[static_cast<std::size_t>(i)] = v0l;
      c.particles.w[static_cast<std::size_t>(i)] = w0l;
    }
  }
  dem::add_random_velocities(c.particles, dim, random_speed, seed);
  if (dim == 2) {
    // 2D: disks one cell deep (the first paper's Table 2: m = rho_s pi r^2 l),
    // not the spheres HostParticles::add makes: mass x (pi r^2) / (4/3 pi r^3).
    for (std::size_t i = 0; i < c.particles.mass.size(); ++i)
      if (c.particles.mass[i] < 1e100) c.particles.mass[i] *= 0.75 / c.particles.r[i];
  }
  pc.finish();
  double vol = 0, vbox = 1;
  for (Index i = 0; i < c.particles.size(); ++i) {
    const double ri = c.particles.r[static_cast<std::size_t>(i)];
    vol += dim == 3 ? 4.0 / 3.0 * M_PI * ri * ri * ri : M_PI * ri * ri;
  }
  if (c.blocks) vol = double(c.blocks->count) * (dim == 3 ? 4.0 / 3.0 * M_PI * r * r * r : M_PI * r * r);
  for (int a = 0; a < dim; ++a) vbox *= double(cells[static_cast<std::size_t>(a)]);
  c.solid_fraction = vol / vbox;
  return c;
}

void coupled_dem_box(dem::DemParams& p, const Grid& grid, int dim, double diameter) {
  dem::set_box_from_grid(p, grid);
  if (dim == 2) {
    p.periodic[2] = false;
    p.lo[2] = 0.5 - diameter;
    p.hi[2] = 0.5 + diameter;
  }
  for (int a = 0; a < dim; ++a) {
    if (grid.periodic[static_cast<std::size_t>(a)]) continue;
    Vec3d n{}, q{};
    n[a] = 1;
    q[a] = 1.0;
    p.walls.push_back({q, n});
    n[a] = -1;
    q[a] = p.hi[static_cast<std::size_t>(a)] - 1.0;
    p.walls.push_back({q, n});
  }
}

// ----------------------------------------------------------------- checks
void check_particles_memory(const Config& root, const CoupledKeys& keys, const lbm::LbmSetup& fluid, double particles,
                            Backend backend) {
  double cells = 1;
  for (int a = 0; a < 3; ++a) cells *= static_cast<double>(fluid.domain.global[static_cast<std::size_t>(a)]);
  const double dev = lbm::rank_grid_bytes(root, fluid) + particles * kDemDeviceBytesPerParticle;
  // Host: the set-up fields of initialize() (flags, rho, u), the particles' host copies.
  const double host = cells * (1 + 4 * sizeof(double)) + particles * kDemHostBytesPerParticle;
  check_memory(root, backend, dev, host, particles > 0 ? keys.cells + ", particles.solid_fraction" : keys.cells,
               "the grid of " + num(cells) + " cells" + (particles > 0 ? " with about " + num(particles) + " particles" : ""),
               "use fewer cells" + std::string(particles > 0 ? ", a lower solid fraction or larger particles" : "") +
                   lbm::or_fp32(fluid));
}

void check_particles_random(const Config& root, const CoupledKeys& keys, const Config& pc, const lbm::LbmSetup& fluid,
                            const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                            const std::array<bool, 3>& periodic, double solid_fraction, double r, Backend backend) {
  // The key is particles.diameter here.
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    if (!(2 * r < hi[k] - lo[k]))
      throw ConfigError(pc.where("diameter") + ": key 'particles.diameter' = " + pc.value_text("diameter") +
                        ": the particles do not fit the box along " + axis_name(a) + " (" + num(hi[k] - lo[k]) +
                        " cells" + (periodic[k] ? ", periodic" : "") +
                        ", " + keys.cells + "); use smaller particles or more cells");
  }
  check_particles_memory(root, keys, fluid, dem::random_packing_count(lo, hi, solid_fraction, r), backend);
}

void check_particles_scene(const Config& root, const lbm::LbmSetup& fluid, const dem::DemParams& dem,
                           const dem::HostParticles& p, const CoupledParams& cp, bool balance, long steps,
                           Backend backend, bool force, const std::string& steps_key) {
  const int dim = fluid.lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  const CoupledKeys& k = cp.keys;
  const auto& gravity = cp.gravity;
  const int dem_substeps = cp.dem_substeps;
  dem::ParticleBox box = dem::particle_box(dem, dim, k.cells, "the wall");
  dem::check_particles_in_box(root, p, box);
  dem::check_particle_overlaps(root, p, box);
  bool periodic = true;
  for (int a = 0; a < dim; ++a) periodic = periodic && fluid.domain.periodic[static_cast<std::size_t>(a)];
  const double g = std::sqrt(gravity[0] * gravity[0] + gravity[1] * gravity[1] + gravity[2] * gravity[2]);
  if (periodic && !balance && g > 0)
    throw ConfigError(root.source() + ": key 'physics.balance_weight' = false with " + k.gravity + " = " +
                      vec({gravity[0], gravity[1], gravity[2]}, 3) +
                      " in a fully periodic domain: nothing holds the particles' weight, and the whole system "
                      "accelerates without bound until the Mach limit; set physics.balance_weight: true (a fluid body "
                      "force balances the weight, first paper Sec. 2) or " + k.gravity + ": [0, 0, 0]");
  // DEM sub-steps against the shortest contact, in double (a stiffness of
  // 1e30 asks for more sub-steps than an int holds).
  const double tc = dem::min_collision_time(dem, p);
  if (std::isfinite(tc) && tc > 0 && double(dem_substeps) * tc < dem.min_steps_per_collision * (1 - 1e-12)) {
    const double need = std::ceil(dem.min_steps_per_collision / tc - 1e-9);
    throw ConfigError(root.source() + ": key '" + k.dem_substeps + "' = " + std::to_string(dem_substeps) +
                      ": the DEM time step 1/" + std::to_string(dem_substeps) +
                      " (lattice units) is too long for the shortest contact, t_c = " + num(tc) + " (from " +
                      k.stiffness + " and the particle masses), which needs at least " +
                      num(dem.min_steps_per_collision) + " DEM steps: use " + k.dem_substeps + " >= " + num(need) +
                      (need > 100000 ? " (beyond its limit 100000: soften " + k.stiffness + ")"
                                     : " or soften " + k.stiffness));
  }
  check_particles_mach(root, fluid, dem, p, cp, CoupledLimits{}.max_mach);
  double cells = 1;
  for (int a = 0; a < 3; ++a) cells *= static_cast<double>(fluid.domain.global[static_cast<std::size_t>(a)]);
  const double n = static_cast<double>(p.x.size());
  check_memory(root, backend, lbm::rank_grid_bytes(root, fluid) + n * kDemDeviceBytesPerParticle,
               cells * (1 + 4 * sizeof(double)) + n * kDemHostBytesPerParticle, k.cells + ", particles",
               "the grid of " + num(cells) + " cells with " + num(n) + " particles",
               "use fewer cells or particles" + lbm::or_fp32(fluid));
  check_plan(root, force, double(steps), cells, n * dem_substeps, steps_key);
}

}  // namespace lbdem::imb
