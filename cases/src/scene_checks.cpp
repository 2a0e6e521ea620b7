#include "scene_checks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

#include "core/buffer.hpp"
#include "halo/comm.hpp"
#include "halo/decomposition.hpp"
#include "halo/parallel_options.hpp"
#include "imb/coupled.hpp"
#include "imb/coupled_checks.hpp"

namespace lbdem::cases {

namespace {

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.4g", v + 0.0);  // + 0.0: no "-0"
  return b;
}
std::string vec(const Vec3d& v, int dim) {
  std::string s("[");  // appended piecewise: GCC 12 warns (-Wrestrict, a false positive) on "[" + std::string
  for (int a = 0; a < dim; ++a) {
    s += num(v[a]);
    s += a + 1 < dim ? ", " : "]";
  }
  return s;
}
const char* axis_name(int a) { return a == 0 ? "x" : a == 1 ? "y" : "z"; }
std::string mib(double bytes) { return num(bytes / 1048576.0) + " MiB"; }

std::int64_t id_of(const dem::HostParticles& p, std::size_t i) {
  return i < p.id.size() ? p.id[i] : static_cast<std::int64_t>(i);
}
std::string particle(const dem::HostParticles& p, std::size_t i, int dim) {
  return "particle id " + std::to_string(id_of(p, i)) + " (position " + vec(p.x[i], dim) + ", radius " + num(p.r[i]) +
         ")";
}

}  // namespace

