// DemSystem: storage, cell and Verlet lists, rebuild with reordering, the
// velocity-Verlet time loop.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>

#include <sstream>
#include <string>

#include "core/algorithms.hpp"
#include "core/error.hpp"
#include "system_impl.hpp"

namespace lbdem::dem {

namespace {

// "{}" placeholders filled in order (fmt's headers do not compile under nvcc
// in this toolchain, and this TU must).
void fmtx_rest(std::ostringstream& o, const char* f) { o << f; }
template <class A, class... R>
void fmtx_rest(std::ostringstream& o, const char* f, const A& a, const R&... r) {
  const char* p = std::strstr(f, "{}");
  if (!p) { o << f; return; }
  o.write(f, p - f);
  o << a;
  fmtx_rest(o, p + 2, r...);
}
template <class... A>
std::string fmtx(const char* f, const A&... a) {
  std::ostringstream o;
  o.precision(6);
  fmtx_rest(o, f, a...);
  return o.str();
}

Real4 r4(const Vec3d& v, double w) { return Real4{v.x, v.y, v.z, w}; }

struct CountAt {
  const int* c;
  LBDEM_HD int operator()(Index i) const { return c[i]; }
};

template <class T>
void upload(Buffer<T>& b, Backend be, const std::vector<T>& v, Index n) {
  b = Buffer<T>(be, n);
  if (n > 0) b.copy_from_host(v.data(), n);
}

void run_forces(DemSystem::Impl& m) {
  if (m.p.friction) run_forces_frictional(m);
  else run_forces_frictionless(m);
}

}  // namespace

DemSystem::DemSystem(Exec ex, DemParams params, const HostParticles& hp) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.ex = ex;
  m.scratch_ptr = std::make_unique<Scratch>();
  m.p = std::move(params);
  DemParams& p = m.p;
  const Backend be = ex.backend();
  m.n = hp.size();
  if (m.n >= (Index{1} << 30)) throw ResourceError(fmtx(("DEM: {} particles exceed the 2^30 limit of 32-bit list indices"), m.n));
  if (hp.r.size() != static_cast<std::size_t>(m.n) || hp.mass.size() != static_cast<std::size_t>(m.n))
    throw ConfigError("DEM: particle arrays of different lengths");

  // Box and walls.
  for (int k = 0; k < 3; ++k) {
    if (!(p.hi[k] > p.lo[k]))
      throw ConfigError(fmtx(("domain: hi[{}] = {} must exceed lo[{}] = {}"), k, p.hi[k], k, p.lo[k]));
    m.box.lo[k] = p.lo[k];
    m.box.len[k] = p.hi[k] - p.lo[k];
    m.box.periodic[k] = p.periodic[k] ? 1 : 0;
  }
  if (static_cast<int>(p.walls.size()) > kMaxWalls)
    throw ConfigError(fmtx(("walls: {} walls given, at most {} supported"), p.walls.size(), kMaxWalls));
  for (std::size_t k = 0; k < p.walls.size(); ++k) {
    Wall w = p.walls[k];
    const double len = norm(w.normal);
    if (!(len > 0)) throw ConfigError(fmtx(("walls[{}].normal: must be a non-zero vector"), k));
    w.normal = w.normal * (1.0 / len);
    m.walls.w[k] = w;
  }
  m.walls.count = static_cast<int>(p.walls.size());

  const Material& mat = p.material;
  auto check_e = [](double e, const char* key) {
    if (!(e > 0 && e <= 1)) throw ConfigError(fmtx(("material.{}: {} must be in (0, 1]"), key, e));
  };
  check_e(mat.restitution, "restitution");
  check_e(mat.wall_restitution, "wall_restitution");
  if (p.friction && !(mat.tangential_stiffness_ratio > 0))
    throw ConfigError("material.tangential_stiffness_ratio must be > 0 with friction");
  m.pp = make_contact_law(mat.stiffness, mat.restitution, mat.tangential_stiffness_ratio, mat.tangential_damping_ratio,
                          mat.friction);
  m.pw = make_contact_law(mat.wall_stiffness, mat.wall_restitution, mat.tangential_stiffness_ratio,
                          mat.tangential_damping_ratio, mat.wall_friction);
  check_time_step(p, hp);

