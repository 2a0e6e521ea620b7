#pragma once
// Fused PSM step: solid fractions computed inside the stream-collide kernel.
//
// One CUDA block per tile of 256 cells (imb/tile_map.hpp). The block
//   1. issues its cells' population loads, then reads the tile's candidate
//      particles (the tile list written by TileMap::build) into shared memory
//      and ranks them by particle index (the slot order of the mapped path,
//      so the sums below do not depend on atomic order);
//   2. per cell, tests each candidate (minimum image, a sphere-vs-cell bound),
//      evaluates ε (table or linear, imb/fraction_eval.hpp) where the cell may
//      overlap, keeps up to K slots (ε_k, candidate) in registers — a cell
//      with more than K overlaps is logged as an overflow, never dropped
//      silently — and forms B and the solid moments;
//   3. collides (psm_collide, the same arithmetic as the mapped kernel) and
//      stores;
//   4. sums the force and torque on each candidate over the block: a fixed
//      tree per warp (the plain shuffle tree's sums, computed by exchanging
//      halves of the six values: warp_sum6_exchange), then the warps in order,
//      into the particle's entry for this tile. TileMap::finish adds a
//      particle's entries in order.
// The mapped pipeline writes per-cell slots and a per-(slot, cell) force array
// that a gather reads back; here nothing per cell leaves the kernel but the
// populations.
//
// The host backend runs the same per-cell functions tile by tile and adds in
// the same tree order (run_fused_host below).
#include <cmath>
#include <cstdint>

#include "core/hd.hpp"
#include "imb/fraction_eval.hpp"
#include "imb/psm.hpp"
#include "imb/tile_map.hpp"
#include "lbm/kernels.hpp"

namespace lbdem::imb {

// A candidate particle as the block holds it (shared memory on the device),
// in the lattice's precision R: its centre relative to the tile's first cell
// corner (formed in double, then rounded: offsets of a few tens of cells, so an
// fp32 run keeps ~1e-6 cells), radius, FractionOf::prepare(radius), velocity
// and angular velocity. All per-cell arithmetic then runs in R.
template <class R>
struct FusedCand {
  R o[3], r, aux;
  R v[3], w[3];
  int p, entry;  // particle index, its partial-force entry for this tile
};

// The solid state of one cell: up to kFusedMaxSlots slots (ε_k, candidate
// rank). The ranks are packed 8 bits each into one register; the ε_k live
// outside the registers (shared memory on the device, eps[k * stride]): the
// kernel holds 19 populations and the moments at once, and the ε_k in
// registers as well would spill.
template <class R>
struct FusedSolid {
  int m = 0;
  unsigned idx = 0;  // rank of slot k in bits 8k .. 8k + 7
  R* eps = nullptr;
  int stride = 1;
  R eps_tot = 0, B = 0, M1[3] = {0, 0, 0}, M2[6] = {0, 0, 0, 0, 0, 0};
  LBDEM_HD int rank(int k) const { return static_cast<int>((idx >> (8 * k)) & 0xFFu); }
  LBDEM_HD R& eps_at(int k) const { return eps[k * stride]; }
};

template <class L, class T, lbm::StreamKind S, int Parity, bool Bnd, bool Force, PsmVariant V, class Frac>
struct PsmFusedKernel : PsmLatticeFields<T> {
  using R = lbm::compute_t<T>;
  using Lattice = L;
  static constexpr int Dim = L::D;
  static constexpr int kQ = L::Q;
  static constexpr bool kBnd = Bnd;

  static constexpr int kForceChunk = 16;  // candidates per shared-memory force pass
  using Lat = PsmLatticeFields<T>;  // the lattice side's members, by name (a dependent base)
  using Lat::src, Lat::dst, Lat::g, Lat::flags, Lat::bt, Lat::omega_p, Lat::omega_m, Lat::F, Lat::G, Lat::tm,
      Lat::weight;
  int K;  // slots per cell in use (<= kFusedMaxSlots)
  TileView tv;
  CellBox tiles;  // the tiles this launch updates (a box in tile coordinates; PsmCoupling::parts)
  int own_lo[3] = {0, 0, 0}, own_hi[3] = {0, 0, 0};  // the owned cells [lo, hi) in storage coordinates
  SphereView p;
  Frac frac;