// ----------------------------------------------------------------- particles
ParticleBox particle_box(const dem::DemParams& p, int dim, const std::string& box_key, const std::string& walls_key) {
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

void check_particles_in_box(const Config& root, const dem::HostParticles& p, const ParticleBox& box) {
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

void check_particle_overlaps(const Config& root, const dem::HostParticles& p, const ParticleBox& box) {
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

// ----------------------------------------------------------------- grids
void check_min_cells(const Config& root, const std::string& key, const std::vector<long>& cells, long min_cells,
                     const std::string& what) {
  for (std::size_t a = 0; a < cells.size(); ++a)
    if (cells[a] < min_cells)
      throw ConfigError(root.source() + ": key '" + key + "': " + std::to_string(cells[a]) + " cells along " +
                        axis_name(static_cast<int>(a)) + " is too few: " + what + "; use at least " +
                        std::to_string(min_cells));
}

// ----------------------------------------------------------------- Mach
void check_fluid_mach(const Config& root, const MachInput& in) {
  if (!(in.dx > 0 && in.nu > 0 && in.u_ref > 0)) return;
  double dt = in.dt;
  if (!(dt > 0)) {
    if (!(in.tau > 0.5)) return;
    dt = (in.tau - 0.5) / 3.0 * in.dx * in.dx / in.nu;
  }
  const double tau = 0.5 + 3.0 * in.nu * dt / (in.dx * in.dx);
  if (!(tau > 0.5)) return;
  const double ma = std::sqrt(3.0) * in.u_ref * dt / in.dx;
  if (!(ma > in.max_mach)) return;
  const double f = in.max_mach / ma;  // every way out scales the lattice speed by this
  const double dt_ok = dt * f;
  const double tau_ok = 0.5 + 3.0 * in.nu * dt_ok / (in.dx * in.dx);
  // With tau kept, dt ~ dx^2 and the lattice speed u dt / dx ~ dx.
  const double dx_ok = in.dx * f;
  std::string msg = root.source() + ": lattice Mach number " + num(ma) + " exceeds the limit " + num(in.max_mach) +
                    " (" + in.max_mach_key + "): the reference speed " + num(in.u_ref) + " m/s, set by '" +
                    in.speed_key + "'" + (in.speed_what.empty() ? "" : " (" + in.speed_what + ")") +
                    ", moves " + num(in.u_ref * dt / in.dx) + " cells per step (dt = " + num(dt) + " s, tau = " +
                    num(tau) + ", dx = " + num(in.dx) + " m); the weakly compressible LBM is inaccurate and unstable "
                    "there. Any one of: lower '" + in.speed_key + "' to at most " +
                    num(in.speed_scale > 0 ? in.u_ref * f / in.speed_scale : in.u_ref * f) +
                    "; a smaller time step: collision.tau <= " + num(tau_ok) + " (or time.dt <= " + num(dt_ok) +
                    " s); a finer grid: domain.spacing <= " + num(dx_ok) +
                    " m with the same tau (more cells for the same size)";
  if (tau_ok < 0.51) msg += "; tau this close to 1/2 needs collision.model: trt";
  throw ConfigError(msg);
}

void check_particles_mach(const Config& root, const lbm::LbmSetup& fluid, const dem::DemParams& dem,
                          const dem::HostParticles& p, double fluid_density, const std::array<double, 3>& gravity,
                          double max_mach) {
  if (!(fluid.tau > 0.5) || p.x.empty()) return;
  imb::CoupledParams cp;
  cp.gravity = gravity;
  cp.fluid_density = fluid_density;
  const imb::CoupledScales s = imb::coupled_scales(fluid, dem, p, cp);
  if (!(s.mach > max_mach)) return;
  const double u_max = max_mach / std::sqrt(3.0);
  std::string head = root.source() + ": lattice Mach number u sqrt(3) = " + num(s.mach) + " exceeds " +
                     num(max_mach) + " (the weakly compressible LBM with PSM diverges beyond it): ";
  if (s.u_ref == s.settling_speed && s.settling_id >= 0) {
    std::size_t i = 0;
    while (i < p.x.size() && id_of(p, i) != s.settling_id) ++i;
    if (i == p.x.size()) i = 0;
    const double d = 2 * p.r[i], m = p.mass[i];
    const double g = std::sqrt(gravity[0] * gravity[0] + gravity[1] * gravity[1] + gravity[2] * gravity[2]);
    // Largest |g| and smallest tau with a settling speed within the limit
    // (the terminal speed grows with g and falls with the viscosity).
    double glo = 0, ghi = g;
    for (int it = 0; it < 100; ++it) {
      const double mid = 0.5 * (glo + ghi);
      (imb::terminal_speed(d, m, fluid_density, s.nu, mid) <= u_max ? glo : ghi) = mid;
    }
    double tlo = fluid.tau, thi = fluid.tau;
    while (imb::terminal_speed(d, m, fluid_density, (thi - 0.5) / 3.0, g) > u_max && thi < 1e6) thi = 0.5 + 2 * (thi - 0.5);
    for (int it = 0; it < 100; ++it) {
      const double mid = 0.5 * (tlo + thi);
      (imb::terminal_speed(d, m, fluid_density, (mid - 0.5) / 3.0, g) > u_max ? tlo : thi) = mid;
    }
    std::string tau_way = thi <= 5.0 ? "raise fluid.tau to at least " + num(thi) + " (a more viscous fluid settles it slower)"
                                     : "fluid.tau would have to exceed its limit 5";
    throw ConfigError(head + "particle id " + std::to_string(s.settling_id) + " would settle at about " +
                      num(s.settling_speed) + " cells per step under physics.gravity (Schiller-Naumann terminal "
                      "speed). Any one of: lower |physics.gravity| to at most " + num(glo) +
                      " (lattice units; it scales with dt^2, so a smaller lattice time step lowers it); " + tau_way +
                      "; a lower particles.density_ratio; a finer grid (a larger particles.diameter in cells for the "
                      "same particle lowers the lattice speeds)");
  }
  if (s.u_ref == s.particle_speed) {
    throw ConfigError(head + "particle id " + std::to_string(s.fastest_id) + " starts at |v| + |w| r = " +
                      num(s.particle_speed) + " cells per step (particles.velocity, particles.angular_velocity). "
                      "Any one of: lower them so that |v| + |w| r <= " + num(u_max) +
                      "; a smaller lattice time step (velocities scale with dt, gravity with dt^2, tau - 1/2 with dt); "
                      "a finer grid (a larger particles.diameter in cells for the same particle)");
  }
  throw ConfigError(head + "a boundary moves at " + num(s.wall_speed) + " cells per step; keep it below " + num(u_max));
}

// ----------------------------------------------------------------- memory
Backend planned_backend(const RunOptions& opt) {
  if (opt.backend == "cpu" || opt.backend == "host") return Backend::Host;
  return cuda_unavailable_reason().empty() ? Backend::Cuda : Backend::Host;
}

double lbm_grid_bytes(const lbm::LbmSetup& s, double cells) {
  const double tsize = lbm::storage_bytes(s.precision);
  const double lattices = s.streaming == lbm::StreamKind::AA ? 1 : 2;
  // As lbm::lbm_memory: populations, one flag byte, the output staging (rho + u of one slab).
  return cells * (lbm::lattice_q(s.lattice) * tsize * lattices + 1) +
         4.0 * sizeof(double) * std::min(cells, static_cast<double>(kOutputSlabCells));
}

// DEM device memory of a coupled scene per particle, an upper bound from the
// DEM's layout (dem/src/particle_store.hpp, neighbour_list.hpp): 23 records
// of 32 bytes (state, its reorder copy, previous forces and velocities,
// coupling input) plus id and type twice; eight ints of sort and list
// bookkeeping; and the neighbour list at its first capacity of 32 slots
// (fitted down after the first build), each an index and a tangential
// history (24 bytes) and their copies from the previous build. The cell
// grid of the DEM (a few bytes per particle cell) is not counted.
constexpr double kCoupledDemBytesPerParticle = 23 * 32 + 2 * (8 + 4) + 8 * 4 + 32 * 2 * (4 + 24);

MemoryUse coupled_memory(const lbm::LbmSetup& fluid, const imb::CoupledParams& cp, double particles, Backend b) {
  const auto n = static_cast<Index>(std::max(0.0, std::ceil(particles)));
  MemoryUse m = lbm::lbm_memory(fluid);
  m.add(imb::psm_memory(fluid, cp.slots, cp.psm, n, b == Backend::Cuda));
  if (n > 0)
    m.add("DEM particles and lists", static_cast<std::size_t>(static_cast<double>(n) * kCoupledDemBytesPerParticle));
  return m;
}

std::string memory_table(const MemoryUse& m, double cells) {
  std::string out;
  char line[160];
  auto row = [&](const std::string& name, double bytes) {
    std::snprintf(line, sizeof line, "  %-26s %9.2f B/cell %12.1f MiB\n", name.c_str(), bytes / std::max(cells, 1.0),
                  bytes / 1048576.0);
    out += line;
  };
  for (const auto& it : m.items) row(it.name, static_cast<double>(it.bytes));
  row("total", static_cast<double>(m.total()));
  return out;
}

// The fluid one rank holds: under mpirun on N ranks the largest piece of
// the decomposition the run will use (ghost layers included), else the whole
// grid. (`lbdem check` runs as one process: the whole grid.)
lbm::LbmSetup rank_fluid(const Config& root, const lbm::LbmSetup& whole) {
  const int ranks = halo::Comm::world().size();
  if (ranks <= 1) return whole;
  const halo::ParallelOptions po = halo::parse_parallel(root);
  const halo::Decomposition dec = halo::decompose(whole.domain, ranks, po.decomposition, "parallel.decomposition");
  lbm::LbmSetup largest = whole;
  Index most = -1;
  for (int r = 0; r < ranks; ++r) {
    const Grid p = dec.piece(whole.domain, r);
    if (p.storage_cells() > most) {
      most = p.storage_cells();
      largest.domain = p;
    }
  }
  return largest;
}

// Device bytes of the grid on one rank (rank_fluid) and the way out of a
// refusal ("precision: fp32" only where it is not already so).
double rank_grid_bytes(const Config& root, const lbm::LbmSetup& fluid) {
  const lbm::LbmSetup mine = rank_fluid(root, fluid);
  return lbm_grid_bytes(mine, static_cast<double>(mine.domain.storage_cells()));
}
std::string or_fp32(const lbm::LbmSetup& fluid) {
  return fluid.precision == lbm::Precision::FP64 ? ", or precision: fp32" : "";
}

void check_coupled_memory(const Config& root, const lbm::LbmSetup& fluid, const imb::CoupledParams& cp,
                          double particles, const RunOptions& opt) {
  double cells = 1;
  for (int a = 0; a < 3; ++a) cells *= static_cast<double>(fluid.domain.global[static_cast<std::size_t>(a)]);
  // The device holds this rank's piece; the host set-up builds whole-grid
  // fields (flags, rho, u) on every rank, and every rank reads every particle.
  const lbm::LbmSetup mine = rank_fluid(root, fluid);
  const double piece_cells = static_cast<double>(mine.domain.storage_cells());
  const Backend b = planned_backend(opt);
  // Absurd sizes first, in double (the exact sum below is in 64-bit integers).
  check_memory(root, b, lbm_grid_bytes(mine, piece_cells) + particles * kDemDeviceBytesPerParticle,
               cells * (1 + 4 * sizeof(double)) + particles * kDemHostBytesPerParticle, "domain.cells, particles",
               "the grid of " + num(cells) + " cells with " + num(particles) + " particles",
               "use fewer cells or particles" + or_fp32(fluid));
  const MemoryUse m = coupled_memory(mine, cp, particles, b);
  std::vector<MemoryItem> big = m.items;
  std::sort(big.begin(), big.end(), [](const MemoryItem& x, const MemoryItem& y) { return x.bytes > y.bytes; });
  std::string parts;
  for (std::size_t i = 0; i < big.size() && i < 3; ++i)
    parts += (i ? ", " : "") + big[i].name + " " + num(static_cast<double>(big[i].bytes) / piece_cells) + " B/cell";
  // Host: the set-up fields of initialize() (flag byte, rho, u per cell) and the particles' host copies.
  check_memory(root, b, static_cast<double>(m.total()),
               cells * (1 + 4 * sizeof(double)) + particles * kDemHostBytesPerParticle, "domain.cells, particles",
               "the grid of " + num(cells) + " cells with " + num(particles) + " particles (" +
                   num(static_cast<double>(m.total()) / piece_cells) + " B/cell: " + parts + ")" +
                   (mine.domain.storage_cells() < fluid.domain.storage_cells()
                        ? " on each of " + std::to_string(halo::Comm::world().size()) + " ranks"
                        : std::string()),
               "use fewer cells or particles" + or_fp32(fluid));
}

void check_memory(const Config& root, Backend b, double device_bytes, double host_bytes, const std::string& key,
                  const std::string& what, const std::string& fix) {
  const double dev_have = static_cast<double>(backend_free_bytes(b));
  const double host_have = static_cast<double>(backend_free_bytes(Backend::Host));
  const bool host = b == Backend::Host;
  const double host_need = host_bytes + (host ? device_bytes : 0);
  if (!host && device_bytes > dev_have)
    throw ResourceError(root.source() + ": " + key + ": " + what + " needs at least " + mib(device_bytes) +
                        " of GPU memory but " + mib(dev_have) + " are free; " + fix);
  if (host_need > host_have)
    throw ResourceError(root.source() + ": " + key + ": " + what + " needs at least " + mib(host_need) +
                        " of host memory but " + mib(host_have) + " are free; " + fix);
}

// ----------------------------------------------------------------- the plan
void check_plan(const Config& root, const RunOptions& opt, double steps, double cell_updates, double particle_steps,
                const std::string& steps_key) {
  if (!(steps < 1e18))  // beyond a 64-bit step counter (and a computer's lifetime)
    throw ConfigError(root.source() + ": " + steps_key + " plans " + num(steps) +
                      " steps, more than a 64-bit step counter holds; check those keys");
  if (opt.force) return;
  const double per_step = std::max(kLeastSecondsPerStep, cell_updates / kFastestCellUpdatesPerSecond +
                                                             particle_steps / kFastestParticleStepsPerSecond);
  const double secs = steps * per_step;
  if (secs > kMaxPlannedSeconds)
    throw ConfigError(root.source() + ": " + steps_key + " plans " + num(steps) + " steps" +
                      (cell_updates > 0 ? " of " + num(cell_updates) + " cells" : std::string()) +
                      (particle_steps > 0 ? (cell_updates > 0 ? " and " : " of ") + num(particle_steps) +
                                                " particles"
                                          : std::string()) +
                      ": at least " + num(secs / kMaxPlannedSeconds) +
                      " years of wall time even at the fastest speed this code reaches on one GPU; check those keys "
                      "(and the values they follow from), or pass --force to start it anyway");
}

// ----------------------------------------------------------------- per scene
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

void check_particles_random(const Config& root, const Config& pc, const lbm::LbmSetup& fluid,
                            const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                            const std::array<bool, 3>& periodic, double solid_fraction, double r,
                            const RunOptions& opt) {
  // The key is particles.diameter here.
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    if (!(2 * r < hi[k] - lo[k]))
      throw ConfigError(pc.where("diameter") + ": key 'particles.diameter' = " + pc.value_text("diameter") +
                        ": the particles do not fit the box along " + axis_name(a) + " (" + num(hi[k] - lo[k]) +
                        " cells" + (periodic[k] ? ", periodic" : "") +
                        ", domain.cells); use smaller particles or more cells");
  }
  check_particles_memory(root, fluid, random_packing_count(lo, hi, solid_fraction, r), opt);
}

void check_dem_scene(const Config& root, const dem::DemParams& p, const dem::HostParticles& hp, long steps,
                     const RunOptions& opt) {
  const ParticleBox box = particle_box(p, 3, "domain.lo, domain.hi", "walls");
  check_particles_in_box(root, hp, box);
  check_particle_overlaps(root, hp, box);
  const double n = static_cast<double>(hp.x.size());
  check_memory(root, planned_backend(opt), n * kDemDeviceBytesPerParticle, n * kDemHostBytesPerParticle, "particles",
               num(n) + " particles", "use fewer particles");
  std::string key = "time.steps";
  double planned = double(steps);
  if (opt.steps) {
    key = "--steps";
  } else if (const auto t = root.optional_section("time"); t && t->has("end_time")) {
    key = "time.end_time = " + t->value_text("end_time") + " s with dt = " + num(p.dt) + " s (" +
          (t->has("dt") ? "time.dt" : "t_c / time.steps_per_collision, t_c from material.stiffness and the radii") +
          ")";
    planned = t->number("end_time") / p.dt;  // in double: the integer count may have overflowed
  }
  check_plan(root, opt, planned, 0, n, key);
}

void check_fluid_scene(const Config& root, const std::string& scene, const std::string& mode,
                       const std::vector<long>& cells, const Config& sc, double dx, double nu, double u_ref,
                       double max_mach, std::optional<double> tau, std::optional<double> dt) {
  MachInput m;
  m.dx = dx;
  m.nu = nu;
  m.u_ref = u_ref;
  m.max_mach = max_mach;
  m.tau = tau.value_or(0);
  m.dt = dt.value_or(0);
  if (scene == "channel") {
    check_min_cells(root, "domain.cells", {cells[1]}, 3, "a channel needs at least 3 fluid cells across (y) for a "
                                                          "velocity profile between its walls");
    if (mode == "inlet_outlet")
      check_min_cells(root, "domain.cells", {cells[0]}, 3, "an inlet/outlet channel needs at least 3 cells along x");
    if (mode == "periodic") {
      m.speed_key = sc.full_key("body_acceleration");
      m.speed_what = "Poiseuille centre-line speed a H^2 / (8 nu)";
      m.speed_scale = u_ref / sc.number("body_acceleration");
    } else {
      m.speed_key = sc.full_key("inlet_velocity");
      m.speed_what = "centre-line speed of the developed profile, 1.5 times the inlet velocity";
      m.speed_scale = 1.5;
    }
  } else if (scene == "taylor_green") {
    check_min_cells(root, "domain.cells", cells, 4, "a Taylor-Green vortex needs at least 4 cells per period");
    m.speed_key = sc.full_key("velocity");
  } else if (scene == "lid_driven_cavity") {
    check_min_cells(root, "domain.cells", cells, 4,
                    "a lid-driven cavity needs at least 4 fluid cells per axis for its vortex between the walls");
    m.speed_key = sc.full_key("lid_velocity");
  } else {
    m.speed_key = sc.full_key(sc.has("reference_velocity") ? "reference_velocity" : "initial_velocity");
    m.speed_what = sc.has("reference_velocity") ? "" : "the length of the initial velocity";
  }
  if (!(m.speed_scale > 0) || !std::isfinite(m.speed_scale)) m.speed_scale = 1;
  check_fluid_mach(root, m);
}

void check_fluid_plan(const Config& root, const RunOptions& opt, double steps, double fluid_cells) {
  std::string key = "time.steps";
  if (opt.steps) key = "--steps";
  else if (const auto t = root.optional_section("time"); t && t->has("end")) key = "time.end / dt";
  check_plan(root, opt, steps, fluid_cells, 0, key);
}

void check_fixed_sphere(const Config& root, int dim, double diameter, double chi, lbm::Precision precision,
                        lbm::StreamKind streaming, long max_steps, const RunOptions& opt) {
  lbm::LbmSetup fluid;
  fluid.lattice = dim == 3 ? lbm::LatticeKind::D3Q19 : lbm::LatticeKind::D2Q9;
  fluid.precision = precision;
  fluid.streaming = streaming;
  const long L = std::lround(diameter / chi);
  if (L < 4)
    throw ConfigError(root.source() + ": keys 'geometry.diameter' = " + num(diameter) + ", 'geometry.chi' = " +
                      num(chi) + ": the array period L = d / chi = " + std::to_string(L) +
                      " cells is too short to hold a resolved sphere and the flow around it; use L >= 4 (a larger "
                      "diameter or a smaller chi)");
  const double cells = dim == 3 ? double(L) * L * L : double(L) * L;
  const double bytes = lbm_grid_bytes(fluid, cells);
  check_memory(root, planned_backend(opt), bytes, cells * (1 + 5 * sizeof(double)), "geometry.diameter, geometry.chi",
               "the grid of " + num(cells) + " cells (L = d / chi = " + std::to_string(L) + ")",
               "use a smaller diameter or a larger chi");
  check_plan(root, opt, double(max_steps), cells, 0, opt.steps ? "--steps" : "steady.max_steps");
}

void check_particles_memory(const Config& root, const lbm::LbmSetup& fluid, double particles, const RunOptions& opt) {
  double cells = 1;
  for (int a = 0; a < 3; ++a) cells *= static_cast<double>(fluid.domain.global[static_cast<std::size_t>(a)]);
  const double dev = rank_grid_bytes(root, fluid) + particles * kDemDeviceBytesPerParticle;
  // Host: the set-up fields of initialize() (flags, rho, u), the particles' host copies.
  const double host = cells * (1 + 4 * sizeof(double)) + particles * kDemHostBytesPerParticle;
  check_memory(root, planned_backend(opt), dev, host, particles > 0 ? "domain.cells, particles.solid_fraction" : "domain.cells",
               "the grid of " + num(cells) + " cells" + (particles > 0 ? " with about " + num(particles) + " particles" : ""),
               "use fewer cells" + std::string(particles > 0 ? ", a lower solid fraction or larger particles" : "") +
                   or_fp32(fluid));
}

void check_particles_scene(const Config& root, const lbm::LbmSetup& fluid, const dem::DemParams& dem,
                           const dem::HostParticles& p, const std::array<double, 3>& gravity, bool balance,
                           int dem_substeps, long steps, const RunOptions& opt) {
  const int dim = fluid.lattice == lbm::LatticeKind::D2Q9 ? 2 : 3;
  ParticleBox box = particle_box(dem, dim, "domain.cells", "the wall");
  check_particles_in_box(root, p, box);
  check_particle_overlaps(root, p, box);
  bool periodic = true;
  for (int a = 0; a < dim; ++a) periodic = periodic && fluid.domain.periodic[static_cast<std::size_t>(a)];
  const double g = std::sqrt(gravity[0] * gravity[0] + gravity[1] * gravity[1] + gravity[2] * gravity[2]);
  if (periodic && !balance && g > 0)
    throw ConfigError(root.source() + ": key 'physics.balance_weight' = false with physics.gravity = " +
                      vec({gravity[0], gravity[1], gravity[2]}, 3) +
                      " in a fully periodic domain: nothing holds the particles' weight, and the whole system "
                      "accelerates without bound until the Mach limit; set physics.balance_weight: true (a fluid body "
                      "force balances the weight, first paper Sec. 2) or physics.gravity: [0, 0, 0]");
  // DEM sub-steps against the shortest contact, in double (a stiffness of
  // 1e30 asks for more sub-steps than an int holds).
  const double tc = dem::min_collision_time(dem, p);
  if (std::isfinite(tc) && tc > 0 && double(dem_substeps) * tc < dem.min_steps_per_collision * (1 - 1e-12)) {
    const double need = std::ceil(dem.min_steps_per_collision / tc - 1e-9);
    throw ConfigError(root.source() + ": key 'dem.substeps' = " + std::to_string(dem_substeps) +
                      ": the DEM time step 1/" + std::to_string(dem_substeps) +
                      " (lattice units) is too long for the shortest contact, t_c = " + num(tc) + " (from dem.stiffness "
                      "and the particle masses), which needs at least " + num(dem.min_steps_per_collision) +
                      " DEM steps: use dem.substeps >= " + num(need) +
                      (need > 100000 ? " (beyond its limit 100000: soften dem.stiffness)" : " or soften dem.stiffness"));
  }
  check_particles_mach(root, fluid, dem, p, 1.0, gravity, imb::CoupledLimits{}.max_mach);
  double cells = 1;
  for (int a = 0; a < 3; ++a) cells *= static_cast<double>(fluid.domain.global[static_cast<std::size_t>(a)]);
  const double n = static_cast<double>(p.x.size());
  check_memory(root, planned_backend(opt), rank_grid_bytes(root, fluid) + n * kDemDeviceBytesPerParticle,
               cells * (1 + 4 * sizeof(double)) + n * kDemHostBytesPerParticle, "domain.cells, particles",
               "the grid of " + num(cells) + " cells with " + num(n) + " particles",
               "use fewer cells or particles" + or_fp32(fluid));
  check_plan(root, opt, double(steps), cells, n * dem_substeps, opt.steps ? "--steps" : "time.steps");
}

// ----------------------------------------------------------------- key names
const KeyMap& key_map(const std::string& scene) {
  // The coupled solver and its checks (imb/) name the parameters of
  // CoupledParams and DemParams; the particles scene reads them from these keys.
  static const KeyMap particles = {
      {"coupling.dem_substeps", "dem.substeps"},
      {"dem.dt", "the DEM time step"},  // 1 / dem.substeps, not a key of the file
      {"coupling.gravity", "physics.gravity"},
      {"dem.gravity", "physics.gravity"},
      {"coupling.slots", "psm.slots"},
      {"material.stiffness", "dem.stiffness"},
      {"material.restitution", "dem.restitution"},
      {"material.wall_stiffness", "dem.wall_stiffness"},
      {"material.wall_restitution", "dem.wall_restitution"},
      {"material.friction", "dem.friction"},
      {"material.wall_friction", "dem.wall_friction"},
      {"fluid.body_force", "physics.balance_weight"},
      {"dem.periodic", "domain.periodic"},
      {"dem.lo", "domain.cells"},
      {"dem.hi", "domain.cells"},
  };
  // run_fixed_sphere() (imb/src/fixed_sphere.cpp) names FixedSphereSpec fields.
  static const KeyMap fixed_sphere = {
      {"fixed_sphere.dim", "geometry.dim"},
      {"fixed_sphere.chi", "geometry.chi"},
      {"fixed_sphere.diameter", "geometry.diameter"},
      {"coupling.slots", "psm.slots"},
  };
  static const KeyMap none;
  if (scene == "particles") return particles;
  if (scene == "fixed_sphere") return fixed_sphere;
  return none;
}

std::string user_keys(const std::string& msg, const KeyMap& map) {
  auto ident = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
  std::string out;
  std::size_t i = 0;
  while (i < msg.size()) {
    // A dotted name starts where no name character precedes it.
    if (ident(msg[i]) && (i == 0 || (!ident(msg[i - 1]) && msg[i - 1] != '.'))) {
      std::size_t j = i;
      while (j < msg.size() && (ident(msg[j]) || (msg[j] == '.' && j + 1 < msg.size() && ident(msg[j + 1])))) ++j;
      const std::string word = msg.substr(i, j - i);
      auto it = std::find_if(map.begin(), map.end(), [&](const auto& kv) { return kv.first == word; });
      out += it != map.end() ? it->second : word;
      i = j;
    } else {
      out += msg[i++];
    }
  }
  return out;
}

}  // namespace lbdem::cases
