// Particle → cell slot mapping and batch fraction evaluation (imb/cell_slots.hpp).
// One kernel body per method and dimension, run as a CUDA kernel or an OpenMP
// loop by core's for_each. The lookup table lives in __constant__ memory of this
// translation unit (constant symbols are per TU without relocatable device code).
#include "imb/cell_slots.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "core/algorithms.hpp"
#include "core/error.hpp"
#include "imb/fraction_eval.hpp"
#include "map_functors.hpp"

namespace lbdem::imb {

namespace {

#if defined(__CUDACC__)
__constant__ float c_fraction_table[kTableCapacity];
// Which table the constant bank holds (per process; device constant memory is
// itself global state, so the cache key is too). 0: none.
std::uint64_t g_uploaded_table = 0;
#endif

// Reads the table on the device from constant memory (global == nullptr; the
// first paper's choice) or from a global-memory copy through the read-only
// cache (__ldg); on the host from the host copy.
struct ConstTableAccess {
  const float* host = nullptr;
  const float* global = nullptr;
  LBDEM_HD void pair(int i, float& e0, float& e1) const {
#if defined(__CUDA_ARCH__)
    if (global) {
      PointerTableAccess{global}.pair(i, e0, e1);
    } else {
      e0 = c_fraction_table[2 * i];
      e1 = c_fraction_table[2 * i + 1];
    }
#else
    e0 = host[2 * i];
    e1 = host[2 * i + 1];
#endif
  }
};

void upload_table(const Exec& ex, const FractionTable& t) {
#if defined(__CUDACC__)
  if (ex.on_device() && g_uploaded_table != t.id) {
    LBDEM_CUDA_CHECK(cudaMemcpyToSymbolAsync(c_fraction_table, t.values.data(), t.values.size() * sizeof(float), 0,
                                             cudaMemcpyHostToDevice, ex.stream()));
    g_uploaded_table = t.id;
  }
#else
  (void)ex;
  (void)t;
#endif
}

LBDEM_HD inline int atomic_inc(int* p) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(p, 1);
#else
  return __atomic_fetch_add(p, 1, __ATOMIC_RELAXED);
#endif
}

LBDEM_HD inline Index wrap(Index i, Index n) {
  i %= n;
  return i < 0 ? i + n : i;
}

// ε of one cell for one method (imb/fraction_eval.hpp), table read from
// constant memory, a global copy or the host copy.
template <int Dim, FractionMethod M>
using Fraction = FractionOf<Dim, M, ConstTableAccess>;

template <int Dim, FractionMethod M>
struct MapKernel {
  SphereView p;
  CellSlotsView s;
  Fraction<Dim, M> frac;
  Index nx, ny, nz;         // storage cells per axis
  bool per_x, per_y, per_z;  // axes that wrap onto themselves in storage
  double sx, sy, sz;         // global lattice frame -> storage coordinates: subtract (GridView::shift)
  GridView img;              // nearest_image on cut periodic axes
  int B;             // box edge in cells
  Index box;         // B^Dim
  int* flags;        // [0] surplus events, [1] radius errors, [2] offending particle, [3] deferred count
  Index* log_cell;
  int* log_particle;
  int log_cap;
  // Exact method: interface cells are queued and done by a second, dense pass
  // (DeferredExact) so that whole warps run the quadrature together instead of
  // a few lanes per warp; when the queue is full a thread does its cell itself.
  Index* queue = nullptr;
  Index queue_cap = 0;
  // Per box thread t: the cell of its (particle, cell) pair if the pair took a
  // slot, else -1. (The cell, not the slot: the slot sort reorders slots.) Every
  // map writes every entry; the force gather reads a particle's entries
  // contiguously (imb/psm.hpp).
  int* pair = nullptr;

  // Maps the box coordinate l of axis (lo cell index i0, n cells, periodic?) to
  // a grid index, or -1 when off a non-periodic grid.
  LBDEM_HD static Index axis(Index g, Index n, bool periodic) {
    if (periodic) return wrap(g, n);
    return (g < 0 || g >= n) ? -1 : g;
  }