  // The tile shape as compile-time constants (TileShape::for_dim, the tile
  // map's shape): the per-thread index arithmetic is then shifts and masks.
  static constexpr TileShape kShape = TileShape::for_dim(Dim);
  static constexpr int kTX = kShape.tx, kTY = kShape.ty, kTZ = kShape.tz;
  static constexpr int kCells = kTX * kTY * kTZ;  // threads per block
  static constexpr int kWarps = kCells / 32;
  static_assert(kTX == 32, "a warp is one x row of its tile");
  static_assert(kCells <= 256 && kCells >= 6 * 16, "the host runner's arrays and the force sums");

  // A tile: its index in the lists and its position in the tile grid (the
  // device takes the position from a 3D launch grid, no division).
  struct TileId {
    Index linear;
    int ix, iy, iz;
  };
  LBDEM_HD TileId tile_id(Index linear) const {
    const auto tl = static_cast<unsigned>(linear);
    const unsigned ntx = static_cast<unsigned>(tv.ntx), nty = static_cast<unsigned>(tv.nty);
    const unsigned q = tl / ntx;
    return {linear, static_cast<int>(tl - q * ntx), static_cast<int>(q % nty), static_cast<int>(q / nty)};
  }
  LBDEM_HD static void tile_origin(const TileId& t, int (&o)[3]) {
    o[0] = t.ix * kTX;
    o[1] = t.iy * kTY;
    o[2] = t.iz * kTZ;
  }

  // Cell of thread `tid` in tile `t`; false if it lies outside the owned box
  // (the tile overhangs the grid, or the cell is a ghost of a cut grid).
  // Ghosts are told by position, not by their flag: a piece without boundary
  // entries then takes the kernel without flag reads (LbmRaw::has_boundaries).
  LBDEM_HD bool coords(const TileId& t, int tid, int& x, int& y, int& z) const {
    int o[3], lx, ly, lz;
    tile_origin(t, o);
    local(tid, lx, ly, lz);
    x = o[0] + lx;
    y = o[1] + ly;
    z = o[2] + lz;
    return x >= own_lo[0] && x < own_hi[0] && y >= own_lo[1] && y < own_hi[1] && z >= own_lo[2] && z < own_hi[2];
  }

  LBDEM_HD int candidates(Index tile) const {
    const int c = tv.count[tile];
    return c < tv.capacity ? c : tv.capacity;
  }

  // Thread tid's offsets from its tile's first cell: a warp is one x row of
  // the tile (coalesced population loads), lane l at x = l; the warps in y,
  // then z.
  LBDEM_HD static void local(int tid, int& lx, int& ly, int& lz) {
    const int lane = tid % 32, w = tid / 32;
    lx = lane;
    ly = w % kTY;
    lz = w / kTY;
  }

