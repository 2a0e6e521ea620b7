// Particle -> tile candidate lists and the per-particle force finish of the
// fused PSM pipeline (imb/tile_map.hpp).
#include "imb/tile_map.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <sstream>

#include "core/algorithms.hpp"
#include "core/error.hpp"
#include "imb/fraction_eval.hpp"
#include "imb/psm_coupling.hpp"
#include "map_functors.hpp"

namespace lbdem::imb {

namespace {

LBDEM_HD inline int atomic_add(int* p, int v) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(p, v);
#else
  return __atomic_fetch_add(p, v, __ATOMIC_RELAXED);
#endif
}

// Zeros the box-ordered output of a box (no particles: no solid).
struct ZeroBox {
  CellBox box;
  double* out;
  LBDEM_HD void operator()(Index, int x, int y, int z) const {
    out[(x - box.lo[0]) + static_cast<Index>(box.ext[0]) * ((y - box.lo[1]) + static_cast<Index>(box.ext[1]) * (z - box.lo[2]))] = 0.0;
  }
};

LBDEM_HD inline Index wrap_index(Index i, Index n) {
  i %= n;
  return i < 0 ? i + n : i;
}

// The l-th distinct tile (along one axis of n cells cut into tiles of T) that
// the cells floor(c - R) .. floor(c + R) touch, wrapped on a periodic axis,
// clipped to the grid otherwise; -1 if there are not l + 1 of them.
LBDEM_HD inline int axis_tile(int l, double c, double R, Index n, int T, bool periodic) {
  Index lo = static_cast<Index>(floor(c - R)), hi = static_cast<Index>(floor(c + R));
  if (!periodic) {
    lo = lo < 0 ? 0 : lo;
    hi = hi > n - 1 ? n - 1 : hi;
    if (lo > hi) return -1;
  }
  Index g = lo;
  int first = -1;
  for (int k = 0;; ++k) {
    const Index w = periodic ? wrap_index(g, n) : g;
    const int tile = static_cast<int>(w / T);
    if (k > 0 && tile == first) return -1;  // wrapped back into the first tile
    if (k == 0) first = tile;
    if (k == l) return tile;
    const Index next = (static_cast<Index>(tile) + 1) * T < n ? (static_cast<Index>(tile) + 1) * T : n;
    g += next - w;
    if (g > hi) return -1;
  }
}

struct TileBuild {
  SphereView p;
  TileView tv;
  int* count;
  int* particle;
  int* entry;
  int dim, B;
  int mx, my, mz;
  int* flags;
  Index* log_tile;
  int* log_particle;
  int log_cap;

  LBDEM_HD void zero_entry(Index e) const {
    for (int a = 0; a < 6; ++a) tv.partial[e * 6 + a] = 0.0;
  }

  LBDEM_HD void operator()(Index t) const {
    const Index pi = t / tv.max_tiles;
    const int l = static_cast<int>(t - pi * tv.max_tiles);
    const int lx = l % mx, ly = (l / mx) % my, lz = l / (mx * my);
    const Index o = pi * p.stride;
    const double R = p.r[o];
    if (l == 0 && static_cast<Index>(floor(2.0 * R)) + 2 > B) {  // its box exceeds the tile ranges sized for max_radius
      atomic_add(&flags[2], 1);
      flags[3] = static_cast<int>(pi);
    }
    // Centres in storage coordinates (GridView::shift: the global frame's offset).
    const int tx = axis_tile(lx, tv.g.nearest_image(0, p.x[o]) - tv.g.shift[0], R, tv.g.nx, tv.t.tx, tv.g.periodic[0]);
    const int ty = axis_tile(ly, tv.g.nearest_image(1, p.y[o]) - tv.g.shift[1], R, tv.g.ny, tv.t.ty, tv.g.periodic[1]);
    const int tz = dim == 3 ? axis_tile(lz, tv.g.nearest_image(2, p.z[o]) - tv.g.shift[2], R, tv.g.nz, tv.t.tz, tv.g.periodic[2])
                            : (lz == 0 ? 0 : -1);
    if (tx < 0 || ty < 0 || tz < 0) {
      zero_entry(t);
      return;
    }
    const Index tile = tx + static_cast<Index>(tv.ntx) * (ty + static_cast<Index>(tv.nty) * tz);
    const int slot = atomic_add(&count[tile], 1);
    if (slot < tv.capacity) {
      particle[tile * tv.capacity + slot] = static_cast<int>(pi);
      entry[tile * tv.capacity + slot] = static_cast<int>(t);
    } else {
      zero_entry(t);
      const int e = atomic_add(&flags[1], 1);
      if (e < log_cap) {
        log_tile[e] = tile;
        log_particle[e] = static_cast<int>(pi);
      }
    }
  }
};

// Per particle (one warp, imb/psm.hpp warp_gather): lane j adds the
// particle's tile entries j, j + 32, ...
struct TileFinish {
  const double* partial;
  int max_tiles;
  ForceWriter write;

