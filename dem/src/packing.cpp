// Random particle sets of a suspension's set-up (dem/packing.hpp).
#include "dem/packing.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "core/error.hpp"
#include "core/random.hpp"

namespace lbdem::dem {

namespace {
std::string g(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}
}  // namespace

HostParticles random_disks(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                                const std::array<bool, 3>& periodic, long count, double r, double density,
                                std::uint64_t seed, const std::string& key) {
  HostParticles hp;
  if (count <= 0) return hp;
  // The region the centres may take: the whole period, or the box less a radius at walls.
  std::array<double, 2> rlo{}, rlen{};
  for (int k = 0; k < 2; ++k) {
    const auto a = static_cast<std::size_t>(k);
    rlo[a] = periodic[a] ? lo[a] : lo[a] + r;
    rlen[a] = periodic[a] ? hi[a] - lo[a] : hi[a] - lo[a] - 2 * r;
    if (!(rlen[a] > 0))
      throw ConfigError(key + ": disks of diameter " + g(2 * r) + " cells do not fit the box along " +
                        std::string(1, char('x' + k)) + " (" + g(hi[a] - lo[a]) + " cells)");
  }
  // Sites per axis at spacing h: a periodic axis holds floor(L / h) sites
  // (spacing L / m >= h), a walled one floor(L / h) + 1 (ends included).
  auto sites_along = [&](int k, double h) -> long {
    const auto a = static_cast<std::size_t>(k);
    const long m = static_cast<long>(std::floor(rlen[a] / h));
    return periodic[a] ? std::max<long>(1, m) : m + 1;
  };
  const double dmin = 2 * r * (1 + 1e-9);  // neighbouring sites never closer than a diameter
  // About twice as many sites as disks (random vacancies), but never closer than dmin.
  double h = std::max(dmin, std::sqrt(rlen[0] * rlen[1] / (2.0 * double(count))));
  std::array<long, 2> m{sites_along(0, h), sites_along(1, h)};
  while (m[0] * m[1] < count && h > dmin) {
    h = std::max(dmin, 0.98 * h);
    m = {sites_along(0, h), sites_along(1, h)};
  }
  if (m[0] * m[1] < count)
    throw ConfigError(key + ": " + std::to_string(count) + " disks of diameter " + g(2 * r) +
                      " cells do not fit a square lattice in this box (at most " + std::to_string(m[0] * m[1]) +
                      "); use fewer particles (a lower solid fraction) or a larger box");
  std::array<double, 2> step{};
  for (int k = 0; k < 2; ++k) {
    const auto a = static_cast<std::size_t>(k);
    step[a] = periodic[a] ? rlen[a] / double(m[a]) : (m[a] > 1 ? rlen[a] / double(m[a] - 1) : 0.0);
  }
  // Free gap between neighbouring disks along each axis: each centre may move
  // by up to half of it either way (a walled axis with one site: none).
  std::array<double, 2> jitter{};
  for (int k = 0; k < 2; ++k) {
    const auto a = static_cast<std::size_t>(k);
    jitter[a] = m[a] > 1 || periodic[a] ? 0.5 * std::max(0.0, step[a] - 2 * r) : 0.0;
    if (m[a] == 1 && periodic[a]) jitter[a] = 0.5 * std::max(0.0, rlen[a] - 2 * r);
  }
  std::mt19937_64 rng(seed);
  const long sites = m[0] * m[1];
  std::vector<long> site(static_cast<std::size_t>(sites));
  for (long i = 0; i < sites; ++i) site[static_cast<std::size_t>(i)] = i;
  for (long i = 0; i < count; ++i) {  // partial Fisher-Yates: a uniform random subset
    std::uniform_int_distribution<long> pick(i, sites - 1);
    std::swap(site[static_cast<std::size_t>(i)], site[static_cast<std::size_t>(pick(rng))]);
  }
  auto U = [](std::mt19937_64& g) { return uniform(g, -1.0, 1.0); };
  hp.x.reserve(static_cast<std::size_t>(count));
  for (long i = 0; i < count; ++i) {
    const long s = site[static_cast<std::size_t>(i)];
    const long c[2] = {s % m[0], s / m[0]};
    Vec3d x{0, 0, 0.5};
    for (int k = 0; k < 2; ++k) {
      const auto a = static_cast<std::size_t>(k);
      x[k] = rlo[a] + (periodic[a] ? (double(c[k]) + 0.5) : double(c[k])) * step[a] + jitter[a] * U(rng);
      if (periodic[a]) {  // keep inside [lo, hi)
        const double L = hi[a] - lo[a];
        if (x[k] >= hi[a]) x[k] -= L;
        if (x[k] < lo[a]) x[k] += L;
      } else {
        x[k] = std::clamp(x[k], rlo[a], rlo[a] + rlen[a]);
      }
    }
    hp.add(x, r, density);
  }
  // Each centre moves by at most half the free gap along each axis from its
  // own lattice site: no two disks overlap (tests/dem SuspensionSetup).
  hp.apart_by_construction = true;
  return hp;
}

HostParticles suspension_blocks(const BlockPackingSpec& spec, const DemDomain* domain) {
  const BlockPacking bp(spec);
  if (!domain || !domain->decomposed()) return bp.pack_all();
  const int me = domain->rank();
  Vec3d lo, hi;
  domain->piece(me, lo, hi);
  HostParticles mine =
      bp.pack({lo.x, lo.y, lo.z}, {hi.x, hi.y, hi.z}, [&](const Vec3d& x) { return domain->owner(x) == me; });
  if (domain->comm->any(mine.size() == 0))
    throw ConfigError("particles.packing: blocks leaves a rank's piece without particles (" + std::to_string(bp.count()) +
                      " particles over " + std::to_string(domain->comm->size()) +
                      " ranks); use fewer ranks or more particles");
  return mine;
}

void add_random_velocities(HostParticles& p, int dim, double speed, std::uint64_t seed) {
  if (!(speed > 0) || p.x.empty()) return;
  // A stream of its own (seed mixed with a constant), so that the positions
  // of a random packing with the same seed do not correlate with it.
  std::mt19937_64 rng(seed ^ 0x9E3779B97F4A7C15ull);
  std::normal_distribution<double> N(0.0, 1.0);
  std::vector<Vec3d> dv(p.x.size());
  Vec3d mean{0, 0, 0};
  for (auto& d : dv) {
    double len = 0;
    do {  // isotropic direction: a normalised Gaussian vector
      d = {N(rng), N(rng), dim == 3 ? N(rng) : 0.0};
      len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    } while (!(len > 1e-12));
    for (int k = 0; k < 3; ++k) d[k] *= speed / len;
    mean = mean + d;
  }
  mean = mean * (1.0 / double(dv.size()));
  for (std::size_t i = 0; i < dv.size(); ++i) p.v[i] = p.v[i] + (dv[i] - mean);
}

}  // namespace lbdem::dem