  // Neighbour search geometry.
  double rmax = 0, rmin = 1e300;
  for (double r : hp.r) {
    if (!(r > 0)) throw ConfigError(fmtx(("particles: radius {} must be > 0"), r));
    rmax = std::max(rmax, r);
    rmin = std::min(rmin, r);
  }
  if (m.n == 0) rmax = rmin = 1;
  m.skin = p.skin > 0 ? p.skin : 0.2 * rmin;
  const double rc = 2 * rmax + m.skin;
  long long total = 1;
  for (int k = 0; k < 3; ++k) {
    if (p.periodic[k] && m.box.len[k] < 2 * rc)
      throw ConfigError(fmtx(("domain: periodic length {} along axis {} is below twice the largest cutoff "
                                    "2*(2 r_max + skin) = {}: enlarge the box or lower the skin"),
                                    m.box.len[k], k, 2 * rc));
    m.grid.nc[k] = std::max(1, static_cast<int>(std::min(1e9, std::floor(m.box.len[k] / rc))));
  }
  // Bound the cell count (a huge non-periodic box with few particles).
  const long long max_cells = std::max<long long>(1 << 20, 2 * static_cast<long long>(m.n));
  for (;;) {
    total = 1LL * m.grid.nc[0] * m.grid.nc[1] * m.grid.nc[2];
    if (total <= max_cells) break;
    int k = static_cast<int>(std::max_element(m.grid.nc, m.grid.nc + 3) - m.grid.nc);
    m.grid.nc[k] = std::max(1, m.grid.nc[k] / 2);
  }
  for (int k = 0; k < 3; ++k) {
    m.grid.lo[k] = m.box.lo[k];
    m.grid.inv_cl[k] = m.grid.nc[k] / m.box.len[k];
    m.grid.periodic[k] = m.box.periodic[k];
  }

