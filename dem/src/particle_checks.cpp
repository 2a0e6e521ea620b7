// Checks of a case's particles (dem/particle_checks.hpp).
#include "dem/particle_checks.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/run_checks.hpp"
#include "core/run_length.hpp"

namespace lbdem::dem {

namespace {

using checks::axis_name;
using checks::num;
using checks::vec;

std::int64_t id_of(const HostParticles& p, std::size_t i) {
  return i < p.id.size() ? p.id[i] : static_cast<std::int64_t>(i);
}
std::string particle(const HostParticles& p, std::size_t i, int dim) {
  return "particle id " + std::to_string(id_of(p, i)) + " (position " + vec(p.x[i], dim) + ", radius " + num(p.r[i]) +
         ")";
}

}  // namespace

ParticleBox particle_box(const DemParams& p, int dim, const std::string& box_key, const std::string& walls_key) {
  ParticleBox b;
  b.lo = p.lo;
  b.hi = p.hi;
  b.periodic = p.periodic;
  b.walls = p.walls;
  b.dim = dim;
  b.box_key = box_key;
  b.walls_key = walls_key;
  return b;
}

void check_particles_in_box(const Config& root, const HostParticles& p, const ParticleBox& box) {
  const std::string& src = root.source();
  for (std::size_t i = 0; i < p.x.size(); ++i) {
    const Vec3d& x = p.x[i];
    const double r = p.r[i];
    for (int a = 0; a < box.dim; ++a) {
      const auto k = static_cast<std::size_t>(a);
      const double L = box.hi[k] - box.lo[k];
      if (2 * r >= L)
        throw ConfigError(src + ": " + box.key + ": " + particle(p, i, box.dim) + " is wider than the box: diameter " +
                          num(2 * r) + " >= its length " + num(L) + " along " + axis_name(a) + " (" + box.box_key +
                          "); use a larger box or smaller particles");
      if (!(x[a] >= box.lo[k] && x[a] <= box.hi[k]))
        throw ConfigError(src + ": " + box.key + ": " + particle(p, i, box.dim) + " lies outside the domain: " +
                          axis_name(a) + " = " + num(x[a]) + " is not in [" + num(box.lo[k]) + ", " + num(box.hi[k]) +
                          "] (" + box.box_key + "); place every particle inside the box");
    }
    for (std::size_t w = 0; w < box.walls.size(); ++w) {
      const Vec3d n = box.walls[w].normal;
      const double len = norm(n);
      if (!(len > 0)) continue;  // the wall's own check names its normal
      const double d = dot(x - box.walls[w].point, n) / len;  // distance in front of the wall
      if (d < 0)
        throw ConfigError(src + ": " + box.key + ": " + particle(p, i, box.dim) + " lies behind " + box.walls_key +
                          "[" + std::to_string(w) + "] (point " + vec(box.walls[w].point, 3) + ", normal " +
                          vec(n, 3) + ") by " + num(-d) + "; the normal points into the domain: place the particle on "
                          "that side, at least its radius away");
      if (r - d > kMaxInitialOverlap * r)
        throw ConfigError(src + ": " + box.key + ": " + particle(p, i, box.dim) + " overlaps " + box.walls_key + "[" +
                          std::to_string(w) + "] by " + num(r - d) + " (" + num(100 * (r - d) / r) +
                          "% of its radius; at most " + num(100 * kMaxInitialOverlap) +
                          "% is accepted): the contact force would throw it off in the first steps; place its centre "
                          "at least its radius " + num(r) + " from the wall");
    }
  }
}

void check_particle_overlaps(const Config& root, const HostParticles& p, const ParticleBox& box) {
  const std::size_t n = p.x.size();
  if (n < 2 || p.apart_by_construction) return;
  double rmax = 0;
  for (double r : p.r) rmax = std::max(rmax, r);
  if (!(rmax > 0)) return;
  // Cell list of cell size 2 r_max (every overlapping pair in neighbouring
  // cells), cells keyed by a 64-bit number and sorted: memory O(n) however
  // large the box.
  const double cs = 2 * rmax;
  std::array<long, 3> nc{1, 1, 1};
  for (int a = 0; a < box.dim; ++a) {
    const auto k = static_cast<std::size_t>(a);
    nc[k] = static_cast<long>(std::clamp(std::floor((box.hi[k] - box.lo[k]) / cs), 1.0, double(1L << 20)));
  }
  auto cell_of = [&](const Vec3d& x, int a) {
    const auto k = static_cast<std::size_t>(a);
    const double c = std::floor((x[a] - box.lo[k]) / (box.hi[k] - box.lo[k]) * double(nc[k]));
    return static_cast<long>(std::clamp(c, 0.0, double(nc[k] - 1)));
  };
  auto key = [&](long cx, long cy, long cz) { return (cz * nc[1] + cy) * nc[0] + cx; };
  std::vector<std::pair<long, std::size_t>> order(n);
  for (std::size_t i = 0; i < n; ++i)
    order[i] = {key(cell_of(p.x[i], 0), cell_of(p.x[i], 1), box.dim == 3 ? cell_of(p.x[i], 2) : 0), i};
  std::sort(order.begin(), order.end());
  // Keys, positions and radii in cell order: the particles of one cell and of
  // its neighbours lie close together in memory, and consecutive particles
  // search nearly the same keys (the check is bound by memory access).
  std::vector<long> keys(n);
  std::vector<Vec3d> xs(n);
  std::vector<double> rs(n);
  for (std::size_t s = 0; s < n; ++s) {
    keys[s] = order[s].first;
    xs[s] = p.x[order[s].second];
    rs[s] = p.r[order[s].second];
  }
  // Where the particles of each cell start, when the cells are not many more
  // than the particles (memory O(n) still); else a binary search per cell.
  const long n_cells = nc[0] * nc[1] * nc[2];
  std::vector<std::size_t> start;
  if (n_cells <= 8 * static_cast<long>(n)) {
    start.assign(static_cast<std::size_t>(n_cells) + 1, n);
    for (std::size_t s = n; s-- > 0;) start[static_cast<std::size_t>(keys[s])] = s;
    for (long k = n_cells - 1; k >= 0; --k)
      start[static_cast<std::size_t>(k)] = std::min(start[static_cast<std::size_t>(k)], start[static_cast<std::size_t>(k) + 1]);
  }
  bool few_cells = false;
  for (int a = 0; a < box.dim; ++a) few_cells |= nc[static_cast<std::size_t>(a)] < 3;
  std::size_t pairs = 0, worst_i = 0, worst_j = 0;
  double worst = 0;
  for (std::size_t s = 0; s < n; ++s) {
    const long c[3] = {keys[s] % nc[0], (keys[s] / nc[0]) % nc[1], keys[s] / (nc[0] * nc[1])};
    // Neighbour cells, each once (fewer than three cells on an axis repeat one).
    std::array<long, 27> seen{};
    std::size_t n_seen = 0;
    for (int dz = box.dim == 3 ? -1 : 0; dz <= (box.dim == 3 ? 1 : 0); ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          long q[3] = {c[0] + dx, c[1] + dy, c[2] + dz};
          bool skip = false;
          for (int a = 0; a < 3; ++a) {
            const auto k = static_cast<std::size_t>(a);
            if (q[a] >= 0 && q[a] < nc[k]) continue;
            if (box.periodic[k]) q[a] = (q[a] + nc[k]) % nc[k];
            else skip = true;
          }
          if (skip) continue;
          const long kq = key(q[0], q[1], q[2]);
          // Each unordered pair once: only partners later in cell order.
          if (kq < keys[s]) continue;
          if (few_cells) {
            if (std::find(seen.begin(), seen.begin() + static_cast<long>(n_seen), kq) != seen.begin() + static_cast<long>(n_seen))
              continue;
            seen[n_seen++] = kq;
          }
          std::size_t t = start.empty() ? static_cast<std::size_t>(std::lower_bound(keys.begin(), keys.end(), kq) - keys.begin())
                                        : start[static_cast<std::size_t>(kq)];
          for (; t < n && keys[t] == kq; ++t) {
            if (t <= s) continue;
            double d2 = 0;
            for (int a = 0; a < box.dim; ++a) {
              const auto k = static_cast<std::size_t>(a);
              double d = xs[t][a] - xs[s][a];
              if (box.periodic[k]) {
                const double L = box.hi[k] - box.lo[k];
                d -= L * std::round(d / L);
              }
              d2 += d * d;
            }
            const double overlap = rs[s] + rs[t] - std::sqrt(d2);
            const double rel = overlap / std::min(rs[s], rs[t]);
            if (rel > kMaxInitialOverlap) {
              ++pairs;
              if (rel > worst) {
                worst = rel;
                worst_i = std::min(order[s].second, order[t].second);
                worst_j = std::max(order[s].second, order[t].second);
              }
            }
          }
        }
  }
  if (pairs == 0) return;
  const double depth = worst * std::min(p.r[worst_i], p.r[worst_j]);
  throw ConfigError(root.source() + ": " + box.key + ": " + std::to_string(pairs) + " pair" + (pairs > 1 ? "s" : "") +
                    " of particles overlap by more than " + num(100 * kMaxInitialOverlap) +
                    "% of the smaller radius; the deepest: " + particle(p, worst_i, box.dim) + " and " +
                    particle(p, worst_j, box.dim) + " overlap by " + num(depth) + " (" + num(100 * worst) +
                    "%). The contact forces of overlaps this deep blow the run up in its first steps: move the "
                    "particles apart (centres at least r_i + r_j apart)");
}

void check_dem_particle_count(const Config& pc, double count, const std::string& key) {
  check_memory(pc, Backend::Host, 0, count * kDemHostBytesPerParticle, pc.full_key(key), num(count) + " particles",
               "use fewer particles");
}

double random_packing_count(const std::array<double, 3>& lo, const std::array<double, 3>& hi, double solid_fraction,
                            double r_max, int dim) {
  double vol = 1;
  for (int a = 0; a < dim; ++a) vol *= hi[static_cast<std::size_t>(a)] - lo[static_cast<std::size_t>(a)];
  const double vp = dim == 3 ? 4.0 / 3.0 * M_PI * r_max * r_max * r_max : M_PI * r_max * r_max;
  return r_max > 0 ? solid_fraction * vol / vp : 0;  // fewest particles: all of the largest radius
}

void check_random_fill(const Config& pc, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                       const std::array<bool, 3>& periodic, double r_max, const std::string& box_key) {
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    const double L = hi[k] - lo[k];
    if (!(2 * r_max < L))
      throw ConfigError(pc.where("radius") + ": key '" + pc.full_key("radius") + "' = " + pc.value_text("radius") +
                        ": a particle of diameter " + num(2 * r_max) + " does not fit the box along " + axis_name(a) +
                        " (length " + num(L) + (periodic[k] ? ", periodic" : "") + ", " + box_key +
                        "); use smaller particles or a larger box");
  }
}