  LBDEM_HD void load_candidate(const TileId& tile, int i, FusedCand<R>& c) const {
    const Index slot = tile.linear * tv.capacity + i;
    load_candidate(tile, tv.particle[slot], tv.entry[slot], c);
  }
  // The same with the list entry (particle index, partial-force entry) already read.
  LBDEM_HD void load_candidate(const TileId& tile, int particle, int entry, FusedCand<R>& c) const {
    c.p = particle;
    c.entry = entry;
    const Index o = static_cast<Index>(c.p) * p.stride;
    int org[3];
    tile_origin(tile, org);
    // Centres in storage coordinates (GridView::shift), brought into [0, n) on
    // axes that wrap (particles may be given unwrapped, any number of periods
    // away), so that one minimum-image correction in rel() finds the image
    // that overlaps a cell.
    // On a cut periodic axis the image nearest this piece; the offset from
    // the tile's first cell is taken in the global frame (one rounding).
    c.o[0] = R(wrap_centre(g.nearest_image(0, p.x[o]), g.nx, g.periodic[0]) - (org[0] + g.shift[0]));
    c.o[1] = R(wrap_centre(g.nearest_image(1, p.y[o]), g.ny, g.periodic[1]) - (org[1] + g.shift[1]));
    c.o[2] = Dim == 3 ? R(wrap_centre(g.nearest_image(2, p.z[o]), g.nz, g.periodic[2]) - (org[2] + g.shift[2])) : R(0.5);
    const double rad = p.r[o];
    c.r = R(rad);
    c.aux = R(frac.prepare(rad));
    c.v[0] = R(p.vx ? p.vx[o] : 0.0);
    c.v[1] = R(p.vy ? p.vy[o] : 0.0);
    c.v[2] = R(p.vz && Dim == 3 ? p.vz[o] : 0.0);
    c.w[0] = R(p.wx ? p.wx[o] : 0.0);
    c.w[1] = R(p.wy ? p.wy[o] : 0.0);
    c.w[2] = R(p.wz ? p.wz[o] : 0.0);
  }

  LBDEM_HD static double wrap_centre(double c, int n, bool periodic) {
    return periodic ? c - n * floor(c / n) : c;
  }

  // Position of the tile's candidate i in particle-index order (indices are
  // unique in a tile), read from the tile list itself: the candidate can then
  // be stored at its rank before the block's one barrier.
  LBDEM_HD int rank(Index tile, int nc, int i) const {
    const int* list = tv.particle + tile * tv.capacity;
    const int pi = list[i];
    int r = 0;
    for (int j = 0; j < nc; ++j) r += list[j] < pi ? 1 : 0;
    return r;
  }

  // Centre of the cell at tile offsets (lx, ly, lz) relative to the
  // candidate's centre, minimum image on periodic axes.
  LBDEM_HD static R min_image_r(R d, int n, bool periodic) {
    if (!periodic) return d;
    const R h = R(0.5) * R(n);
    return d > h ? d - R(n) : (d < -h ? d + R(n) : d);
  }
  LBDEM_HD void rel(int lx, int ly, int lz, const FusedCand<R>& c, R (&r)[3]) const {
    r[0] = min_image_r(R(lx) + R(0.5) - c.o[0], g.nx, g.periodic[0]);
    r[1] = min_image_r(R(ly) + R(0.5) - c.o[1], g.ny, g.periodic[1]);
    r[2] = Dim == 3 ? min_image_r(R(lz) + R(0.5) - c.o[2], g.nz, g.periodic[2]) : R(0);
  }

  // Solid velocity at the cell centre, v + w x r (first paper Eq. 2).
  LBDEM_HD static void solid_velocity(const FusedCand<R>& c, const R (&r)[3], R (&vs)[3]) {
    vs[0] = c.v[0] + c.w[1] * r[2] - c.w[2] * r[1];
    vs[1] = c.v[1] + c.w[2] * r[0] - c.w[0] * r[2];
    vs[2] = Dim == 3 ? c.v[2] + c.w[0] * r[1] - c.w[1] * r[0] : R(0);
  }