  struct Target {
    Index pi, cell;
    double rx, ry, rz, R;
  };
  // Decodes box thread t into its particle and cell; false if off the particle's box or grid.
  LBDEM_HD bool decode(Index t, Target& o, bool check_radius) const {
    // 32-bit division where it fits (64-bit integer division is a long
    // software sequence on the GPU; this decode runs for every box cell).
    const Index pi = t <= static_cast<Index>(UINT32_MAX)
                         ? static_cast<Index>(static_cast<std::uint32_t>(t) / static_cast<std::uint32_t>(box))
                         : t / box;
    const std::uint32_t l32 = static_cast<std::uint32_t>(t - pi * box), B32 = static_cast<std::uint32_t>(B);
    const Index po = static_cast<Index>(pi) * p.stride;
    const double R = p.r[po];
    // Global position (the image nearest this piece on a cut periodic axis),
    // then storage coordinates for the box; the offsets to cell centres are
    // taken in the global frame, (storage index + shift) + 1/2 - x, so that
    // every piece of a cut grid computes the whole grid's bits.
    const double xg = img.nearest_image(0, p.x[po]), yg = img.nearest_image(1, p.y[po]);
    const double zg = Dim == 3 ? img.nearest_image(2, p.z[po]) : 0.5;
    const double cx = xg - sx, cy = yg - sy, cz = Dim == 3 ? zg - sz : 0.5;
    const Index i0 = static_cast<Index>(floor(cx - R)), j0 = static_cast<Index>(floor(cy - R));
    const Index k0 = Dim == 3 ? static_cast<Index>(floor(cz - R)) : 0;
    if (check_radius && l32 == 0) {  // one thread per particle checks that its box fits
      const Index need = static_cast<Index>(floor(2.0 * R)) + 2;
      if (need > B) {
        atomic_inc(&flags[1]);
        flags[2] = static_cast<int>(pi);
      }
    }
    const std::uint32_t lq = l32 / B32;
    const Index li = static_cast<Index>(l32 - lq * B32);
    const Index lj = static_cast<Index>(lq % B32);
    const Index lk = Dim == 3 ? static_cast<Index>(lq / B32) : 0;
    const Index gi = i0 + li, gj = j0 + lj, gk = k0 + lk;
    // Cells of the box beyond the particle's own bounding box.
    if (gi > static_cast<Index>(floor(cx + R)) || gj > static_cast<Index>(floor(cy + R))) return false;
    if (Dim == 3 && gk > static_cast<Index>(floor(cz + R))) return false;
    const Index ci = axis(gi, nx, per_x), cj = axis(gj, ny, per_y);
    const Index ck = Dim == 3 ? axis(gk, nz, per_z) : 0;
    if (ci < 0 || cj < 0 || ck < 0) return false;
    o = {pi, ci + nx * (cj + ny * ck), (static_cast<double>(gi) + sx) + 0.5 - xg,
         (static_cast<double>(gj) + sy) + 0.5 - yg, Dim == 3 ? (static_cast<double>(gk) + sz) + 0.5 - zg : gk + 0.5 - cz, R};
    return true;
  }

  LBDEM_HD void insert(Index t, const Target& c, double eps) const {
    const Index pi = c.pi, cell = c.cell;
    const int slot = atomic_inc(&s.count[cell]);
    if (slot < s.K) {
      s.particle_at(cell, slot) = static_cast<int>(pi);
      s.eps_at(cell, slot) = eps;
      // Solid velocity at the cell centre: v + w x r, r = (c.rx, c.ry, c.rz)
      // the unwrapped offset of the cell centre from the particle centre.
      const Index o = pi * p.stride;
      const double w[3] = {p.wx ? p.wx[o] : 0.0, p.wy ? p.wy[o] : 0.0, p.wz ? p.wz[o] : 0.0};
      const double rz = Dim == 3 ? c.rz : 0.0;
      s.vel_at(0, cell, slot) = static_cast<float>((p.vx ? p.vx[o] : 0.0) + w[1] * rz - w[2] * c.ry);
      s.vel_at(1, cell, slot) = static_cast<float>((p.vy ? p.vy[o] : 0.0) + w[2] * c.rx - w[0] * rz);
      s.vel_at(2, cell, slot) = Dim == 3 ? static_cast<float>((p.vz ? p.vz[o] : 0.0) + w[0] * c.ry - w[1] * c.rx) : 0.0f;
      pair[t] = static_cast<int>(cell);  // < 2^31: checked by the constructor
    } else {
      pair[t] = -1;
      const int e = atomic_inc(&flags[0]);
      if (e < log_cap) {
        log_cell[e] = cell;
        log_particle[e] = static_cast<int>(pi);
      }
    }
  }