  // Particle arrays.
  const Index n = m.n;
  std::vector<Real4> pos(n), vel(n), omg(n), zero(n, Real4{0, 0, 0, 0});
  for (Index i = 0; i < n; ++i) {
    Vec3d x = m.box.wrap(hp.x[i]);
    pos[i] = r4(x, hp.r[i]);
    if (!(hp.mass[i] > 0)) throw ConfigError(fmtx(("particles: mass {} of particle {} must be > 0"), hp.mass[i], i));
    vel[i] = r4(hp.v[i], 1.0 / hp.mass[i]);
    omg[i] = r4(hp.w.empty() ? Vec3d{} : hp.w[i], 1.0 / sphere_inertia(hp.mass[i], hp.r[i]));
  }
  {
    std::vector<std::int64_t> ids(hp.id.begin(), hp.id.end());
    std::sort(ids.begin(), ids.end());
    if (static_cast<Index>(ids.size()) != n || std::adjacent_find(ids.begin(), ids.end()) != ids.end())
      throw ConfigError("particles: global ids are missing or not unique");
  }
  upload(m.pos, be, pos, n);
  upload(m.vel, be, vel, n);
  upload(m.omg, be, omg, n);
  upload(m.frc, be, zero, n);
  upload(m.trq, be, zero, n);
  upload(m.x0, be, pos, n);
  upload(m.gid, be, hp.id, n);
  std::vector<int> types = hp.type;
  types.resize(n, 0);
  upload(m.type, be, types, n);
  m.pos2 = Buffer<Real4>(be, n);
  m.vel2 = Buffer<Real4>(be, n);
  m.omg2 = Buffer<Real4>(be, n);
  m.frc2 = Buffer<Real4>(be, n);
  m.trq2 = Buffer<Real4>(be, n);
  upload(m.frco, be, zero, n);
  upload(m.trqo, be, zero, n);
  upload(m.vpr, be, vel, n);
  m.vpr2 = Buffer<Real4>(be, n);
  if (p.friction) {
    upload(m.wpr, be, omg, n);
    m.wpr2 = Buffer<Real4>(be, n);
  }
  m.frco2 = Buffer<Real4>(be, n);
  m.trqo2 = Buffer<Real4>(be, n);
  m.gid2 = Buffer<std::int64_t>(be, n);
  m.type2 = Buffer<int>(be, n);
  if (p.external_forcing) {
    upload(m.extf, be, zero, n);
    upload(m.extt, be, zero, n);
    m.extf2 = Buffer<Real4>(be, n);
    m.extt2 = Buffer<Real4>(be, n);
  }
  if (p.friction && m.walls.count > 0) {
    const Index nw = n * m.walls.count;
    m.whist = Buffer<Vec3d>(be, nw);
    m.whist.fill_zero();
    m.whist2 = Buffer<Vec3d>(be, nw);
  }
  m.key = Buffer<std::uint32_t>(be, n);
  m.key_sorted = Buffer<std::uint32_t>(be, n);
  m.idx = Buffer<int>(be, n);
  m.perm = Buffer<int>(be, n);
  m.cell_start = Buffer<int>(be, total);
  m.cell_end = Buffer<int>(be, total);
  m.cell_start.fill_zero();
  m.cell_end.fill_zero();
  m.ncount = Buffer<int>(be, n);
  if (p.friction) m.ncount_prev = Buffer<int>(be, n);
  m.ccount = Buffer<int>(be, n + 1);
  m.ccount.fill_zero();
  m.coffs = Buffer<int>(be, n + 1);
  m.flags = Buffer<int>(be, 4);
  m.flags.fill_zero();
  m.cap = p.neighbour_capacity > 0 ? p.neighbour_capacity : 32;
  rebuild();
  if (p.neighbour_capacity == 0 && n > 0) {
    // Fit the capacity to what the first build needed (x1.5 + 8 headroom,
    // grown again on overflow): list and history memory scale with it.
    const int* cnt = m.ncount.data();
    const int mx = transform_reduce(m.ex, n, 0, MaxOp{}, CountAt{cnt}, m.scratch());
    const int fit = ((mx * 3 / 2 + 8 + 7) / 8) * 8;
    if (fit < m.cap) {
      m.cap = fit;
      if (p.friction) {
        // Drop the stale previous list: the next rebuild starts afresh.
        m.have_prev = false;
      }
      m.nbr = Buffer<int>();
      m.hist = Buffer<Vec3d>();
      m.pairs = Buffer<PairIJ>();
      m.nbr_prev = Buffer<int>();
      m.hist_prev = Buffer<Vec3d>();
      rebuild();
    }
  }
  m.rebuilds = 0;  // the initial build is not counted
}

DemSystem::~DemSystem() {
#if defined(LBDEM_HAVE_CUDA)
  if (impl_ && impl_->flags_pinned) cudaFreeHost(impl_->flags_pinned);
#endif
}

namespace {
// The rebuild flag: a 4-byte device-to-host read into page-locked memory on
// the Exec's stream (the one host round trip per step).
int read_rebuild_flag(DemSystem::Impl& m) {
  if (!m.ex.on_device()) return m.flags.data()[0];
#if defined(LBDEM_HAVE_CUDA)
  if (!m.flags_pinned) LBDEM_CUDA_CHECK(cudaMallocHost(reinterpret_cast<void**>(&m.flags_pinned), sizeof(int)));
  LBDEM_CUDA_CHECK(cudaMemcpyAsync(m.flags_pinned, m.flags.data(), sizeof(int), cudaMemcpyDeviceToHost, m.ex.stream()));
  LBDEM_CUDA_CHECK(cudaStreamSynchronize(m.ex.stream()));
  return *m.flags_pinned;
#else
  return 0;
#endif
}
}  // namespace

