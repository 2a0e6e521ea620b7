#include "dem/block_packing.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

#include <fmt/format.h>

#include "core/error.hpp"
#include "core/random.hpp"

namespace lbdem::dem {

namespace {

// SplitMix64 (Steele, Lea & Flood 2014): decorrelates the seeds of
// neighbouring blocks before they seed a Mersenne twister.
std::uint64_t mix(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace

BlockPacking::BlockPacking(const BlockPackingSpec& s) : spec_(s) {
  const int dim = s.dim;
  if (dim != 2 && dim != 3) throw ConfigError(fmt::format("block packing: dimension {} must be 2 or 3", dim));
  if (!(s.radius > 0)) throw ConfigError(fmt::format("particles.diameter: radius {} must be > 0", s.radius));
  if (s.count < 0) throw ConfigError(fmt::format("particles.count: {} must be >= 0", s.count));
  edge_ = dim == 3 ? kBlockEdge3d : kBlockEdge2d;
  const double r = s.radius;
  std::array<double, 3> rlen{0, 0, 0};
  for (int a = 0; a < dim; ++a) {
    const auto k = static_cast<std::size_t>(a);
    const double L = s.hi[k] - s.lo[k];
    rlo_[k] = s.periodic[k] ? s.lo[k] : s.lo[k] + r;
    rlen[k] = s.periodic[k] ? L : L - 2 * r;
    if (!(rlen[k] > 0))
      throw ConfigError(fmt::format("particles.diameter: particles of diameter {:.6g} do not fit the box along {} "
                                    "({:.6g} long)", 2 * r, char('x' + a), L));
  }
  if (dim == 2) {
    rlo_[2] = 0.5;  // the 2D scene's one-cell slab
    m_[2] = 1;
    step_[2] = 0;
  }
  const double dmin = 2 * r * (1 + 1e-9);
  // The lattice of half-spacing (3D) or spacing (2D) h: points per axis, the
  // step between them, the site count and the nearest-neighbour distance.
  auto build = [&](double h) {
    for (int a = 0; a < dim; ++a) {
      const auto k = static_cast<std::size_t>(a);
      if (s.periodic[k]) {
        const long n = static_cast<long>(std::floor(rlen[k] / (dim == 3 ? 2 * h : h)));
        m_[k] = dim == 3 ? 2 * std::max<long>(1, n) : std::max<long>(1, n);  // FCC: even, so parity wraps
        step_[k] = rlen[k] / double(m_[k]);
      } else {
        m_[k] = static_cast<long>(std::floor(rlen[k] / h)) + 1;
        step_[k] = m_[k] > 1 ? rlen[k] / double(m_[k] - 1) : 0.0;
      }
    }
    const long all = m_[0] * m_[1] * m_[2];
    sites_ = dim == 3 ? (all + 1) / 2 : all;  // FCC: the points with i + j + k even, (0,0,0) among them
    nn_ = std::numeric_limits<double>::infinity();
    for (int a = 0; a < dim; ++a) {
      const auto k = static_cast<std::size_t>(a);
      if (m_[k] < 2) continue;
      nn_ = std::min(nn_, dim == 3 ? 2 * step_[k] : step_[k]);
      for (int b = a + 1; dim == 3 && b < dim; ++b)
        if (m_[static_cast<std::size_t>(b)] > 1) nn_ = std::min(nn_, std::hypot(step_[k], step_[static_cast<std::size_t>(b)]));
    }
  };
  // About two sites per particle (random vacancies), h opened up where the
  // sites would be closer than a diameter, closed in where rounding left too few.
  const double vol = dim == 3 ? rlen[0] * rlen[1] * rlen[2] : rlen[0] * rlen[1];
  const double n_target = 2.0 * double(std::max<long>(1, s.count));
  double h = dim == 3 ? std::cbrt(vol / (2 * n_target)) : std::sqrt(vol / n_target);
  build(h);
  for (int it = 0; it < 10000 && nn_ < dmin; ++it) build(h *= 1.01);
  for (int it = 0; it < 10000 && sites_ < s.count; ++it) {
    build(h * 0.99);
    if (nn_ < dmin) {
      build(h);
      break;
    }
    h *= 0.99;
  }
  if (sites_ < s.count || nn_ < dmin)
    throw ConfigError(fmt::format("particles.count: {} particles of diameter {:.6g} do not fit this box on a lattice "
                                  "of sites a diameter apart (at most {}); use fewer particles (a lower solid "
                                  "fraction) or a larger box",
                                  s.count, 2 * r, sites_));
  jitter_ = std::isfinite(nn_) ? 0.5 * (nn_ - 2 * r) : 0.0;
  // The blocks and their counts: the largest-remainder rounding of
  // count x sites_b / sites, ties to the lower block index.
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    nb_[k] = (m_[k] + edge_ - 1) / edge_;
  }
  const long nblocks = nb_[0] * nb_[1] * nb_[2];
  count_.assign(static_cast<std::size_t>(nblocks), 0);
  first_id_.assign(static_cast<std::size_t>(nblocks), 0);
  std::vector<long> rem(static_cast<std::size_t>(nblocks), 0);
  long given = 0;
  for (long b = 0; b < nblocks; ++b) {
    const __int128 num = static_cast<__int128>(s.count) * block_sites(b);
    count_[static_cast<std::size_t>(b)] = static_cast<long>(num / sites_);
    rem[static_cast<std::size_t>(b)] = static_cast<long>(num % sites_);
    given += count_[static_cast<std::size_t>(b)];
  }
  std::vector<long> order(static_cast<std::size_t>(nblocks));
  std::iota(order.begin(), order.end(), 0L);
  std::stable_sort(order.begin(), order.end(), [&](long a, long b) {
    return rem[static_cast<std::size_t>(a)] > rem[static_cast<std::size_t>(b)];
  });
  for (long i = 0; i < s.count - given; ++i) ++count_[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])];
  long id = 0;
  for (long b = 0; b < nblocks; ++b) {
    first_id_[static_cast<std::size_t>(b)] = id;
    id += count_[static_cast<std::size_t>(b)];
  }
}

