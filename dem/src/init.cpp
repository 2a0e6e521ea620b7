#include "dem/init.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numeric>
#include <random>
#include <sstream>
#include <vector>

#include <fmt/format.h>

#include "core/error.hpp"
#include "core/random.hpp"
#include "core/output.hpp"
#include "dem/contact.hpp"

namespace lbdem::dem {

HostParticles read_particles_csv(const std::string& path, double default_density) {
  std::ifstream in(path);
  if (!in) throw ConfigError(fmt::format("particles.file: cannot open '{}'", path));
  std::string line;
  if (!std::getline(in, line)) throw ConfigError(fmt::format("particles.file: '{}' is empty", path));
  std::map<std::string, int> col;
  {
    std::stringstream ss(line);
    std::string name;
    int k = 0;
    while (std::getline(ss, name, ',')) {
      name.erase(std::remove_if(name.begin(), name.end(), [](unsigned char c) { return std::isspace(c); }), name.end());
      col[name] = k++;
    }
  }
  for (const char* req : {"x", "y", "z", "r"})
    if (!col.count(req))
      throw ConfigError(fmt::format("particles.file: '{}' has no column '{}' (header must name x,y,z,r and may add "
                                    "vx,vy,vz,wx,wy,wz,density,id,type)", path, req));
  HostParticles hp;
  long lineno = 1;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::vector<double> v;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) {
      try {
        std::size_t used = 0;
        v.push_back(std::stod(cell, &used));
      } catch (const std::exception&) {
        throw ConfigError(fmt::format("particles.file: '{}' line {}: '{}' is not a number", path, lineno, cell));
      }
    }
    if (v.size() < col.size())
      throw ConfigError(fmt::format("particles.file: '{}' line {}: {} values, header has {}", path, lineno, v.size(),
                                    col.size()));
    auto get = [&](const char* k, double def) { return col.count(k) ? v[col[k]] : def; };
    const double r = get("r", 0);
    if (!(r > 0)) throw ConfigError(fmt::format("particles.file: '{}' line {}: radius {} must be > 0", path, lineno, r));
    const double rho = get("density", default_density);
    hp.add({get("x", 0), get("y", 0), get("z", 0)}, r, rho, {get("vx", 0), get("vy", 0), get("vz", 0)},
           {get("wx", 0), get("wy", 0), get("wz", 0)}, static_cast<int>(get("type", 0)),
           col.count("id") ? static_cast<std::int64_t>(get("id", 0)) : -1);
  }
  return hp;
}

HostParticles read_particles_h5(const std::string& path, double default_density) {
  auto optional = [&](const char* name) {
    try {
      return io::read_dataset(path, name);
    } catch (const std::exception&) {
      return std::vector<double>{};
    }
  };
  std::vector<double> x, r;
  try {
    x = io::read_dataset(path, "positions");
    r = io::read_dataset(path, "radius");
  } catch (const std::exception& e) {
    throw ConfigError(fmt::format("particles.file: '{}' is not a particle snapshot with 'positions' and 'radius' ({})",
                                  path, e.what()));
  }
  const std::size_t n = r.size();
  if (x.size() != 3 * n)
    throw ConfigError(fmt::format("particles.file: '{}': {} positions for {} radii", path, x.size() / 3, n));
  const std::vector<double> v = optional("velocity"), w = optional("angular_velocity"), id = optional("id"),
                            m = optional("mass");
  HostParticles hp;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3d vel = v.size() == 3 * n ? Vec3d{v[3 * i], v[3 * i + 1], v[3 * i + 2]} : Vec3d{};
    const Vec3d om = w.size() == 3 * n ? Vec3d{w[3 * i], w[3 * i + 1], w[3 * i + 2]} : Vec3d{};
    hp.add({x[3 * i], x[3 * i + 1], x[3 * i + 2]}, r[i], default_density, vel, om, 0,
           id.size() == n ? static_cast<std::int64_t>(id[i]) : -1);
    if (m.size() == n) hp.mass.back() = m[i];
  }
  return hp;
}

HostParticles lattice_particles(const Vec3d& origin, const std::array<long, 3>& count, const Vec3d& spacing,
                                double radius, double density) {
  HostParticles hp;
  for (long k = 0; k < count[2]; ++k)
    for (long j = 0; j < count[1]; ++j)
      for (long i = 0; i < count[0]; ++i)
        hp.add({origin.x + i * spacing.x, origin.y + j * spacing.y, origin.z + k * spacing.z}, radius, density);
  return hp;
}

namespace {

// Cell grid on the host for the Monte Carlo overlap checks.
struct HostCells {
  std::array<int, 3> nc{};
  std::array<double, 3> lo{}, len{};
  std::array<bool, 3> per{};
  std::vector<std::vector<int>> cells;
  int cell_of(const Vec3d& x) const {
    int c[3];
    for (int k = 0; k < 3; ++k) {
      c[k] = static_cast<int>(std::floor((x[k] - lo[k]) / len[k] * nc[k]));
      c[k] = std::clamp(c[k], 0, nc[k] - 1);
    }
    return c[0] + nc[0] * (c[1] + nc[1] * c[2]);
  }
};

}  // namespace

