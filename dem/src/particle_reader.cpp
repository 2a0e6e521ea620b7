// The reader of a case file's `particles` section (dem/particle_reader.hpp).
#include "dem/particle_reader.hpp"

#include <cmath>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/run_checks.hpp"
#include "dem/init.hpp"
#include "dem/particle_checks.hpp"

namespace lbdem::dem {

namespace {

Vec3d vec3(const std::vector<double>& v) { return {v[0], v[1], v[2]}; }

// Mean r^3 of radii uniform in [a, b].
double mean_r3(double a, double b) { return b > a ? (b * b * b * b - a * a * a * a) / (4 * (b - a)) : a * a * a; }

}  // namespace

HostParticles read_particles(const Config& pc, const DemParams& p, const ParticleReading& o) {
  const std::string init = pc.choice("init", {"list", "csv", "hdf5", "lattice", "random"});
  const double rho = o.density ? pc.positive("density", *o.density) : pc.positive("density");
  HostParticles hp;
  if (init == "list") {
    const auto items = pc.sequence("list");
    if (items.empty()) pc.fail("list", "needs at least one particle");
    for (const Config& it : items) {
      const Vec3d x = vec3(it.numbers("position", 3, 3));
      const double r = it.positive("radius");
      const Vec3d v = vec3(it.numbers("velocity", {0, 0, 0}, 3, 3));
      const Vec3d w = vec3(it.numbers("angular_velocity", {0, 0, 0}, 3, 3));
      const double d = it.positive("density", rho);
      hp.add(x, r, d, v, w);
      it.finish();
    }
  } else if (init == "csv" || init == "hdf5") {
    std::filesystem::path f = pc.text("file");
    if (f.is_relative() && std::filesystem::exists(pc.source()))
      f = std::filesystem::path(pc.source()).parent_path() / f;
    hp = init == "csv" ? read_particles_csv(f.string(), rho) : read_particles_h5(f.string(), rho);
  } else if (init == "lattice") {
    const auto cnt = pc.integers("count", 3, 3, 1, 100000000);
    const Vec3d origin = vec3(pc.numbers("origin", 3, 3));
    const Vec3d spacing = vec3(pc.numbers("spacing", 3, 3));
    const double r = pc.positive("radius");
    check_dem_particle_count(pc, double(cnt[0]) * double(cnt[1]) * double(cnt[2]), "count");
    hp = lattice_particles(origin, {cnt[0], cnt[1], cnt[2]}, spacing, r, rho);
  } else {
    RandomPackingSpec s;
    s.lo = p.lo;
    s.hi = p.hi;
    s.periodic = p.periodic;
    // A region of the box (the lower part of a bed) may be filled instead.
    for (const bool upper : {false, true}) {
      const std::string key = upper ? "region_hi" : "region_lo";
      if (!pc.has(key)) continue;
      const auto v = pc.numbers(key, 3, 3);
      for (std::size_t k = 0; k < 3; ++k) {
        if (!(v[k] >= p.lo[k] && v[k] <= p.hi[k])) pc.fail(key, "each component must lie in [domain.lo, domain.hi]");
        (upper ? s.hi : s.lo)[k] = v[k];
      }
    }
    for (std::size_t k = 0; k < 3; ++k) {
      if (!(s.hi[k] > s.lo[k])) pc.fail("region_hi", "must exceed particles.region_lo (and domain.lo) on every axis");
      if (s.lo[k] > p.lo[k] || s.hi[k] < p.hi[k]) s.periodic[k] = false;
    }
    const auto r = pc.numbers("radius", 1, 2);
    s.r_min = r[0];
    s.r_max = r.size() > 1 ? r[1] : r[0];
    if (!(s.r_min > 0 && s.r_max >= s.r_min)) pc.fail("radius", "needs 0 < r_min <= r_max");
    const double vol = (s.hi[0] - s.lo[0]) * (s.hi[1] - s.lo[1]) * (s.hi[2] - s.lo[2]);
    if (pc.has("count") == pc.has("solid_fraction"))
      pc.fail("count", "give either particles.count or particles.solid_fraction (of the region), not both or neither");
    if (pc.has("count")) {
      const double n = static_cast<double>(pc.integer_in("count", 1, 1000000000));
      s.solid_fraction = n * 4.0 / 3.0 * M_PI * mean_r3(s.r_min, s.r_max) / vol;
      if (!(s.solid_fraction <= 0.7))
        pc.fail("count", "fills the region to a solid fraction of " + checks::num(s.solid_fraction) +
                             "; a random packing reaches at most ~0.7: enlarge particles.region_hi or use fewer");
    } else {
      s.solid_fraction = pc.number_in("solid_fraction", 1e-6, 0.7, "random packing reaches at most ~0.7 on a lattice");
    }
    s.density = rho;
    s.seed = static_cast<std::uint64_t>(pc.integer_in("seed", 1, 0, std::numeric_limits<long>::max()));
    s.mc_sweeps = static_cast<int>(pc.integer_in("mc_sweeps", 0, 0, 1000));
    check_random_fill(pc, s.lo, s.hi, s.periodic, s.r_max,
                      pc.has("region_lo") || pc.has("region_hi") ? "particles.region_lo, particles.region_hi"
                                                                 : "domain.lo, domain.hi");
    check_dem_particle_count(pc, random_packing_count(s.lo, s.hi, s.solid_fraction, s.r_max),
                             pc.has("count") ? "count" : "solid_fraction");
    s.displace = !o.validate_only;  // lbdem check: lattice sites (dem/init.hpp)
    hp = random_packing(s);
  }
  // Random initial velocities (zero mean), for granular-gas scenes; a
  // validation (lbdem check) reads the keys and draws none.
  const double vrms = pc.number_in("velocity_rms", 0.0, 0.0, 1e6);
  const auto seed = static_cast<std::uint64_t>(pc.integer_in("velocity_seed", 7, 0, std::numeric_limits<long>::max()));
  if (vrms > 0 && hp.size() > 0 && !o.validate_only) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> N(0, vrms / std::sqrt(3.0));
    Vec3d mean{};
    for (auto& v : hp.v) {
      v = {N(rng), N(rng), N(rng)};
      mean += v;
    }
    for (auto& v : hp.v) v -= mean * (1.0 / static_cast<double>(hp.size()));
  }
  pc.finish();
  if (hp.size() == 0) pc.fail("init", "produced no particles");
  return hp;
}