  // Every box thread writes its pair entry exactly once (insert() or -1; a
  // queued exact cell writes -1 and DeferredExact overwrites it on insert).
  LBDEM_HD void operator()(Index t) const {
    Target c{};
    if (!decode(t, c, true)) {
      pair[t] = -1;
      return;
    }
    if (M == FractionMethod::Exact && queue_cap > 0) {
      const double R2 = c.R * c.R;
      const double n2 = Dim == 3 ? cell_near2(c.rx, c.ry, c.rz) : cell_near2(c.rx, c.ry, 0.0);
      if (n2 >= R2) {
        pair[t] = -1;
        return;
      }
      const double f2 = Dim == 3 ? cell_far2(c.rx, c.ry, c.rz)
                                 : (fabs(c.rx) + 0.5) * (fabs(c.rx) + 0.5) + (fabs(c.ry) + 0.5) * (fabs(c.ry) + 0.5);
      if (f2 <= R2) {
        insert(t, c, 1.0);
        return;
      }
      const int q = atomic_inc(&flags[3]);
      if (q < queue_cap) {
        pair[t] = -1;
        queue[q] = t;
        return;
      }
    }
    const double eps = frac(c.rx, c.ry, c.rz, c.R);
    if (!(eps > 0.0)) {
      pair[t] = -1;
      return;
    }
    insert(t, c, eps);
  }
};

// Second pass of the exact method: a fixed number of workers stride over the
// queue, whose length is read on the device (no host round trip).
template <int Dim, FractionMethod M>
struct DeferredExact {
  MapKernel<Dim, M> k;
  Index workers;
  LBDEM_HD void operator()(Index w) const {
    const Index n = k.flags[3] < k.queue_cap ? k.flags[3] : k.queue_cap;
    for (Index q = w; q < n; q += workers) {
      typename MapKernel<Dim, M>::Target c{};
      if (!k.decode(k.queue[q], c, false)) continue;
      const double eps = k.frac(c.rx, c.ry, c.rz, c.R);
      if (eps > 0.0) k.insert(k.queue[q], c, eps);
    }
  }
};

// Slot sort, deterministic and race-free, over the pair array (no cell list):
// exactly one pair per cell with two or more slots sorts that cell, the one
// whose particle is the cell's smallest index. MarkSorters finds it (reads
// only) and marks its pair entry as -(cell + 2); SortMarked sorts the marked
// cells (insertion sort, K small) and restores the entries. Two passes, so no
// thread reads a cell that another is reordering.
struct MarkSorters {
  CellSlotsView s;
  int* pair;
  Index box;
  LBDEM_HD void operator()(Index t) const {
    const int c = pair[t];
    if (c < 0) return;
    const int m = s.used(c);
    if (m < 2) return;
    int lo = s.particle_at(c, 0);
    for (int k = 1; k < m; ++k) lo = s.particle_at(c, k) < lo ? s.particle_at(c, k) : lo;
    if (static_cast<Index>(lo) == t / box) pair[t] = -(c + 2);
  }
};

struct SortMarked {
  CellSlotsView s;
  int* pair;
  LBDEM_HD void operator()(Index t) const {
    if (pair[t] > -2) return;
    const Index cell = -static_cast<Index>(pair[t]) - 2;
    pair[t] = static_cast<int>(cell);
    const int m = s.used(cell);
    for (int a = 1; a < m; ++a) {
      const int pa = s.particle_at(cell, a);
      const double ea = s.eps_at(cell, a);
      const float va[3] = {s.vel_at(0, cell, a), s.vel_at(1, cell, a), s.vel_at(2, cell, a)};
      int b = a - 1;
      while (b >= 0 && s.particle_at(cell, b) > pa) {
        s.particle_at(cell, b + 1) = s.particle_at(cell, b);
        s.eps_at(cell, b + 1) = s.eps_at(cell, b);
        for (int d = 0; d < 3; ++d) s.vel_at(d, cell, b + 1) = s.vel_at(d, cell, b);
        --b;
      }
      s.particle_at(cell, b + 1) = pa;
      s.eps_at(cell, b + 1) = ea;
      for (int d = 0; d < 3; ++d) s.vel_at(d, cell, b + 1) = va[d];
    }
  }
};

template <int Dim, FractionMethod M>
struct EvalKernel {
  Fraction<Dim, M> frac;
  const double* rel;
  const double* radius;
  double* out;
  LBDEM_HD void operator()(Index i) const {
    const double rz = Dim == 3 ? rel[Dim * i + 2] : 0.0;
    out[i] = frac(rel[Dim * i], rel[Dim * i + 1], rz, radius[i]);
  }
};

template <int Dim, FractionMethod M>
Fraction<Dim, M> make_fraction(const FractionTable* table, bool linear_normalised, const float* global_table) {
  Fraction<Dim, M> f{};
  f.linear_normalised = linear_normalised;
  if (table) {
    f.g = table->geometry;
    f.tab.host = table->values.data();
    f.tab.global = global_table;
  }
  return f;
}

// Runtime (dim, method) → template instance, in one place.
template <template <int, FractionMethod> class Body>
struct Dispatch {
  template <class... A>
  static void run(int dim, FractionMethod m, A&&... a) {
    if (dim == 3) {
      switch (m) {
        case FractionMethod::Exact: return Body<3, FractionMethod::Exact>::run(a...);
        case FractionMethod::Table: return Body<3, FractionMethod::Table>::run(a...);
        case FractionMethod::Linear: return Body<3, FractionMethod::Linear>::run(a...);
      }
    } else {
      switch (m) {
        case FractionMethod::Exact: return Body<2, FractionMethod::Exact>::run(a...);
        case FractionMethod::Table: return Body<2, FractionMethod::Table>::run(a...);
        case FractionMethod::Linear: return Body<2, FractionMethod::Linear>::run(a...);
      }
    }
  }
};

void check_table(const FractionTable* table, int dim, const char* where) {
  if (!table)
    throw ConfigError(std::string(where) + ": solid-fraction method 'table' needs a table (build_fraction_table)");
  if (table->geometry.dim != dim)
    throw ConfigError(std::string(where) + ": the fraction table is " + std::to_string(table->geometry.dim) +
                      "D but the grid is " + std::to_string(dim) + "D");
}

// Clears the counts of the cells the previous map's pairs name (every cell
// with a non-zero count has at least one; several pairs may clear one cell).
struct ClearPaired {
  int* count;
  const int* pair;
  LBDEM_HD void operator()(Index t) const {
    const int c = pair[t];
    if (c < 0) return;
#if defined(__CUDA_ARCH__)
    count[c] = 0;
#else
    __atomic_store_n(&count[c], 0, __ATOMIC_RELAXED);  // the same value from several threads
#endif
  }
};

using mapk::ZeroInts;

template <int Dim, FractionMethod M>
struct LaunchMap {
  static void run(const Exec& ex, const SphereView& p, const CellSlotsView& s, const GridView& g, const MapOptions& o,
                  int B, int* flags, Index* log_cell, int* log_particle, int log_cap, const float* global_table,
                  Index* queue, Index queue_cap, int* pair) {
    MapKernel<Dim, M> k{};
    k.pair = pair;
    k.p = p;
    k.s = s;
    k.frac = make_fraction<Dim, M>(o.table, o.linear_normalised, global_table);
    k.nx = g.nx;
    k.ny = g.ny;
    k.nz = g.nz;
    k.per_x = g.periodic[0];
    k.per_y = g.periodic[1];
    k.per_z = g.periodic[2];
    k.img = g;
    k.sx = g.shift[0];
    k.sy = g.shift[1];
    k.sz = g.shift[2];
    k.B = B;
    k.box = Dim == 3 ? static_cast<Index>(B) * B * B : static_cast<Index>(B) * B;
    k.flags = flags;
    k.log_cell = log_cell;
    k.log_particle = log_particle;
    k.log_cap = log_cap;
    if (M == FractionMethod::Exact) {
      k.queue = queue;
      k.queue_cap = queue_cap;
    }
    for_each(ex, p.n * k.box, k);
    if (M == FractionMethod::Exact && queue_cap > 0) {
      const Index workers = ex.on_device() ? (Index{1} << 18) : Index{4096};
      for_each(ex, workers, DeferredExact<Dim, M>{k, workers});
    }
  }
};

template <int Dim, FractionMethod M>
struct LaunchEval {
  static void run(const Exec& ex, const FractionTable* table, const double* rel, const double* radius, double* out,
                  Index n, const float* global_table) {
    EvalKernel<Dim, M> k{make_fraction<Dim, M>(table, true, global_table), rel, radius, out};
    for_each(ex, n, k);
  }
};

}  // namespace