  // Step 2: the cell's slots, B and solid moments. (x, y, z): the cell's
  // offsets in its tile. `cand` is in particle-index order. Surplus
  // overlaps beyond K are logged (cell, particle).
  LBDEM_HD void overlap(int x, int y, int z, Index cell, const FusedCand<R>* cand, int nc,
                        FusedSolid<R>& s) const {
    // A cell overlaps a ball only if its centre lies within R + half its diagonal.
    const double half_diag = Dim == 3 ? 0.86602540378443865 : 0.70710678118654752;
    for (int c = 0; c < nc; ++c) {
      const FusedCand<R>& q = cand[c];
      R r[3];
      rel(x, y, z, q, r);
      const R lim = q.r + R(half_diag);
      // y and z first: the same for a warp's 32 cells (one x row), so most
      // candidates that miss a row are skipped without divergence.
      const R yz2 = r[1] * r[1] + r[2] * r[2];
      if (yz2 >= lim * lim) continue;
      if (r[0] * r[0] + yz2 >= lim * lim) continue;
      const R e = frac.eval(r[0], r[1], r[2], q.r, q.aux);
      if (!(e > R(0))) continue;
      if (s.m < K) {
        s.eps_at(s.m) = e;
        s.idx |= static_cast<unsigned>(c) << (8 * s.m);
        s.eps_tot += e;
        ++s.m;
      } else {
        log_overflow(cell, q.p);
      }
    }
    if (s.m == 0) return;
    s.B = psm_cell_weight(s.eps_tot, tm, weight);
    LBDEM_UNROLL
    for (int k = 0; k < kFusedMaxSlots; ++k) {
      if (k >= s.m) break;
      const FusedCand<R>& q = cand[s.rank(k)];
      R r[3];
      rel(x, y, z, q, r);
      R vs[3];
      solid_velocity(q, r, vs);
      add_solid_moments(psm_slot_weight(s.B, s.eps_at(k), s.eps_tot), vs, s.M1, s.M2);
    }
  }

  LBDEM_HD void log_overflow(Index cell, int particle) const {
#if defined(__CUDA_ARCH__)
    const int e = atomicAdd(&tv.flags[0], 1);
#else
    const int e = __atomic_fetch_add(&tv.flags[0], 1, __ATOMIC_RELAXED);
#endif
    if (e < tv.log_cap) {
      tv.log_cell[e] = cell;
      tv.log_particle[e] = particle;
    }
  }

  // Step 1: the cell's incoming populations.
  LBDEM_HD LBDEM_FORCEINLINE void load(int x, int y, int z, Index cell, lbm::Neighbours& nb, R (&f)[L::Q]) const {
    nb = lbm::neighbours_at<L>(g, x, y, z);
    lbm::load_incoming<L, T, R, S, Parity>(src, nb, cell, f);
  }

  // Step 3: collide and store. `plain` (no solid lane in the warp; on the host:
  // no slot in the cell) takes the plain collision, the B = 0 case of the same
  // arithmetic with fewer instructions. rho and u feed the force (step 4).
  LBDEM_HD LBDEM_FORCEINLINE void collide_store(Index cell, const lbm::Neighbours& nb, R (&f)[L::Q],
                                                const FusedSolid<R>& s, bool plain, R& rho, R (&u)[3]) const {
    if (plain) {
      R drho;
      Lat::template collider<L, Force>()(f, drho, u);
      rho = R(1) + drho;
    } else {
      psm_collide<L, R, Force, V>(Lat::template collider<L, Force>(), f, s.B, Lat::even_weight(s.B), s.M1, s.M2,
                                  rho, u);
    }
    lbm::store_outgoing<L, T, R, S, Parity, Bnd>(dst, nb, cell, f, flags, bt, u);
  }

