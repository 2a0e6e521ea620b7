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
  m.flags = Buffer<int>(be, 2);
  m.flags.fill_zero();
  if (!(p.lookahead_safety >= 1))
    throw ConfigError(fmtx("lookahead_safety: {} must be >= 1 (a factor on the predicted motion)", p.lookahead_safety));
  m.status = Buffer<StatusRecord>(be, Impl::kRing + 1);
  m.status.fill_zero();
  if (ex.on_device()) {
#if defined(LBDEM_HAVE_CUDA)
    LBDEM_CUDA_CHECK(cudaMallocHost(reinterpret_cast<void**>(&m.mirror), sizeof(StatusRecord) * Impl::kRing));
    for (auto& e : m.events) LBDEM_CUDA_CHECK(cudaEventCreateWithFlags(&e, cudaEventDisableTiming));
#endif
  } else {
    m.mirror_host.resize(Impl::kRing);
    m.mirror = m.mirror_host.data();
  }
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

DemSystem::~DemSystem() = default;

DemSystem::Impl::~Impl() {
#if defined(LBDEM_HAVE_CUDA)
  if (!mirror_host.empty() || !mirror) return;
  cudaFreeHost(mirror);
  for (auto& e : events)
    if (e) cudaEventDestroy(e);
#endif
}

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

// Sort by cell, reorder, build the Verlet list (carrying histories).
void rebuild_list(DemSystem::Impl& m) {
  const Index n = m.n;
  m.t_build = m.steps;
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
    // The one blocking read of a rebuild: a list that overflowed must be
    // rebuilt larger before any force uses it. The flags stay zero otherwise.
    int f[2];
    m.flags.copy_to_host(f, 2);
    if (!f[0]) break;
    if (attempt > 4) throw ResourceError("DEM: neighbour list kept overflowing");
    m.cap = ((static_cast<int>(f[1] * 1.25) + 7) / 8) * 8;
    m.flags.fill_zero();
  }
  m.have_prev = m.p.friction;
  ++m.rebuilds;
}

}  // namespace