CellSlots::CellSlots(Backend b, const Grid& grid, int K, int overflow_log)
    : backend_(b), grid_(grid), K_(K), log_cap_(overflow_log), scratch_(std::make_shared<Scratch>()) {
  try {
    grid_.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(std::string("CellSlots: ") + e.what());
  }
  gv_ = grid_.view();
  if (K_ < 1 || K_ > 64) throw ConfigError("CellSlots: K (slots per cell) = " + std::to_string(K_) + " must be in 1..64");
  if (log_cap_ < 1) log_cap_ = 1;
  const Index n = gv_.n;
  count_ = Buffer<int>(b, n);
  particle_ = Buffer<int>(b, n * K_);
  eps_ = Buffer<double>(b, n * K_);
  vel_ = Buffer<float>(b, 3 * n * K_);
  flags_ = Buffer<int>(b, 4);
  if (n > static_cast<Index>(INT32_MAX))
    throw ConfigError("CellSlots: " + std::to_string(n) + " cells exceed the int32 pair entries (2^31 cells per rank)");
  log_cell_ = Buffer<Index>(b, log_cap_);
  log_particle_ = Buffer<int>(b, log_cap_);
  count_.fill_zero();
  flags_.fill_zero();
  // Slots past a cell's count are never read by a kernel, but the host copies
  // (particles_host, eps_host, total_eps_host) take whole buffers: defined
  // contents from the start.
  particle_.fill_zero();
  eps_.fill_zero();
  vel_.fill_zero();
}