namespace {

void allocate_lists(DemSystem::Impl& m) {
  const Backend be = m.ex.backend();
  const Index slots = m.n * m.cap;
  m.nbr.reserve_discard(be, slots);
  if (m.p.friction) m.hist.reserve_discard(be, slots);
  if (m.p.path == ForcePath::Pair) m.pairs.reserve_discard(be, slots / 2 + 1);
}

template <bool Friction>
void build_list(DemSystem::Impl& m) {
  BuildList<Friction> b{m.state(), m.grid, m.cell_start.data(), m.cell_end.data(), m.perm.data(),
                        m.nbr_prev.data(), m.ncount_prev.data(), m.hist_prev.data(), m.gid2.data(),
                        m.have_prev ? 1 : 0, m.p.path == ForcePath::Particle ? 1 : 0};
  launch(m.ex, m.n, b);
}

}  // namespace

void DemSystem::rebuild() {
  Impl& m = *impl_;
  const Index n = m.n;
  if (n == 0) return;
  // 1. Cell of every particle, then sort by cell.
  launch(m.ex, n, CellKey{m.pos.data(), m.grid, m.key.data(), m.idx.data()});
  const bool host = !m.ex.on_device();
  if (host) {
    // Host: a stable counting sort by cell (O(N + cells)), which yields the
    // cell ranges as a by-product; far cheaper than a comparison sort.
    const std::uint32_t* key = m.key.data();
    std::uint32_t* ks = m.key_sorted.data();
    int *start = m.cell_start.data(), *end = m.cell_end.data(), *perm = m.perm.data();
    const Index ncells = m.cell_start.size();
    std::fill(end, end + ncells, 0);
    for (Index i = 0; i < n; ++i) ++end[key[i]];
    int run = 0;
    for (Index c = 0; c < ncells; ++c) {
      const int cnt = end[c];
      start[c] = run;
      end[c] = run;  // fill cursor; ends at start + count
      run += cnt;
    }
    for (Index i = 0; i < n; ++i) {
      const int at = end[key[i]]++;
      perm[at] = static_cast<int>(i);
      ks[at] = key[i];
    }
  } else {
    // Device: empty the cells of the previous build (its sorted keys are
    // still there: O(N), not O(cells)), then a CUB radix sort over only the
    // bits a cell index can use.
    if (m.have_cells) launch(m.ex, n, ClearCells{m.key_sorted.data(), m.cell_start.data(), m.cell_end.data()});
    m.have_cells = true;
    int bits = 1;
    while (bits < 32 && (Index{1} << bits) < m.cell_start.size()) ++bits;
    sort_pairs(m.ex, m.key.data(), m.key_sorted.data(), m.idx.data(), m.perm.data(), n, m.scratch(), 0, bits);
  }
  // 2. Reorder all particle arrays into cell order (locality for the force loop).
  Gather g{m.perm.data(),  m.pos.data(),   m.vel.data(),   m.omg.data(),  m.frc.data(),   m.trq.data(),
           m.frco.data(),  m.trqo.data(),  m.vpr.data(),   m.wpr.data(),  m.extf.data(),  m.extt.data(),
           m.pos2.data(),  m.vel2.data(),  m.omg2.data(),  m.frc2.data(), m.trq2.data(),  m.frco2.data(),
           m.trqo2.data(), m.vpr2.data(),  m.wpr2.data(),  m.extf2.data(), m.extt2.data(), m.gid.data(),
           m.gid2.data(),  m.type.data(),  m.type2.data(), m.whist.data(), m.whist2.data(), m.walls.count, n};
  launch(m.ex, n, g);
  m.pos.swap(m.pos2); m.vel.swap(m.vel2); m.omg.swap(m.omg2); m.frc.swap(m.frc2); m.trq.swap(m.trq2);
  m.frco.swap(m.frco2); m.trqo.swap(m.trqo2); m.vpr.swap(m.vpr2); m.wpr.swap(m.wpr2);
  m.extf.swap(m.extf2); m.extt.swap(m.extt2); m.gid.swap(m.gid2); m.type.swap(m.type2);
  m.whist.swap(m.whist2);
  // gid2 now holds the old order's ids (history lookup by partner id).
  // 3. Cell ranges.
  if (!host) launch(m.ex, n, CellRange{m.key_sorted.data(), m.cell_start.data(), m.cell_end.data(), n});
  // 4. Verlet list (keeping the previous one for the history hand-over).
  if (m.p.friction) {
    m.nbr.swap(m.nbr_prev);
    m.ncount.swap(m.ncount_prev);
    m.hist.swap(m.hist_prev);
  }
  for (int attempt = 0;; ++attempt) {
    allocate_lists(m);
    if (m.p.friction) build_list<true>(m);
    else build_list<false>(m);
    int f[4];
    m.flags.copy_to_host(f, 4);  // the one small read of a rebuild
    if (!f[1]) break;
    if (attempt > 4) throw ResourceError("DEM: neighbour list kept overflowing");
    m.cap = ((static_cast<int>(f[2] * 1.25) + 7) / 8) * 8;
    m.flags.fill_zero();
  }
  m.have_prev = m.p.friction;
  m.flags.fill_zero();
  ++m.rebuilds;
}