  LBDEM_HD void lane_sum(Index i, int lane, double (&acc)[6]) const {
    for (int a = 0; a < 6; ++a) acc[a] = 0.0;
    for (int l = lane; l < max_tiles; l += 32) {
      const double* e = partial + (i * max_tiles + l) * 6;
      for (int a = 0; a < 6; ++a) acc[a] += e[a];
    }
  }
  LBDEM_HD void operator()(Index t) const { warp_gather(*this, t); }
};

using mapk::ZeroInts;

int ceil_div(Index a, int b) { return static_cast<int>((a + b - 1) / b); }

}  // namespace

TileMap::TileMap(Backend b, const Grid& grid, int K, int capacity, int overflow_log)
    : backend_(b), grid_(grid), shape_(TileShape::for_dim(grid.dim())), K_(K), capacity_(capacity),
      log_cap_(std::max(overflow_log, 1)), scratch_(std::make_shared<Scratch>()) {
  if (K_ < 1 || K_ > kFusedMaxSlots)
    throw ConfigError("TileMap: K (slots per cell) = " + std::to_string(K_) + ": the fused PSM pipeline keeps 1.." +
                      std::to_string(kFusedMaxSlots) + " slots per cell; use psm.pipeline: mapped for more");
  if (capacity_ < 1 || capacity_ > kFusedMaxCapacity)
    throw ConfigError("psm.tile_capacity = " + std::to_string(capacity_) + ": must be in 1.." +
                      std::to_string(kFusedMaxCapacity));
  try {
    grid_.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(std::string("TileMap: ") + e.what());
  }
  gv_ = grid_.view();
  ntx_ = ceil_div(gv_.nx, shape_.tx);
  nty_ = ceil_div(gv_.ny, shape_.ty);
  ntz_ = ceil_div(gv_.nz, shape_.tz);
  const Index tiles = static_cast<Index>(ntx_) * nty_ * ntz_;
  count_ = Buffer<int>(b, tiles);
  particle_ = Buffer<int>(b, tiles * capacity_);
  entry_ = Buffer<int>(b, tiles * capacity_);
  flags_ = Buffer<int>(b, 4);
  log_cell_ = Buffer<Index>(b, log_cap_);
  log_particle_ = Buffer<int>(b, log_cap_);
  log_tile_ = Buffer<Index>(b, log_cap_);
  log_tile_particle_ = Buffer<int>(b, log_cap_);
  count_.fill_zero();
  flags_.fill_zero();
  // The fused kernel reads a tile's list entries before its count arrives
  // (entries past the count are not used): they are defined from the start.
  particle_.fill_zero();
  entry_.fill_zero();
}

TileView TileMap::view() const {
  TileView v;
  v.g = gv_;
  v.t = shape_;
  v.ntx = ntx_;
  v.nty = nty_;
  v.ntz = ntz_;
  v.capacity = capacity_;
  v.max_tiles = max_tiles_;
  v.count = count_.data();
  v.particle = particle_.data();
  v.entry = entry_.data();
  v.partial = const_cast<double*>(partial_.data());
  v.flags = const_cast<int*>(flags_.data());
  v.log_cell = const_cast<Index*>(log_cell_.data());
  v.log_particle = const_cast<int*>(log_particle_.data());
  v.log_cap = log_cap_;
  return v;
}