void CellSlots::map(const Exec& ex, const SphereView& particles, const MapOptions& opt) {
  if (ex.backend() != backend_)
    throw ConfigError(std::string("CellSlots::map: slots live on ") + to_string(backend_) + " but the Exec runs on " +
                      to_string(ex.backend()));
  const int dim = grid_.dim();
  const float* global_table = nullptr;
  if (opt.method == FractionMethod::Table) {
    check_table(opt.table, dim, "CellSlots::map");
    if (opt.table_in_constant || !ex.on_device()) {
      upload_table(ex, *opt.table);
    } else {
      if (global_table_id_ != opt.table->id) {  // copied once per table, not per step
        global_table_.reserve_discard(backend_, static_cast<Index>(opt.table->values.size()));
        global_table_.copy_from_host(opt.table->values);
        global_table_id_ = opt.table->id;
      }
      global_table = global_table_.data();
    }
  }
  if (particles.n > 0 && (!particles.x || !particles.y || !particles.r || (dim == 3 && !particles.z)))
    throw ConfigError("CellSlots::map: particle view has null position or radius arrays");
  if (particles.n > static_cast<Index>(INT32_MAX))
    throw ConfigError("CellSlots::map: " + std::to_string(particles.n) + " particles exceed the int32 slot index");
  double rmax = opt.max_radius;
  if (!(rmax > 0.0) && particles.n > 0) {
    rmax = mapk::largest_radius(ex, particles, *scratch_);
  }
  max_radius_ = std::max(rmax, 0.0);
  const int B = static_cast<int>(std::floor(2.0 * std::max(rmax, 0.0))) + 2;
  const Index ns[3] = {gv_.nx, gv_.ny, gv_.nz};
  for (int a = 0; a < dim; ++a)
    if (gv_.periodic[a] && B > ns[a])
      throw ConfigError("CellSlots::map: particle radius " + std::to_string(rmax) + " spans " + std::to_string(B) +
                        " cells, more than the " + std::to_string(ns[a]) + " cells of periodic axis " +
                        std::string(1, "xyz"[a]) + " (a particle would meet its own image)");
  // Cleared on the Exec's stream (a kernel, not cudaMemset on the legacy
  // stream), in order with the fill: only the cells the previous map's pairs
  // name (about a fifth of the grid in a dense suspension), the whole grid the
  // first time.
  if (paired_ > 0) for_each(ex, paired_, ClearPaired{count_.data(), pair_.data()});
  else for_each(ex, gv_.n, ZeroInts{count_.data()});
  paired_ = 0;
  // [0..2] are overflow counters (kept across maps on request); [3] is this
  // map's deferred-queue length and always starts from zero.
  if (!opt.keep_overflow) for_each(ex, flags_.size(), ZeroInts{flags_.data()});
  else for_each(ex, 1, ZeroInts{flags_.data() + 3});
  particles_mapped_ = particles.n;
  pair_box_ = dim == 3 ? static_cast<Index>(B) * B * B : static_cast<Index>(B) * B;
  pair_B_ = B;
  if (particles.n == 0) return;
  pair_.reserve_discard(backend_, particles.n * pair_box_);  // grows only: no allocation in a steady time loop
  Index queue_cap = 0;
  if (opt.method == FractionMethod::Exact && opt.defer_exact) {
    // Interface cells per particle ≤ cells within √dim of the sphere surface.
    const double ro = rmax + std::sqrt(static_cast<double>(dim)), ri = std::max(rmax - std::sqrt(double(dim)), 0.0);
    const double shell = dim == 3 ? 4.0 / 3.0 * M_PI * (ro * ro * ro - ri * ri * ri) : M_PI * (ro * ro - ri * ri);
    queue_cap = particles.n * static_cast<Index>(std::ceil(shell));
    queue_.reserve_discard(backend_, queue_cap);  // grows only: no allocation in a steady time loop
  }
  Dispatch<LaunchMap>::run(dim, opt.method, ex, particles, view(), gv_, opt, B, flags_.data(), log_cell_.data(),
                           log_particle_.data(), log_cap_, global_table, queue_.data(), queue_cap, pair_.data());
  paired_ = particles.n * pair_box_;
  if (opt.sort_slots && K_ > 1) {
    for_each(ex, paired_, MarkSorters{view(), pair_.data(), pair_box_});
    for_each(ex, paired_, SortMarked{view(), pair_.data()});
  }
}