void check_dem_random_packing(const Config& pc, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                              const std::array<bool, 3>& periodic, double solid_fraction, double r_max) {
  check_random_fill(pc, lo, hi, periodic, r_max,
                    pc.has("region_hi") ? "particles.region_hi, domain.lo" : "domain.lo, domain.hi");
  check_dem_particle_count(pc, random_packing_count(lo, hi, solid_fraction, r_max), "solid_fraction");
}

void check_dem_scene(const Config& root, const DemParams& p, const HostParticles& hp, long steps, Backend backend,
                     bool force, bool steps_given) {
  const ParticleBox box = particle_box(p, 3, "domain.lo, domain.hi", "walls");
  check_particles_in_box(root, hp, box);
  check_particle_overlaps(root, hp, box);
  const double n = static_cast<double>(hp.x.size());
  check_memory(root, backend, n * kDemDeviceBytesPerParticle, n * kDemHostBytesPerParticle, "particles",
               num(n) + " particles", "use fewer particles");
  std::string key = "time.steps";
  double planned = double(steps);
  if (steps_given) {
    key = "--steps";
  } else if (const auto t = root.optional_section("time"); t && t->has(end_key(*t))) {
    key = t->full_key(end_key(*t)) + " = " + t->value_text(end_key(*t)) + " s with dt = " + num(p.dt) + " s (" +
          (t->has("dt") ? "time.dt" : "t_c / time.steps_per_collision, t_c from material.stiffness and the radii") +
          ")";
    planned = t->number(end_key(*t)) / p.dt;  // in double: the integer count may have overflowed
  }
  check_plan(root, force, planned, 0, n, key);
}

}  // namespace lbdem::dem