// ------------------------------------------------------------ rebuild decisions
// The list built at state t_build holds every pair closer than r_i + r_j +
// skin there, so it holds every contact while no particle has moved more
// than skin/2 since. The host must therefore rebuild before the force
// evaluation of the first state where some displacement could exceed skin/2,
// and it must not wait for the device each step to learn the displacements.
//
// Reports. At chosen steps the drift kernel also reduces the largest
// displacement since the build d, speed v and acceleration a (KickDrift,
// StatusRecord) into a ring slot, which is copied to page-locked memory on
// the stream, an event after it. A report is read when due: the one at the
// end of an advance() call when the next call starts (the host then waits at
// most until the device has done the previous call's DEM steps: work queued
// after them, such as the coupled fluid step, keeps the device busy); inside
// a call, every k steps, each read k steps after it was taken (when it is
// read, the device has k steps of work queued).
//
// Decision. Before launching the step that produces state t, with the last
// report read at state t_k (m = t - t_k steps ago), the host bounds one
// particle's motion over those m steps by
//   M(m) = S dt (m v + dt a m (m + 1) / 2)
// (constant acceleration: sum over j = 1..m of dt (v + j dt a)), with the
// safety factor S = lookahead_safety (2: a collision at most doubles a
// particle's speed relative to the fastest one, light on heavy, elastic).
// It rebuilds at t when d + M(m) > skin/2, or, if the list was rebuilt at
// t_b >= t_k since, when M(m) - M(t_b - t_k) > skin/2. The real motion being
// about M(m) / S, a rebuild comes about (S - 1) m steps of the fastest motion
// earlier than the exact test would call it, m <= 2k - 1. So k follows from
// each report: n / 8 (clamped to 1..8), n the steps in which a particle at
// the bounded speed S (v + 8 dt a) crosses skin/2; then m < n / 4 and, with
// S = 2, rebuilds come at most ~1/8 of their interval early (measured: 1-5 %
// more rebuilds; 20 % when particles cross skin/2 in 6 steps, where k = 1).
//
// Safety net. Every step the drift kernel also compares each real
// displacement with skin/2 where the host decided not to rebuild; any excess
// is kept in the next report (over2), and reading it throws DivergenceError
// naming the step range, the displacement and the skin. So a contact is never
// missed silently: either the list was rebuilt in time, or the run stops.
//
// Determinism. Which steps report and when each report is read depend only on
// the state and the advance() call lengths, never on timing, so the two
// backends and repeated runs take the same decisions (the host backend reads
// the same reports at the same steps, without copies).
namespace {

constexpr int kMaxReportEvery = 8;

const StatusRecord& wait_report(DemSystem::Impl& m, int slot) {
  if (m.ex.on_device()) {
#if defined(LBDEM_HAVE_CUDA)
    const cudaError_t e = cudaEventQuery(m.events[slot]);
    if (e == cudaErrorNotReady) {
      ++m.status_waits;
      LBDEM_CUDA_CHECK(cudaEventSynchronize(m.events[slot]));
    } else {
      LBDEM_CUDA_CHECK(e);
    }
#endif
  }
  ++m.status_reads;
  return m.mirror[slot];
}

DemSystem::Impl::Pending pop_front(DemSystem::Impl& m) {
  const DemSystem::Impl::Pending p = m.pending[0];
  for (int k = 1; k < m.npending; ++k) m.pending[k - 1] = m.pending[k];
  --m.npending;
  return p;
}

std::string stale_message(const DemSystem::Impl& m, const DemSystem::Impl::Pending& p, std::uint32_t over2) {
  return fmtx("DEM neighbour list went stale between steps {} and {}: a particle moved {} m since the list was "
              "built, more than skin/2 = {} m (skin {} m), at a step where the rebuild look-ahead (largest "
              "speed and acceleration of the last report x lookahead_safety = {}) predicted it would not; "
              "contacts of those steps may have been missed. A force or collision changed a particle's "
              "speed faster than the bound: raise DemParams::lookahead_safety, or the skin (larger skin, "
              "more slack per rebuild), or lower dt (or the DEM sub-steps per advance() call); "
              "rebuild_check = every_step tests every step exactly at one blocking read per step. "
              "rebuild() clears this error.",
              p.from, p.t, std::sqrt(detail::from_float_bits(over2)), 0.5 * m.skin, m.skin,
              m.p.lookahead_safety);
}

// Reads the oldest pending report (Lookahead): the stale check, then the
// known state and the report interval it implies.
void read_front(DemSystem::Impl& m) {
  const DemSystem::Impl::Pending p = pop_front(m);
  const StatusRecord r = wait_report(m, p.slot);
  if (r.over2 != 0) {
    m.stale_error = stale_message(m, p, r.over2);
    throw DivergenceError(m.stale_error);
  }
  m.known = true;
  m.t_known = p.t;
  m.d_known = std::sqrt(detail::from_float_bits(r.disp2));
  m.v_known = std::sqrt(detail::from_float_bits(r.speed2));
  m.a_known = std::sqrt(detail::from_float_bits(r.accel2));
  // Steps for the fastest particle to cross skin/2 at the bounded speed.
  const double S = m.p.lookahead_safety, dt = m.p.dt;
  const double per_step = S * dt * (m.v_known + dt * m.a_known * kMaxReportEvery);
  const double cross = per_step > 0 ? 0.5 * m.skin / per_step : 1e30;
  m.report_every = static_cast<int>(std::clamp(cross / 8.0, 1.0, static_cast<double>(kMaxReportEvery)));
}

// Queues the copy of the report just reduced into its slot (device: async,
// page-locked target, event after it; host: the value is already final).
void take_report(DemSystem::Impl& m, long t, long due) {
  const int slot = static_cast<int>(m.reports % DemSystem::Impl::kRing);
  // The oldest pending report may still sit in this mirror slot (not with the
  // schedules above, which keep at most two pending): read it first.
  if (m.npending == DemSystem::Impl::kRing) read_front(m);
  if (m.ex.on_device()) {
#if defined(LBDEM_HAVE_CUDA)
    LBDEM_CUDA_CHECK(cudaMemcpyAsync(m.mirror + slot, m.status.data() + slot, sizeof(StatusRecord),
                                     cudaMemcpyDeviceToHost, m.ex.stream()));
    LBDEM_CUDA_CHECK(cudaEventRecord(m.events[slot], m.ex.stream()));
#endif
  } else {
    m.mirror[slot] = m.status.data()[slot];
  }
  m.pending[m.npending++] = DemSystem::Impl::Pending{m.t_last_report + 1, t, due, slot};
  m.t_last_report = t;
  ++m.reports;
}

StatusRecord* report_slot(DemSystem::Impl& m, long q) { return m.status.data() + q % DemSystem::Impl::kRing; }

// A synchronous report of the current state (first advance() call, or after
// a bench hook moved the particles).
void initial_report(DemSystem::Impl& m) {
  launch(m.ex, m.n, Report{m.state(), report_slot(m, m.reports), report_slot(m, m.reports + 1)});
  take_report(m, m.steps, m.steps);
  while (m.npending > 0) read_front(m);
}

// Bound on one particle's motion over the k steps after the known state [m].
double motion_bound(const DemSystem::Impl& m, long k) {
  const double kk = static_cast<double>(k), dt = m.p.dt;
  return m.p.lookahead_safety * dt * (kk * m.v_known + 0.5 * dt * m.a_known * kk * (kk + 1));
}

// Largest displacement since the build that state t could have.
double predicted_displacement(const DemSystem::Impl& m, long t) {
  if (m.t_build >= m.t_known) return motion_bound(m, t - m.t_known) - motion_bound(m, m.t_build - m.t_known);
  return m.d_known + motion_bound(m, t - m.t_known);
}

// Drops all reports and zeroes the ring (after a full synchronisation).
void reset_reports(DemSystem::Impl& m) {
  m.ex.synchronize();
  m.npending = 0;
  m.status.fill_zero();
  m.known = false;
  m.stale_error.clear();
}

}  // namespace