HostParticles random_packing(const RandomPackingSpec& s) {
  const double phi = s.solid_fraction;
  if (!(phi > 0 && phi < 0.74))
    throw ConfigError(fmt::format("particles.solid_fraction: {} must be in (0, 0.74)", phi));
  if (!(s.r_min > 0 && s.r_max >= s.r_min))
    throw ConfigError(fmt::format("particles.radius: range [{}, {}] must satisfy 0 < min <= max", s.r_min, s.r_max));
  double vbox = 1;
  std::array<double, 3> rlo{}, rlen{};
  for (int k = 0; k < 3; ++k) {
    const double L = s.hi[k] - s.lo[k];
    vbox *= L;
    rlo[k] = s.periodic[k] ? s.lo[k] : s.lo[k] + s.r_max;
    rlen[k] = s.periodic[k] ? L : L - 2 * s.r_max;
    if (!(rlen[k] > 0)) throw ConfigError(fmt::format("domain: axis {} is narrower than one particle", k));
  }
  const double er3 = s.r_max > s.r_min
                         ? (std::pow(s.r_max, 4) - std::pow(s.r_min, 4)) / (4 * (s.r_max - s.r_min))
                         : s.r_min * s.r_min * s.r_min;
  const double vmean = 4.0 / 3.0 * kPi * er3;
  const long N = std::lround(phi * vbox / vmean);
  if (N <= 0) return {};
  // FCC = points of a cubic grid of half-spacing h with i+j+k even.
  auto axis_points = [&](int k, double h) -> long {
    if (s.periodic[k]) return 2 * std::max<long>(1, static_cast<long>(std::floor(rlen[k] / (2 * h))));
    return static_cast<long>(std::floor(rlen[k] / h)) + 1;
  };
  double h = std::cbrt(2.0 * rlen[0] * rlen[1] * rlen[2] / static_cast<double>(N)) * 1.3;
  std::array<long, 3> m{};
  std::array<double, 3> step{};
  long sites = 0;
  for (int it = 0; it < 2000; ++it, h *= 0.99) {
    for (int k = 0; k < 3; ++k) {
      m[k] = axis_points(k, h);
      step[k] = s.periodic[k] ? rlen[k] / m[k] : (m[k] > 1 ? rlen[k] / (m[k] - 1) : 0.0);
    }
    long total = m[0] * m[1] * m[2];
    sites = (total + 1) / 2;
    if (sites >= N) break;
  }
  // Nearest-neighbour distance of the (possibly anisotropic) FCC lattice.
  double nn = 1e300;
  for (int a = 0; a < 3; ++a) {
    if (m[a] > 1) nn = std::min(nn, 2 * step[a]);
    for (int b = a + 1; b < 3; ++b)
      if (m[a] > 1 && m[b] > 1) nn = std::min(nn, std::hypot(step[a], step[b]));
  }
  if (sites < N || nn < 2 * s.r_max * (1 + 1e-9))
    throw ConfigError(fmt::format("particles.solid_fraction: {} particles of radius up to {} do not fit this box at "
                                  "solid fraction {} (lattice spacing {:.4g} < diameter {:.4g}); lower the fraction",
                                  N, s.r_max, phi, nn, 2 * s.r_max));
  std::mt19937_64 rng(s.seed);
  // Random subset of the sites (partial Fisher-Yates over site ranks).
  std::vector<long> site(static_cast<std::size_t>(sites));
  {
    long q = 0;
    for (long kk = 0; kk < m[2]; ++kk)
      for (long jj = 0; jj < m[1]; ++jj)
        for (long ii = (jj + kk) % 2; ii < m[0]; ii += 2) site[q++] = ii + m[0] * (jj + m[1] * kk);
    site.resize(static_cast<std::size_t>(q));
  }
  for (long i = 0; i < N; ++i) {
    std::uniform_int_distribution<long> pick(i, static_cast<long>(site.size()) - 1);
    std::swap(site[i], site[pick(rng)]);
  }
  auto U = [](std::mt19937_64& g) { return uniform01(g); };
  HostParticles hp;
  hp.x.reserve(N); hp.v.reserve(N); hp.w.reserve(N); hp.r.reserve(N); hp.mass.reserve(N); hp.id.reserve(N); hp.type.reserve(N);
  const double jitter = 0.5 * (nn - 2 * s.r_max);
  for (long i = 0; i < N; ++i) {
    const long sidx = site[i];
    const long c[3] = {sidx % m[0], (sidx / m[0]) % m[1], sidx / (m[0] * m[1])};
    Vec3d x;
    for (int k = 0; k < 3; ++k) x[k] = rlo[k] + (s.periodic[k] ? (c[k] + 0.5) : c[k]) * step[k];
    // Uniform point in a ball of radius `jitter`, kept inside the region.
    for (int tries = 0; tries < 20 && s.displace; ++tries) {
      Vec3d d{2 * U(rng) - 1, 2 * U(rng) - 1, 2 * U(rng) - 1};
      if (dot(d, d) > 1) continue;
      Vec3d y = x + d * jitter;
      bool ok = true;
      for (int k = 0; k < 3; ++k)
        if (!s.periodic[k] && (y[k] < rlo[k] || y[k] > rlo[k] + rlen[k])) ok = false;
      if (ok) { x = y; break; }
    }
    for (int k = 0; k < 3; ++k)
      if (s.periodic[k]) x[k] = x[k] >= s.hi[k] ? x[k] - rlen[k] : x[k];
    const double r = s.r_min + (s.r_max - s.r_min) * U(rng);
    hp.add(x, r, s.density);
  }
  // Hard-sphere Monte Carlo sweeps (sequential, with a cell grid).
  if (s.mc_sweeps > 0 && s.displace) {
    HostCells hc;
    for (int k = 0; k < 3; ++k) {
      hc.lo[k] = s.lo[k];
      hc.len[k] = s.hi[k] - s.lo[k];
      hc.per[k] = s.periodic[k];
      hc.nc[k] = std::max(1, static_cast<int>(std::floor(hc.len[k] / (2 * s.r_max))));
      if (hc.per[k] && hc.nc[k] < 3) hc.nc[k] = 1;
    }
    hc.cells.assign(static_cast<std::size_t>(hc.nc[0]) * hc.nc[1] * hc.nc[2], {});
    std::vector<int> cell_of(N);
    for (long i = 0; i < N; ++i) {
      cell_of[i] = hc.cell_of(hp.x[i]);
      hc.cells[cell_of[i]].push_back(static_cast<int>(i));
    }
    auto min_img = [&](Vec3d d) {
      for (int k = 0; k < 3; ++k)
        if (hc.per[k]) d[k] -= hc.len[k] * std::rint(d[k] / hc.len[k]);
      return d;
    };
    double delta = std::max(jitter, 0.05 * s.r_min);
    for (int sweep = 0; sweep < s.mc_sweeps; ++sweep) {
      long accepted = 0;
      for (long i = 0; i < N; ++i) {
        Vec3d y = hp.x[i] + Vec3d{(2 * U(rng) - 1) * delta, (2 * U(rng) - 1) * delta, (2 * U(rng) - 1) * delta};
        bool ok = true;
        for (int k = 0; k < 3; ++k) {
          if (hc.per[k]) {
            if (y[k] >= s.hi[k]) y[k] -= hc.len[k];
            if (y[k] < s.lo[k]) y[k] += hc.len[k];
          } else if (y[k] < s.lo[k] + hp.r[i] || y[k] > s.hi[k] - hp.r[i]) ok = false;
        }
        if (!ok) continue;
        const int c0 = hc.cell_of(y);
        const int cx = c0 % hc.nc[0], cy = (c0 / hc.nc[0]) % hc.nc[1], cz = c0 / (hc.nc[0] * hc.nc[1]);
        for (int dz = -1; dz <= 1 && ok; ++dz)
          for (int dy = -1; dy <= 1 && ok; ++dy)
            for (int dx = -1; dx <= 1 && ok; ++dx) {
              int q[3] = {cx + dx, cy + dy, cz + dz};
              bool skip = false;
              for (int k = 0; k < 3; ++k) {
                if (hc.nc[k] == 1) { if ((k == 0 ? dx : k == 1 ? dy : dz) != 0) skip = true; q[k] = 0; continue; }
                if (hc.per[k]) q[k] = (q[k] + hc.nc[k]) % hc.nc[k];
                else if (q[k] < 0 || q[k] >= hc.nc[k]) skip = true;
              }
              if (skip) continue;
              for (int j : hc.cells[q[0] + hc.nc[0] * (q[1] + hc.nc[1] * q[2])]) {
                if (j == i) continue;
                const Vec3d d = min_img(hp.x[j] - y);
                const double rs = hp.r[i] + hp.r[j];
                if (dot(d, d) < rs * rs) { ok = false; break; }
              }
            }
        if (!ok) continue;
        ++accepted;
        hp.x[i] = y;
        if (c0 != cell_of[i]) {
          auto& v = hc.cells[cell_of[i]];
          v.erase(std::find(v.begin(), v.end(), static_cast<int>(i)));
          hc.cells[c0].push_back(static_cast<int>(i));
          cell_of[i] = c0;
        }
      }
      // Keep the acceptance near one half.
      const double acc = static_cast<double>(accepted) / static_cast<double>(N);
      delta *= acc > 0.5 ? 1.2 : 0.8;
      delta = std::min(delta, s.r_min);
    }
  }
  hp.apart_by_construction = true;
  return hp;
}

}  // namespace lbdem::dem