long BlockPacking::block_sites(long b) const {
  const long c[3] = {b % nb_[0], (b / nb_[0]) % nb_[1], b / (nb_[0] * nb_[1])};
  long ext[3], lo[3];
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    lo[a] = c[a] * edge_;
    ext[a] = std::min(m_[k], lo[a] + edge_) - lo[a];
  }
  const long all = ext[0] * ext[1] * ext[2];
  if (spec_.dim == 2) return all;
  // Points with i + j + k even in a box of `all` points: half of them when
  // `all` is even, else one more (corner even) or one fewer (corner odd).
  if (all % 2 == 0) return all / 2;
  return (lo[0] + lo[1] + lo[2]) % 2 == 0 ? (all + 1) / 2 : (all - 1) / 2;
}

void BlockPacking::block(long b, HostParticles& out, const std::array<double, 3>* lo, const std::array<double, 3>* hi,
                         const std::function<bool(const Vec3d&)>& keep) const {
  const BlockPackingSpec& s = spec_;
  const int dim = s.dim;
  const long n = count_[static_cast<std::size_t>(b)];
  if (n == 0) return;
  const long c[3] = {b % nb_[0], (b / nb_[0]) % nb_[1], b / (nb_[0] * nb_[1])};
  long lo_site[3], ext[3];
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    lo_site[a] = c[a] * edge_;
    ext[a] = std::min(m_[k], lo_site[a] + edge_) - lo_site[a];
  }
  // The block's sites (offsets in the block, x fastest), then a uniform
  // random subset of n of them (partial Fisher-Yates).
  std::vector<long> site;
  site.reserve(static_cast<std::size_t>(ext[0] * ext[1] * ext[2]));
  for (long z = 0; z < ext[2]; ++z)
    for (long y = 0; y < ext[1]; ++y)
      for (long x = 0; x < ext[0]; ++x)
        if (dim == 2 || (lo_site[0] + x + lo_site[1] + y + lo_site[2] + z) % 2 == 0) site.push_back(x + ext[0] * (y + ext[1] * z));
  std::mt19937_64 rng(mix(s.seed ^ mix(static_cast<std::uint64_t>(b))));
  for (long i = 0; i < n; ++i) {
    std::uniform_int_distribution<long> pick(i, static_cast<long>(site.size()) - 1);
    std::swap(site[static_cast<std::size_t>(i)], site[static_cast<std::size_t>(pick(rng))]);
  }
  // Random velocities from a stream of their own, their block mean removed.
  std::vector<Vec3d> dv(static_cast<std::size_t>(n), Vec3d{0, 0, 0});
  if (s.speed > 0) {
    std::mt19937_64 vr(mix(~s.seed ^ mix(static_cast<std::uint64_t>(b) + 0x5851F42D4C957F2Dull)));
    std::normal_distribution<double> N01(0.0, 1.0);
    Vec3d mean{0, 0, 0};
    for (auto& d : dv) {
      double len = 0;
      do {  // isotropic direction: a normalised Gaussian vector
        d = {N01(vr), N01(vr), dim == 3 ? N01(vr) : 0.0};
        len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      } while (!(len > 1e-12));
      for (int k = 0; k < 3; ++k) d[k] *= s.speed / len;
      mean = mean + d;
    }
    mean = mean * (1.0 / double(n));
    for (auto& d : dv) d = d - mean;
  }
  generated_ += n;
  for (long i = 0; i < n; ++i) {
    const long o = site[static_cast<std::size_t>(i)];
    const long q[3] = {lo_site[0] + o % ext[0], lo_site[1] + (o / ext[0]) % ext[1], lo_site[2] + o / (ext[0] * ext[1])};
    Vec3d x{0, 0, 0};
    for (int a = 0; a < 3; ++a) {
      const auto k = static_cast<std::size_t>(a);
      x[a] = rlo_[k] + (a < dim && s.periodic[k] ? double(q[a]) + 0.5 : double(q[a])) * step_[k];
    }
    // A uniform point of the ball (disk) of radius jitter about the site,
    // kept inside the region on closed axes (else the site itself).
    for (int tries = 0; tries < 20 && s.displace && jitter_ > 0; ++tries) {
      Vec3d d{uniform(rng, -1.0, 1.0), uniform(rng, -1.0, 1.0), dim == 3 ? uniform(rng, -1.0, 1.0) : 0.0};
      if (dot(d, d) > 1) continue;
      const Vec3d y = x + d * jitter_;
      bool ok = true;
      for (int a = 0; a < dim; ++a) {
        const auto k = static_cast<std::size_t>(a);
        if (!s.periodic[k] && (y[a] < rlo_[k] || y[a] > s.hi[k] - s.radius)) ok = false;
      }
      if (ok) {
        x = y;
        break;
      }
    }
    bool inside = true;
    for (int a = 0; a < dim; ++a) {
      const auto k = static_cast<std::size_t>(a);
      if (s.periodic[k]) {
        const double L = s.hi[k] - s.lo[k];
        if (x[a] >= s.hi[k]) x[a] -= L;
        if (x[a] < s.lo[k]) x[a] += L;
      }
      if (lo && (x[a] < (*lo)[k] || !(x[a] < (*hi)[k]))) inside = false;
    }
    if (!inside || (keep && !keep(x))) continue;
    out.add(x, s.radius, s.density, s.velocity + dv[static_cast<std::size_t>(i)], s.angular_velocity, 0,
            first_id_[static_cast<std::size_t>(b)] + i);
  }
}