void CellSlots::clear_overflow(const Exec& ex) { for_each(ex, flags_.size(), ZeroInts{flags_.data()}); }

OverflowReport CellSlots::overflow() const {
  OverflowReport r;
  const std::vector<int> flags = mapk::read_flags(backend_, flags_);
  r.events = flags[0];
  r.radius_too_large = flags[1] > 0;
  r.bad_particle = r.radius_too_large ? flags[2] : -1;
  r.overflow = flags[0] > 0;
  std::ostringstream msg;
  if (r.overflow) {
    const mapk::LoggedOverflow lo = mapk::read_overflow_log(log_cell_, log_particle_, flags[0], log_cap_);
    r.cell = lo.key;
    r.ijk = {r.cell % gv_.nx, (r.cell / gv_.nx) % gv_.ny, r.cell / (static_cast<Index>(gv_.nx) * gv_.ny)};
    int cnt = 0;
    count_.copy_to_host(&cnt, 1, r.cell);
    r.count = cnt;
    for (int k = 0; k < K_; ++k) {
      int pk = -1;
      particle_.copy_to_host(&pk, 1, static_cast<Index>(k) * gv_.n + r.cell);
      r.particles.push_back(pk);
    }
    r.particles.insert(r.particles.end(), lo.particles.begin(), lo.particles.end());
    std::sort(r.particles.begin(), r.particles.end());
    msg << "PSM cell slots overflow: cell (" << r.ijk[0] << ", " << r.ijk[1] << ", " << r.ijk[2] << ") [index "
        << r.cell << "] is overlapped by " << r.count << " particles (";
    for (std::size_t i = 0; i < r.particles.size(); ++i) msg << (i ? ", " : "") << r.particles[i];
    msg << ") but K = " << K_ << " slots per cell; " << r.events
        << " (cell, particle) pairs found no slot in all. Raise K (slots per cell) to at least " << r.count
        << ", or check for overlapping particles.";
  }
  mapk::finish_report(r, msg);
  return r;
}