void DemSystem::compute_forces() {
  Impl& m = *impl_;
  if (m.n == 0) return;
  const State st = m.state();
  if (m.p.friction) launch(m.ex, m.n, SyncPredictor<true>{st});
  else launch(m.ex, m.n, SyncPredictor<false>{st});
  run_forces(m);
  m.forces_valid = true;
  m.old_valid = false;
}

void DemSystem::advance(long steps) {
  Impl& m = *impl_;
  if (steps <= 0) return;
  if (m.n == 0) {
    m.time += steps * m.p.dt;
    return;
  }
  if (!m.forces_valid) compute_forces();
  const double dt = m.p.dt;
  for (long s = 0; s < steps; ++s) {
    const State st = m.state();
    const int synced = s == 0, extrap = m.old_valid ? 1 : 0;
    if (m.p.friction) launch(m.ex, m.n, KickDrift<true>{st, synced, extrap});
    else launch(m.ex, m.n, KickDrift<false>{st, synced, extrap});
    // The forces just used become the "old" ones of the velocity predictor.
    m.frc.swap(m.frco);
    if (m.p.friction) m.trq.swap(m.trqo);
    if (read_rebuild_flag(m)) rebuild();  // the one small read per step
    run_forces(m);
    m.old_valid = true;
    m.time += dt;
    ++m.steps;
  }
  const State st = m.state();
  if (m.p.friction) launch(m.ex, m.n, Kick<true>{st});
  else launch(m.ex, m.n, Kick<false>{st});
  m.forces_valid = true;
}

void DemSystem::bench_integrate() {
  Impl& m = *impl_;
  const State st = m.state();
  if (m.p.friction) launch(m.ex, m.n, KickDrift<true>{st, 0, 1});
  else launch(m.ex, m.n, KickDrift<false>{st, 0, 1});
}
void DemSystem::bench_forces() { run_forces(*impl_); }
void DemSystem::bench_rebuild() { rebuild(); }
void DemSystem::synchronize() const { impl_->ex.synchronize(); }

double DemSystem::time() const { return impl_->time; }
Index DemSystem::size() const { return impl_->n; }
const DemParams& DemSystem::params() const { return impl_->p; }
Backend DemSystem::backend() const { return impl_->ex.backend(); }
double DemSystem::cell_size(int axis) const { return 1.0 / impl_->grid.inv_cl[axis]; }

}  // namespace lbdem::dem