void check_arrived_reports(DemSystem::Impl& m) {
  if (m.p.rebuild_check != RebuildCheck::Lookahead || !m.stale_error.empty()) return;
  for (int k = 0; k < m.npending; ++k) {
    const std::uint32_t over2 = m.mirror[m.pending[k].slot].over2;
    if (over2 != 0) {
      m.stale_error = stale_message(m, m.pending[k], over2);
      throw DivergenceError(m.stale_error);
    }
  }
}

void DemSystem::rebuild() {
  Impl& m = *impl_;
  if (!m.stale_error.empty()) reset_reports(m);
  rebuild_list(m);
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
  if (!m.stale_error.empty()) throw DivergenceError(m.stale_error);
  if (m.n == 0) {
    m.time += steps * m.p.dt;
    return;
  }
  if (!m.forces_valid) compute_forces();
  const bool ahead = m.p.rebuild_check == RebuildCheck::Lookahead;
  if (ahead && !m.known) initial_report(m);
  const double dt = m.p.dt, half_skin = 0.5 * m.skin;
  const long t_end = m.steps + steps;
  // Closing half kick (velocities synchronised at the state reached).
  auto close = [&m] {
    const State st = m.state();
    if (m.p.friction) launch(m.ex, m.n, Kick<true>{st});
    else launch(m.ex, m.n, Kick<false>{st});
    m.forces_valid = true;
  };
  for (long s = 0; s < steps; ++s) {
    const long t = m.steps + 1;  // the state this step produces
    bool build = false;
    if (ahead) {
      try {
        while (m.npending > 0 && m.pending[0].due <= t) read_front(m);
      } catch (const DivergenceError&) {
        if (s > 0) close();  // leave a consistent state (stopped at step t - 1)
        throw;
      }
      build = predicted_displacement(m, t) > half_skin;
    }
    // Reports: every step (exact test), at the end of the call (read when the
    // next one starts), and every k steps when read within this call.
    const long k = m.report_every;
    const bool report = !ahead || t == t_end || (t - m.t_last_report >= k && t + k <= t_end);
    const State st = m.state();
    const int synced = s == 0, extrap = m.old_valid ? 1 : 0;
    StatusRecord *rec = report_slot(m, m.reports), *next = report_slot(m, m.reports + 1);
    const int rep = report ? 1 : 0, check = build ? 0 : 1;
    if (m.p.friction) launch(m.ex, m.n, KickDrift<true>{st, synced, extrap, rec, next, rep, check});
    else launch(m.ex, m.n, KickDrift<false>{st, synced, extrap, rec, next, rep, check});
    // The forces just used become the "old" ones of the velocity predictor.
    m.frc.swap(m.frco);
    if (m.p.friction) m.trq.swap(m.trqo);
    ++m.steps;
    m.time += dt;
    if (ahead) {
      if (report) take_report(m, t, t == t_end ? t + 1 : t + k);
    } else {
      // Exact test: this step's displacements, read now (one blocking read).
      take_report(m, t, t);
      const Impl::Pending p = pop_front(m);
      build = wait_report(m, p.slot).over2 != 0;
    }
    if (build) rebuild_list(m);
    run_forces(m);
    m.old_valid = true;
  }
  close();
}

void DemSystem::bench_integrate() {
  Impl& m = *impl_;
  const State st = m.state();
  // Displacement checks go to the sink slot; the moved particles call for a
  // fresh report before the next advance() decides anything.
  StatusRecord* sink = m.status.data() + Impl::kRing;
  if (m.p.friction) launch(m.ex, m.n, KickDrift<true>{st, 0, 1, sink, sink, 0, 1});
  else launch(m.ex, m.n, KickDrift<false>{st, 0, 1, sink, sink, 0, 1});
  m.known = false;
}
void DemSystem::bench_forces() { run_forces(*impl_); }
void DemSystem::bench_rebuild() { rebuild(); }
void DemSystem::synchronize() const {
  impl_->ex.synchronize();
  check_arrived_reports(*impl_);
}

double DemSystem::time() const { return impl_->time; }
Index DemSystem::size() const { return impl_->n; }
const DemParams& DemSystem::params() const { return impl_->p; }
Backend DemSystem::backend() const { return impl_->ex.backend(); }
double DemSystem::cell_size(int axis) const { return 1.0 / impl_->grid.inv_cl[axis]; }

}  // namespace lbdem::dem