void CellSlots::throw_if_overflow() const {
  const OverflowReport r = overflow();
  if (r.overflow || r.radius_too_large) throw ResourceError(r.message);
}

namespace {
struct SlotEpsBox {
  CellSlotsView s;
  CellBox box;
  double* out;
  LBDEM_HD void operator()(Index cell, int x, int y, int z) const {
    out[(x - box.lo[0]) + static_cast<Index>(box.ext[0]) * ((y - box.lo[1]) + static_cast<Index>(box.ext[1]) * (z - box.lo[2]))] =
        s.total_eps(cell);
  }
};
}  // namespace

void CellSlots::total_eps_box(const Exec& ex, const CellBox& box, double* out) const {
  if (box.empty()) return;
  for_each_cell(ex, gv_, box, SlotEpsBox{view(), box, out});
}

MemoryUse CellSlots::memory_use() const {
  MemoryUse m;
  m.add("cell slots", count_.bytes() + particle_.bytes() + eps_.bytes() + vel_.bytes());
  m.add("slot pairs", pair_.bytes());
  m.add("overflow logs", flags_.bytes() + log_cell_.bytes() + log_particle_.bytes());
  m.add("fraction table", global_table_.bytes());
  m.add("exact queue", queue_.bytes());
  return m;
}

std::vector<double> CellSlots::total_eps_host() const {
  const auto cnt = counts_host();
  const auto eps = eps_host();
  const Index n = gv_.n;
  std::vector<double> out(static_cast<std::size_t>(n), 0.0);
  for (Index c = 0; c < n; ++c) {
    const int m = std::min(cnt[static_cast<std::size_t>(c)], K_);
    for (int k = 0; k < m; ++k) out[static_cast<std::size_t>(c)] += eps[static_cast<std::size_t>(k * n + c)];
  }
  return out;
}

void evaluate_fractions(const Exec& ex, FractionMethod method, int dim, const FractionTable* table, const double* rel,
                        const double* radius, double* out, Index n, bool table_in_constant) {
  if (dim != 2 && dim != 3) throw ConfigError("evaluate_fractions: dim = " + std::to_string(dim) + " (must be 2 or 3)");
  Buffer<float> global;  // test/bench helper: allocating here is fine (not in a time loop)
  if (method == FractionMethod::Table) {
    check_table(table, dim, "evaluate_fractions");
    if (table_in_constant || !ex.on_device()) {
      upload_table(ex, *table);
    } else {
      global = Buffer<float>(ex.backend(), static_cast<Index>(table->values.size()));
      global.copy_from_host(table->values);
    }
  }
  Dispatch<LaunchEval>::run(dim, method, ex, table, rel, radius, out, n, global.data());
  ex.synchronize();  // `global` must outlive the kernel
}

}  // namespace lbdem::imb