void TileMap::build(const Exec& ex, const SphereView& p, double max_radius) {
  if (ex.backend() != backend_)
    throw ConfigError(std::string("TileMap::build: tiles live on ") + to_string(backend_) + " but the Exec runs on " +
                      to_string(ex.backend()));
  const int dim = grid_.dim();
  if (p.n > 0 && (!p.x || !p.y || !p.r || (dim == 3 && !p.z)))
    throw ConfigError("TileMap::build: particle view has null position or radius arrays");
  if (p.n > static_cast<Index>(INT32_MAX) / 64)
    throw ConfigError("TileMap::build: " + std::to_string(p.n) + " particles exceed the int32 entry index");
  double rmax = max_radius;
  if (!(rmax > 0.0) && p.n > 0) rmax = mapk::largest_radius(ex, p, *scratch_);
  rmax = std::max(rmax, 0.0);
  const int B = static_cast<int>(std::floor(2.0 * rmax)) + 2;
  const Index ns[3] = {gv_.nx, gv_.ny, gv_.nz};
  const int ts[3] = {shape_.tx, shape_.ty, shape_.tz};
  for (int a = 0; a < dim; ++a) {
    if (gv_.periodic[a] && B > ns[a])
      throw ConfigError("PSM tiles: particle radius " + std::to_string(rmax) + " spans " + std::to_string(B) +
                        " cells, more than the " + std::to_string(ns[a]) + " cells of periodic axis " +
                        std::string(1, "xyz"[a]) + " (a particle would meet its own image)");
    axis_max_[a] = 2 + (B - 1) / ts[a];
  }
  if (dim == 2) axis_max_[2] = 1;
  max_tiles_ = axis_max_[0] * axis_max_[1] * axis_max_[2];
  for_each(ex, count_.size(), ZeroInts{count_.data()});
  built_particles_ = p.n;
  if (p.n == 0) return;
  partial_.reserve_discard(backend_, p.n * max_tiles_ * 6);  // grows only: no allocation in a steady time loop
  TileBuild k{};
  k.p = p;
  k.tv = view();
  k.count = count_.data();
  k.particle = particle_.data();
  k.entry = entry_.data();
  k.dim = dim;
  k.B = B;
  k.mx = axis_max_[0];
  k.my = axis_max_[1];
  k.mz = axis_max_[2];
  k.flags = flags_.data();
  k.log_tile = log_tile_.data();
  k.log_particle = log_tile_particle_.data();
  k.log_cap = log_cap_;
  for_each(ex, p.n * max_tiles_, k);
}

void TileMap::finish(const Exec& ex, const SphereView& p, const ForceOut& out) const {
  if (p.n == 0) return;
  if (p.n != built_particles_)
    throw ConfigError("TileMap::finish: " + std::to_string(p.n) + " particles but the tiles were built for " +
                      std::to_string(built_particles_));
  TileFinish k{partial_.data(), max_tiles_,
               ForceWriter{p, grid_.dim(), out.force, out.torque, out.fstride, out.tstride,
                           {out.per_volume[0], out.per_volume[1], out.per_volume[2]}, out.per_volume_count}};
  for_each(ex, 32 * p.n, k);
}

void TileMap::clear_overflow(const Exec& ex) { for_each(ex, flags_.size(), ZeroInts{flags_.data()}); }

namespace {

// Total solid fraction of the cells of a box from the tile lists, for output:
// per cell, its tile's candidates, each tested over the cells of its bounding
// box [floor(c - R), floor(c + R)] with the image and the offsets the slot map
// takes (cell_slots.cu: the image nearest this piece, the unwrapped cell
// index, offsets formed in the global frame), ε in double, the overlaps kept in
// particle-index order and the first K summed: the slot map's sorted slots
// and CellSlotsView::total_eps, bit for bit, without per-cell slot arrays.
template <int Dim, FractionMethod M>
struct TileEpsKernel {
  static constexpr int kKept = 2 * kFusedMaxSlots;  // more than K overlaps is an overflow (reported by the step)
  TileView tv;
  SphereView p;
  FractionOf<Dim, M, PointerTableAccess, double> frac;
  int K;
  CellBox box;
  double* out;  // box.size() values, box x-fastest

  // Unwrapped index of storage cell x in the particle's box [i0, i1] on an
  // axis of n cells, or false when the box misses it.
  LBDEM_HD static bool image(Index x, Index i0, Index i1, Index n, bool periodic, Index& gi) {
    gi = periodic ? i0 + wrap_index(x - i0, n) : x;
    return gi >= i0 && gi <= i1;
  }