HostParticles BlockPacking::pack(const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                                 const std::function<bool(const Vec3d&)>& keep) const {
  generated_ = 0;
  // Per axis, the blocks holding a site within the displacement of [lo, hi)
  // (on a periodic axis, of one of its images).
  std::array<std::vector<long>, 3> along;
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    std::vector<char> need(static_cast<std::size_t>(nb_[k]), 0);
    if (a >= spec_.dim || m_[k] == 1 || !(step_[k] > 0)) {
      std::fill(need.begin(), need.end(), 1);
    } else {
      const bool per = spec_.periodic[k];
      const double off = per ? 0.5 : 0.0;  // site q at rlo + (q + off) step
      const double pad = jitter_ + 1e-9 * (spec_.hi[k] - spec_.lo[k]);
      long q0 = static_cast<long>(std::floor((lo[k] - pad - rlo_[k]) / step_[k] - off));
      long q1 = static_cast<long>(std::ceil((hi[k] + pad - rlo_[k]) / step_[k] - off));
      if (per && q1 - q0 + 1 >= m_[k]) {
        std::fill(need.begin(), need.end(), 1);
      } else {
        if (!per) {
          q0 = std::max<long>(q0, 0);
          q1 = std::min<long>(q1, m_[k] - 1);
        }
        for (long q = q0; q <= q1; ++q) {
          const long w = ((q % m_[k]) + m_[k]) % m_[k];
          need[static_cast<std::size_t>(w / edge_)] = 1;
        }
      }
    }
    for (long i = 0; i < nb_[k]; ++i)
      if (need[static_cast<std::size_t>(i)]) along[k].push_back(i);
  }
  HostParticles out;
  for (long bz : along[2])
    for (long by : along[1])
      for (long bx : along[0]) block(bx + nb_[0] * (by + nb_[1] * bz), out, &lo, &hi, keep);
  out.apart_by_construction = true;  // sites nn apart, each centre within (nn - 2 r) / 2 of its own
  return out;
}

HostParticles BlockPacking::pack_all() const {
  generated_ = 0;
  HostParticles out;
  out.x.reserve(static_cast<std::size_t>(spec_.count));
  for (long b = 0; b < blocks(); ++b) block(b, out, nullptr, nullptr, {});
  out.apart_by_construction = true;
  return out;
}

}  // namespace lbdem::dem