void read_material(const Config& m, DemParams& p, FrictionFrom friction) {
  Material& mat = p.material;
  mat.stiffness = m.positive("stiffness");
  mat.restitution = m.number_in("restitution", 1e-6, 1.0, "restitution coefficient e in (0, 1]");
  mat.wall_stiffness = m.positive("wall_stiffness", mat.stiffness);
  mat.wall_restitution =
      m.number_in("wall_restitution", mat.restitution, 1e-6, 1.0, "restitution coefficient e in (0, 1]");
  if (friction == FrictionFrom::Physics && !p.friction) {
    for (const char* k : {"friction", "wall_friction", "tangential_stiffness_ratio", "tangential_damping_ratio"})
      if (m.has(k)) m.fail(k, "is only used with physics.friction: true");
  } else {
    mat.friction = friction == FrictionFrom::Physics ? m.number_in("friction", 0.0, 10.0)
                                                     : m.number_in("friction", 0.0, 0.0, 10.0);
    mat.wall_friction = m.number_in("wall_friction", mat.friction, 0.0, 10.0);
    mat.tangential_stiffness_ratio = m.number_in("tangential_stiffness_ratio", 2.0 / 7.0, 1e-6, 10.0);
    mat.tangential_damping_ratio = m.number_in("tangential_damping_ratio", 0.5, 0.0, 10.0);
    if (friction == FrictionFrom::Values) p.friction = mat.friction > 0 || mat.wall_friction > 0;
  }
  m.finish();
}

int read_coupled_dem(const Config& dm, const Units& U, DemParams& p) {
  p.material.stiffness = U.to_lattice_stiffness(dm.positive("stiffness"));
  p.material.restitution = dm.number_in("restitution", 0.9, 1e-6, 1.0, "restitution coefficient e in (0, 1]");
  p.material.wall_stiffness = dm.has("wall_stiffness") ? U.to_lattice_stiffness(dm.positive("wall_stiffness"))
                                                       : p.material.stiffness;
  p.material.wall_restitution = dm.number_in("wall_restitution", p.material.restitution, 1e-6, 1.0, "e in (0, 1]");
  p.material.friction = dm.number_in("friction", 0.0, 0.0, 10.0);
  p.material.wall_friction = dm.number_in("wall_friction", p.material.friction, 0.0, 10.0);
  const int substeps = static_cast<int>(dm.integer_in("substeps", 10, 1, 100000));
  p.dt = 1.0 / substeps;
  return substeps;
}

}  // namespace lbdem::dem