  LBDEM_HD void operator()(Index, int x, int y, int z) const {
    const GridView& g = tv.g;
    const Index o = (x - box.lo[0]) + static_cast<Index>(box.ext[0]) * ((y - box.lo[1]) + static_cast<Index>(box.ext[1]) * (z - box.lo[2]));
    const Index tile = x / tv.t.tx + static_cast<Index>(tv.ntx) * (y / tv.t.ty + static_cast<Index>(tv.nty) * (z / tv.t.tz));
    const int nc = tv.count[tile] < tv.capacity ? tv.count[tile] : tv.capacity;
    int kept_p[kKept];
    double kept_e[kKept];
    int m = 0;
    for (int c = 0; c < nc; ++c) {
      const int pi = tv.particle[tile * tv.capacity + c];
      const Index po = static_cast<Index>(pi) * p.stride;
      const double R = p.r[po];
      const double xg = g.nearest_image(0, p.x[po]), yg = g.nearest_image(1, p.y[po]);
      const double zg = Dim == 3 ? g.nearest_image(2, p.z[po]) : 0.5;
      const double cx = xg - g.shift[0], cy = yg - g.shift[1], cz = Dim == 3 ? zg - g.shift[2] : 0.5;
      Index gi, gj, gk = 0;
      if (!image(x, static_cast<Index>(floor(cx - R)), static_cast<Index>(floor(cx + R)), g.nx, g.periodic[0], gi)) continue;
      if (!image(y, static_cast<Index>(floor(cy - R)), static_cast<Index>(floor(cy + R)), g.ny, g.periodic[1], gj)) continue;
      if (Dim == 3 &&
          !image(z, static_cast<Index>(floor(cz - R)), static_cast<Index>(floor(cz + R)), g.nz, g.periodic[2], gk))
        continue;
      const double rx = (static_cast<double>(gi) + g.shift[0]) + 0.5 - xg;
      const double ry = (static_cast<double>(gj) + g.shift[1]) + 0.5 - yg;
      const double rz = Dim == 3 ? (static_cast<double>(gk) + g.shift[2]) + 0.5 - zg : gk + 0.5 - cz;
      const double e = frac(rx, ry, rz, R);
      if (!(e > 0.0)) continue;
      // Insert in particle-index order, keeping the kKept smallest indices.
      int at = m < kKept ? m : kKept;
      while (at > 0 && kept_p[at - 1] > pi) --at;
      if (at >= kKept) continue;
      for (int k = (m < kKept ? m : kKept - 1); k > at; --k) {
        kept_p[k] = kept_p[k - 1];
        kept_e[k] = kept_e[k - 1];
      }
      kept_p[at] = pi;
      kept_e[at] = e;
      if (m < kKept) ++m;
    }
    double sum = 0.0;
    for (int k = 0; k < m && k < K; ++k) sum += kept_e[k];
    out[o] = sum;
  }
};

template <int Dim, FractionMethod M>
void launch_tile_eps(const Exec& ex, const TileView& tv, const SphereView& p, const FractionTable* table,
                     const float* values, bool linear_normalised, int K, const CellBox& box, double* out) {
  TileEpsKernel<Dim, M> k{};
  k.tv = tv;
  k.p = p;
  k.frac.linear_normalised = linear_normalised;
  if (table) k.frac.g = table->geometry;
  k.frac.tab.p = values;
  k.K = K;
  k.box = box;
  k.out = out;
  for_each_cell(ex, tv.g, box, k);
}

}  // namespace