  // Step 4: the slot of this cell that holds the candidate of rank c, or -1
  // (a particle holds at most one slot of a cell).
  LBDEM_HD static int slot_of(const FusedSolid<R>& s, int c) {
    int found = -1;
    LBDEM_UNROLL
    for (int k = 0; k < kFusedMaxSlots; ++k)
      if (k < s.m && s.rank(k) == c) found = k;
    return found;
  }
  // Force (0..2) and torque (3..5) of this cell on the particle of slot k.
  LBDEM_HD void contribution(int x, int y, int z, const FusedSolid<R>& s, int k, const FusedCand<R>& q, R rho,
                             const R (&u)[3], R (&out)[6]) const {
    R r[3];
    rel(x, y, z, q, r);
    R vs[3];
    solid_velocity(q, r, vs);
    R Fk[3];
    psm_particle_force<R, Force, V>(psm_slot_weight(s.B, s.eps_at(k), s.eps_tot), rho, vs, u, F, G, omega_m, Fk);
    out[0] = Fk[0];
    out[1] = Fk[1];
    out[2] = Fk[2];
    out[3] = r[1] * Fk[2] - r[2] * Fk[1];
    out[4] = r[2] * Fk[0] - r[0] * Fk[2];
    out[5] = r[0] * Fk[1] - r[1] * Fk[0];
  }
};

// Host backend: the same per-cell functions, tile by tile (OpenMP over tiles),
// the force sums in the device's order (shuffle tree per warp of 32 cells,
// then the 8 warps in order).
template <class Kern>
void run_fused_host(const Kern& k) {
  using R = typename Kern::R;
  const Index ntiles = k.tiles.size();
  const int ncell = k.tv.t.cells();
#pragma omp parallel for schedule(dynamic, 8)
  for (Index ti = 0; ti < ntiles; ++ti) {
    int ix, iy, iz;
    k.tiles.coords(ti, ix, iy, iz);
    const Index tl = ix + static_cast<Index>(k.tv.ntx) * (iy + static_cast<Index>(k.tv.nty) * iz);
    const auto tile = k.tile_id(tl);
    FusedCand<R> cand[kFusedMaxCapacity];
    const int nc = k.candidates(tl);
    for (int i = 0; i < nc; ++i) k.load_candidate(tile, i, cand[k.rank(tl, nc, i)]);  // in particle-index order
    FusedSolid<R> sol[256];
    R eps_store[256][kFusedMaxSlots];
    R rho[256], u[256][3];
    int cx[256], cy[256], cz[256];
    bool valid[256];
    for (int t = 0; t < ncell; ++t) {
      int x, y, z;
      valid[t] = k.coords(tile, t, x, y, z);
      k.local(t, cx[t], cy[t], cz[t]);  // offsets in the tile (what rel() takes)
      sol[t] = FusedSolid<R>{};
      sol[t].eps = eps_store[t];
      sol[t].stride = 1;
      rho[t] = R(1);
      u[t][0] = u[t][1] = u[t][2] = R(0);
      if (!valid[t]) continue;
      const Index cell = k.g.index(x, y, z);
      if constexpr (Kern::kBnd) {
        if (k.flags[cell] != 0) {
          valid[t] = false;
          continue;
        }
      }
      lbm::Neighbours nb;
      R f[Kern::kQ];
      k.load(x, y, z, cell, nb, f);
      if (nc > 0) k.overlap(cx[t], cy[t], cz[t], cell, cand, nc, sol[t]);
      k.collide_store(cell, nb, f, sol[t], sol[t].m == 0, rho[t], u[t]);
    }
    for (int c0 = 0; c0 < nc; c0 += Kern::kForceChunk) {
      const int cn = nc - c0 < Kern::kForceChunk ? nc - c0 : Kern::kForceChunk;
      for (int c = 0; c < cn; ++c) {
        const FusedCand<R>& q = cand[c0 + c];
        double total[6] = {0, 0, 0, 0, 0, 0};
        for (int w = 0; w < ncell / 32; ++w) {
          R v[32][6];
          bool any = false;
          for (int l = 0; l < 32; ++l) {
            const int t = 32 * w + l;
            for (int a = 0; a < 6; ++a) v[l][a] = R(0);
            const int ks = valid[t] ? Kern::slot_of(sol[t], c0 + c) : -1;
            if (ks >= 0) k.contribution(cx[t], cy[t], cz[t], sol[t], ks, q, rho[t], u[t], v[l]);
            any = any || ks >= 0;
          }
          if (!any) continue;  // the device writes 0 for this warp
          for (int off = 16; off > 0; off >>= 1)
            for (int l = 0; l < off; ++l)
              for (int a = 0; a < 6; ++a) v[l][a] += v[l + off][a];
          for (int a = 0; a < 6; ++a) total[a] += static_cast<double>(v[0][a]);
        }
        for (int a = 0; a < 6; ++a) k.tv.partial[static_cast<Index>(q.entry) * 6 + a] = total[a];
      }
    }
  }
}

}  // namespace lbdem::imb