void TileMap::total_eps(const Exec& ex, const SphereView& p, FractionMethod method, const FractionTable* table,
                        const float* table_values, bool linear_normalised, const CellBox& box, double* out) const {
  if (box.empty()) return;
  if (method == FractionMethod::Exact)
    throw ConfigError("TileMap::total_eps: the fused pipeline has no exact fractions");
  if (method == FractionMethod::Table && (!table || !table_values))
    throw ConfigError("TileMap::total_eps: solid-fraction method 'table' needs a table");
  if (p.n == 0 || built_particles_ != p.n) {
    for_each_cell(ex, gv_, box, ZeroBox{box, out});
    return;
  }
  const TileView tv = view();
  const int dim = grid_.dim();
  if (dim == 3) {
    if (method == FractionMethod::Table)
      launch_tile_eps<3, FractionMethod::Table>(ex, tv, p, table, table_values, linear_normalised, K_, box, out);
    else
      launch_tile_eps<3, FractionMethod::Linear>(ex, tv, p, table, table_values, linear_normalised, K_, box, out);
  } else {
    if (method == FractionMethod::Table)
      launch_tile_eps<2, FractionMethod::Table>(ex, tv, p, table, table_values, linear_normalised, K_, box, out);
    else
      launch_tile_eps<2, FractionMethod::Linear>(ex, tv, p, table, table_values, linear_normalised, K_, box, out);
  }
}

MemoryUse TileMap::memory_use() const {
  MemoryUse m;
  m.add("tile lists", count_.bytes() + particle_.bytes() + entry_.bytes());
  m.add("tile partial forces", partial_.bytes());
  m.add("overflow logs", flags_.bytes() + log_cell_.bytes() + log_particle_.bytes() + log_tile_.bytes() +
                             log_tile_particle_.bytes());
  return m;
}

OverflowReport TileMap::overflow() const {
  OverflowReport r;
  const std::vector<int> flags = mapk::read_flags(backend_, flags_);
  r.events = flags[0] + flags[1];
  r.radius_too_large = flags[2] > 0;
  r.bad_particle = r.radius_too_large ? flags[3] : -1;
  r.overflow = flags[0] > 0 || flags[1] > 0;
  std::ostringstream msg;
  if (flags[0] > 0) {
    mapk::LoggedOverflow lo = mapk::read_overflow_log(log_cell_, log_particle_, flags[0], log_cap_);
    r.cell = lo.key;
    r.ijk = {r.cell % gv_.nx, (r.cell / gv_.nx) % gv_.ny, r.cell / (static_cast<Index>(gv_.nx) * gv_.ny)};
    r.particles = std::move(lo.particles);
    std::sort(r.particles.begin(), r.particles.end());
    r.count = K_ + static_cast<int>(r.particles.size());
    msg << "PSM cell slots overflow: cell (" << r.ijk[0] << ", " << r.ijk[1] << ", " << r.ijk[2] << ") [index "
        << r.cell << "] is overlapped by at least " << r.count << " particles but K = " << K_
        << " slots per cell; the surplus particles were ";
    for (std::size_t i = 0; i < r.particles.size(); ++i) msg << (i ? ", " : "") << r.particles[i];
    msg << " (" << flags[0] << " (cell, particle) pairs found no slot in all). Raise K (slots per cell, at most "
        << kFusedMaxSlots << " in the fused pipeline), or check for overlapping particles.";
  }
  if (flags[1] > 0) {
    mapk::LoggedOverflow lo = mapk::read_overflow_log(log_tile_, log_tile_particle_, flags[1], log_cap_);
    const Index t = lo.key;
    const Index tx = t % ntx_, ty = (t / ntx_) % nty_, tz = t / (static_cast<Index>(ntx_) * nty_);
    if (r.cell < 0) {
      r.cell = tx * shape_.tx + static_cast<Index>(gv_.nx) * (ty * shape_.ty + static_cast<Index>(gv_.ny) * tz * shape_.tz);
      r.ijk = {tx * shape_.tx, ty * shape_.ty, tz * shape_.tz};
      r.particles = std::move(lo.particles);
      std::sort(r.particles.begin(), r.particles.end());
    }
    if (flags[0] > 0) msg << " ";
    msg << "PSM tile candidate list overflow: the tile of " << shape_.tx << "x" << shape_.ty << "x" << shape_.tz
        << " cells from cell (" << tx * shape_.tx << ", " << ty * shape_.ty << ", " << tz * shape_.tz
        << ") is touched by more than psm.tile_capacity = " << capacity_ << " particles (" << flags[1]
        << " (tile, particle) pairs found no place). Raise psm.tile_capacity (at most " << kFusedMaxCapacity
        << ") or use psm.pipeline: mapped.";
  }
  mapk::finish_report(r, msg);
  return r;
}

}  // namespace lbdem::imb
