#pragma once
// The fused PSM step as a CUDA kernel (one block per tile) and its dispatch:
// runtime choices -> template parameters, instantiated per (lattice,
// precision) in psm_fused_*.cu. The per-cell physics is in imb/psm_fused.hpp.
#include <type_traits>

#include "core/exec.hpp"
#include "imb/psm_coupling.hpp"
#include "imb/psm_fused.hpp"
#include "lbm/dispatch.hpp"

#if defined(__CUDACC__)
#include <cuda_pipeline.h>
#endif

namespace lbdem::imb {

#if defined(__CUDACC__)
// The six force and torque sums of a warp by a tree that exchanges halves:
// at distance 16 a lane keeps 4 of the (zero-padded) 8 values and sends the
// other 4, at 8 it keeps 2, at 4 one, then two plain levels. Each sum is the
// plain shuffle tree's (v[l] + v[l + off], off = 16, 8, 4, 2, 1) bit for bit:
// a lane adds its partner's value to its own, and float addition commutes.
// Returns, in lanes with lane % 4 == 0, the sum of value
// 4 (lane >> 4 & 1) + 2 (lane >> 3 & 1) + (lane >> 2 & 1) (6 and 7: zero).
template <class R>
__device__ LBDEM_FORCEINLINE R warp_sum6_exchange(const R (&v)[6], int lane) {
  const bool h16 = (lane & 16) != 0, h8 = (lane & 8) != 0, h4 = (lane & 4) != 0;
  R a[4];
  LBDEM_UNROLL
  for (int i = 0; i < 4; ++i) {
    const R lo = v[i], hi = i + 4 < 6 ? v[i + 4] : R(0);
    a[i] = (h16 ? hi : lo) + __shfl_xor_sync(0xffffffffu, h16 ? lo : hi, 16);
  }
  R b[2];
  LBDEM_UNROLL
  for (int i = 0; i < 2; ++i) b[i] = (h8 ? a[i + 2] : a[i]) + __shfl_xor_sync(0xffffffffu, h8 ? a[i] : a[i + 2], 8);
  R c = (h4 ? b[1] : b[0]) + __shfl_xor_sync(0xffffffffu, h4 ? b[0] : b[1], 4);
  c += __shfl_xor_sync(0xffffffffu, c, 2);
  c += __shfl_xor_sync(0xffffffffu, c, 1);
  return c;
}

// One block per tile, one thread per cell (imb/psm_fused.hpp, steps 1 to 4).
template <int MinBlocks, class Kern>
__global__ void __launch_bounds__(Kern::kCells, MinBlocks) psm_fused_kernel(Kern k) {
  using R = typename Kern::R;
  __shared__ FusedCand<R> cand[kFusedMaxCapacity];
  __shared__ R part[Kern::kWarps][Kern::kForceChunk][6];
  __shared__ R slot_eps[kFusedMaxSlots][Kern::kCells];
  const int tid = static_cast<int>(threadIdx.x);
  const int lane = tid & 31, warp = tid >> 5;
  const int ix = static_cast<int>(blockIdx.x) + k.tiles.lo[0], iy = static_cast<int>(blockIdx.y) + k.tiles.lo[1],
            iz = static_cast<int>(blockIdx.z) + k.tiles.lo[2];
  const typename Kern::TileId tile{ix + static_cast<Index>(k.tv.ntx) * (iy + static_cast<Index>(k.tv.nty) * iz), ix, iy, iz};
  int x, y, z;
  bool fluid = k.coords(tile, tid, x, y, z);
  const Index cell = fluid ? k.g.index(x, y, z) : 0;
  if constexpr (Kern::kBnd) fluid = fluid && k.flags[cell] == 0;
  // 1. Populations first (their latency hides the candidate reads and the
  // fraction arithmetic), then the tile's candidates.
  lbm::Neighbours nb;
  R f[Kern::kQ];
  if (fluid) k.load(x, y, z, cell, nb, f);
  // The tile's list entries are read beside its count, not after it (entries
  // past the count are defined but unused): the chain the block's barrier
  // waits for is then count|list -> particle, not count -> list -> particle.
  const Index slot = tile.linear * k.tv.capacity + tid;
  const bool listed = tid < k.tv.capacity;
  const int pi = listed ? k.tv.particle[slot] : 0;
  const int ei = listed ? k.tv.entry[slot] : 0;
  const int nc = k.candidates(tile.linear);
  if (nc <= 32) {
    // Rank in particle-index order (indices are unique in a tile) by shuffles within warp 0.
    if (warp == 0) {
      int r = 0;
      for (int j = 0; j < nc; ++j) r += __shfl_sync(0xffffffffu, pi, j) < pi ? 1 : 0;
      if (lane < nc) k.load_candidate(tile, pi, ei, cand[r]);
    }
  } else if (tid < nc) {
    k.load_candidate(tile, pi, ei, cand[k.rank(tile.linear, nc, tid)]);
  }
  __syncthreads();
  // 2. Slots, B and solid moments of this cell.
  FusedSolid<R> s;
  s.eps = &slot_eps[0][tid];
  s.stride = Kern::kCells;
  int lx, ly, lz;  // offsets in the tile: the per-cell arithmetic is relative to its first cell
  Kern::local(tid, lx, ly, lz);
  if (fluid && nc > 0) k.overlap(lx, ly, lz, cell, cand, nc, s);
  // 3. Collide and store; a warp without a solid lane takes the plain collision.
  const bool plain = !__any_sync(0xffffffffu, s.m > 0);
  R rho = R(1), u[3] = {R(0), R(0), R(0)};
  // The neighbour offsets are formed again for the store rather than kept
  // from the load: nine fewer values live across steps 2 and 3, which keeps
  // the odd-parity kernel within its 64 registers without spilling.
  if (fluid) k.collide_store(cell, lbm::neighbours_at<typename Kern::Lattice>(k.g, x, y, z), f, s, plain, rho, u);
  if (nc == 0) return;  // block-uniform
  // 4. Force and torque per candidate: exchange tree per warp (warp_sum6_exchange), warps in order.
  for (int c0 = 0; c0 < nc; c0 += Kern::kForceChunk) {
    const int cn = nc - c0 < Kern::kForceChunk ? nc - c0 : Kern::kForceChunk;
    if (plain) {  // no slot in this warp: zeros for every candidate
      if (lane == 0)
        for (int c = 0; c < cn; ++c)
          for (int a = 0; a < 6; ++a) part[warp][c][a] = R(0);
    } else {
    for (int c = 0; c < cn; ++c) {
      // Warps whose cells hold no slot of this candidate write zeros and skip the tree.
      const int ks = fluid ? Kern::slot_of(s, c0 + c) : -1;
      const bool any = __any_sync(0xffffffffu, ks >= 0);
      R v[6] = {R(0), R(0), R(0), R(0), R(0), R(0)};  // lanes without a slot (or off the grid) add zeros
      R sum = R(0);
      if (any) {
        if (ks >= 0) k.contribution(lx, ly, lz, s, ks, cand[c0 + c], rho, u, v);
        sum = warp_sum6_exchange(v, lane);
      }
      const int a = 4 * ((lane >> 4) & 1) + 2 * ((lane >> 3) & 1) + ((lane >> 2) & 1);
      if ((lane & 3) == 0 && a < 6) part[warp][c][a] = sum;
    }
    }
    __syncthreads();
    if (tid < 6 * cn) {
      const int c = tid / 6, a = tid % 6;
      double sum = 0.0;
      for (int w = 0; w < Kern::kWarps; ++w) sum += static_cast<double>(part[w][c][a]);
      k.tv.partial[static_cast<Index>(cand[c0 + c].entry) * 6 + a] = sum;
    }
    if (c0 + Kern::kForceChunk < nc) __syncthreads();  // part[] is reused by the next chunk
  }
}
#endif

#if defined(__CUDACC__)
// A copy of the kernel with its population strides and grid extents hidden
// from the optimiser: in a loop over tiles the compiler would form the 19
// direction offsets q * stride and the wrap limits once before the loop and
// hold them across every tile, which spills; formed per tile from the copy,
// they live as in the one-block kernel.
template <class Kern>
__device__ LBDEM_FORCEINLINE Kern per_tile(const Kern& k) {
  Kern c = k;
  asm volatile("" : "+l"(c.src.stride), "+l"(c.dst.stride), "+r"(c.g.nx), "+r"(c.g.ny), "+r"(c.g.nz), "+l"(c.g.nxy));
  return c;
}

// The persistent schedule (PsmFusedSchedule::Persistent): the same steps 1
// to 4 per tile, each block taking the tiles blockIdx.x, blockIdx.x +
// gridDim.x, ... of the launch box (x fastest, the order of the one-block-per-
// tile grid). Warp 0 runs the next tile's candidate chain while the block
// collides the current one, with asynchronous copies to shared memory (no
// registers held across the collision):
//   a. at the start of tile i: its candidates from the staged particle data
//      (candidate_from, at their rank), then the copy of tile i + 1's count and
//      list entries;
//   b. after warp 0's collision: ranks of tile i + 1's candidates (shuffles)
//      and the copy of their particle data, at their rank.
// The block's first barrier then waits on shared-memory work only. A tile with
// more than 32 candidates reads them after that barrier (the one-block path's
// way for long lists) and passes a second barrier.
// The per-cell arithmetic, the candidate order and the force sums are those of
// psm_fused_kernel: the results are the same bit for bit.
// Shared-memory reuse across tiles: every read of cand[] for tile i comes
// before the block's last barrier of tile i (the sums take their entry before
// it), so warp 0 may refill cand[] at the start of tile i + 1; the candidate
// count is double-buffered (tile_nc[parity]) because a tile without candidates
// has no barrier after the first.
template <int MinBlocks, class Kern>
__global__ void __launch_bounds__(Kern::kCells, MinBlocks) psm_fused_persistent_kernel(Kern k) {
  using R = typename Kern::R;
  using TileId = typename Kern::TileId;
  constexpr int kPre = 32;  // candidates staged ahead (warp 0's lanes)
  __shared__ FusedCand<R> cand[kFusedMaxCapacity];
  __shared__ R part[Kern::kWarps][Kern::kForceChunk][6];
  __shared__ R slot_eps[kFusedMaxSlots][Kern::kCells];
  __shared__ double raw[kPre][Kern::kRaw];  // staged particle data, at rank
  __shared__ int list_p[kPre], list_e[kPre], list_count;  // staged list entries of the next tile
  __shared__ int meta_p[kPre], meta_e[kPre], staged_nc;  // particle and entry, at rank; its candidates
  __shared__ int tile_nc[2];
  int lane = static_cast<int>(threadIdx.x) & 31, warp = static_cast<int>(threadIdx.x) >> 5;  // set again per tile
  const unsigned ntile = static_cast<unsigned>(k.tiles.size());
  const unsigned ex0 = static_cast<unsigned>(k.tiles.ext[0]), ex1 = static_cast<unsigned>(k.tiles.ext[1]);
  auto tile_at = [&](unsigned b) {
    const unsigned q = b / ex0, bz = q / ex1;
    const int ix = static_cast<int>(b - q * ex0) + k.tiles.lo[0], iy = static_cast<int>(q - bz * ex1) + k.tiles.lo[1],
              iz = static_cast<int>(bz) + k.tiles.lo[2];
    return TileId{ix + static_cast<Index>(k.tv.ntx) * (iy + static_cast<Index>(k.tv.nty) * iz), ix, iy, iz};
  };
  // (warp 0) Copies tile t's count and first kPre list entries into shared memory.
  auto stage_list = [&](const TileId& t) {
    const Index base = t.linear * k.tv.capacity;
    if (lane < k.tv.capacity) {
      __pipeline_memcpy_async(&list_p[lane], k.tv.particle + base + lane, sizeof(int));
      __pipeline_memcpy_async(&list_e[lane], k.tv.entry + base + lane, sizeof(int));
    }
    if (lane == 0) __pipeline_memcpy_async(&list_count, k.tv.count + t.linear, sizeof(int));
    __pipeline_commit();
  };
  // (warp 0) Once the staged list is in: ranks by particle index and copies
  // each candidate's particle data to its rank's row.
  auto stage_candidates = [&]() {
    __pipeline_wait_prior(0);
    __syncwarp();
    const int cnt = list_count;
    const int nc = cnt < k.tv.capacity ? cnt : k.tv.capacity;
    if (nc <= kPre) {
      const int pi = lane < nc ? list_p[lane] : 0, ei = lane < nc ? list_e[lane] : 0;
      int r = 0;
      for (int j = 0; j < nc; ++j) r += __shfl_sync(0xffffffffu, pi, j) < pi ? 1 : 0;
      if (lane < nc) {
        meta_p[r] = pi;
        meta_e[r] = ei;
        LBDEM_UNROLL
        for (int a = 0; a < Kern::kRaw; ++a) {
          const double* src = k.raw_source(pi, a);
          if (src) __pipeline_memcpy_async(&raw[r][a], src, sizeof(double));
          else raw[r][a] = 0.0;
        }
      }
      __pipeline_commit();
    }
    if (lane == 0) staged_nc = nc;
  };
  // (warp 0) The staged candidates of tile t into cand[], their count into tile_nc[par].
  auto unstage = [&](const TileId& t, int par) {
    __pipeline_wait_prior(0);
    __syncwarp();
    const int nc = staged_nc;
    if (nc <= kPre && lane < nc) k.candidate_from(t, meta_p[lane], meta_e[lane], raw[lane], cand[lane]);
    if (lane == 0) tile_nc[par] = nc;
  };
  unsigned b = blockIdx.x;
  if (b >= ntile) return;
  if (warp == 0) {
    stage_list(tile_at(b));
    stage_candidates();
  }
  for (int par = 0; b < ntile; b += gridDim.x, par ^= 1) {
    // The thread's index hidden from the optimiser as well: what derives from
    // it (cell offsets, sum indices) is formed per tile, not held across tiles.
    int tid = static_cast<int>(threadIdx.x);
    asm volatile("" : "+r"(tid));
    lane = tid & 31;
    warp = tid >> 5;
    const TileId tile = tile_at(b);
    int x, y, z;
    bool fluid = k.coords(tile, tid, x, y, z);
    const Index cell = fluid ? k.g.index(x, y, z) : 0;
    if constexpr (Kern::kBnd) fluid = fluid && k.flags[cell] == 0;
    // 1. Populations first, then this tile's candidates (staged) and the next tile's list.
    lbm::Neighbours nb;
    R f[Kern::kQ];
    if (fluid) per_tile(k).load(x, y, z, cell, nb, f);
    if (warp == 0) {
      unstage(tile, par);
      if (b + gridDim.x < ntile) stage_list(tile_at(b + gridDim.x));
    }
    __syncthreads();
    const int nc = tile_nc[par];
    if (nc > kPre) {  // a long list: read here, as the one-block path does
      if (tid < nc) k.load_candidate(tile, tid, cand[k.rank(tile.linear, nc, tid)]);
      __syncthreads();
    }
    // 2. Slots, B and solid moments of this cell.
    FusedSolid<R> s;
    s.eps = &slot_eps[0][tid];
    s.stride = Kern::kCells;
    int lx, ly, lz;
    Kern::local(tid, lx, ly, lz);
    if (fluid && nc > 0) k.overlap(lx, ly, lz, cell, cand, nc, s);
    // 3. Collide and store.
    const bool plain = !__any_sync(0xffffffffu, s.m > 0);
    R rho = R(1), u[3] = {R(0), R(0), R(0)};
    if (fluid) {
      const Kern kt = per_tile(k);
      kt.collide_store(cell, lbm::neighbours_at<typename Kern::Lattice>(kt.g, x, y, z), f, s, plain, rho, u);
    }
    if (warp == 0 && b + gridDim.x < ntile) stage_candidates();
    if (nc == 0) continue;  // block-uniform
    // 4. Force and torque per candidate, as psm_fused_kernel.
    for (int c0 = 0; c0 < nc; c0 += Kern::kForceChunk) {
      const int cn = nc - c0 < Kern::kForceChunk ? nc - c0 : Kern::kForceChunk;
      if (plain) {
        if (lane == 0)
          for (int c = 0; c < cn; ++c)
            for (int a = 0; a < 6; ++a) part[warp][c][a] = R(0);
      } else {
        for (int c = 0; c < cn; ++c) {
          const int ks = fluid ? Kern::slot_of(s, c0 + c) : -1;
          const bool any = __any_sync(0xffffffffu, ks >= 0);
          R v[6] = {R(0), R(0), R(0), R(0), R(0), R(0)};
          R sum = R(0);
          if (any) {
            if (ks >= 0) k.contribution(lx, ly, lz, s, ks, cand[c0 + c], rho, u, v);
            sum = warp_sum6_exchange(v, lane);
          }
          const int a = 4 * ((lane >> 4) & 1) + 2 * ((lane >> 3) & 1) + ((lane >> 2) & 1);
          if ((lane & 3) == 0 && a < 6) part[warp][c][a] = sum;
        }
      }
      const bool summer = tid < 6 * cn;
      const int sc = tid / 6, sa = tid % 6;
      const int entry = summer ? cand[c0 + sc].entry : 0;  // before the barrier: cand[] is refilled after it
      __syncthreads();
      if (summer) {
        double sum = 0.0;
        for (int w = 0; w < Kern::kWarps; ++w) sum += static_cast<double>(part[w][sc][sa]);
        k.tv.partial[static_cast<Index>(entry) * 6 + sa] = sum;
      }
      if (c0 + Kern::kForceChunk < nc) __syncthreads();
    }
  }
}

// Blocks of the persistent grid: as many as the device holds at once (once
// per kernel instantiation and process), or `blocks` when given; at most one
// per tile.
template <int MinBlocks, class Kern>
unsigned persistent_grid(Index tiles, int blocks) {
  static const int resident = [] {
    int dev = 0, sms = 0, per_sm = 0;
    LBDEM_CUDA_CHECK(cudaGetDevice(&dev));
    LBDEM_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev));
    LBDEM_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, psm_fused_persistent_kernel<MinBlocks, Kern>,
                                                                   Kern::kCells, 0));
    return sms * (per_sm > 0 ? per_sm : 1);
  }();
  const Index want = blocks > 0 ? blocks : resident;
  return static_cast<unsigned>(want < tiles ? want : tiles);
}
#endif

template <class Kern>
void launch_fused(const Exec& ex, const Kern& k, PsmFusedSchedule schedule = PsmFusedSchedule::Block,
                  int persistent_blocks = 0) {
  if (ex.on_device()) {
#if defined(__CUDACC__)
    // Blocks of 256 per multiprocessor: 4 in fp32 (64 registers), 2 in fp64.
    // More blocks leave too few registers: the kernel spills and runs slower.
    constexpr int kMinBlocks = (sizeof(typename Kern::R) == 4 ? 4 : 2) * 256 / Kern::kCells;
    if (k.tiles.empty()) return;
    if (schedule == PsmFusedSchedule::Persistent) {
      using T = typename Kern::Stored;
      if constexpr (Kern::Dim == 3 && (std::is_same_v<T, float> || std::is_same_v<T, double>)) {
        if (k.tiles.size() > static_cast<Index>(INT32_MAX))
          throw ConfigError("psm fused step: " + std::to_string(k.tiles.size()) +
                            " tiles exceed the persistent schedule's 32-bit tile index");
        const unsigned grid = persistent_grid<kMinBlocks, Kern>(k.tiles.size(), persistent_blocks);
        psm_fused_persistent_kernel<kMinBlocks><<<grid, Kern::kCells, 0, ex.stream()>>>(k);
        LBDEM_CUDA_CHECK(cudaGetLastError());
        return;
      } else {
        throw ConfigError("LBDEM_PSM_FUSED_SCHEDULE = persistent: the persistent fused kernel is built for D3Q19 "
                          "in fp32 and fp64 only; unset it (block) for this lattice and precision");
      }
    }
    if (k.tiles.ext[1] > 65535 || k.tiles.ext[2] > 65535)
      throw ConfigError("psm fused step: " + std::to_string(k.tiles.ext[1]) + " x " + std::to_string(k.tiles.ext[2]) +
                        " tiles along y and z exceed the launch grid (65535 each); use psm.pipeline: mapped");
    const dim3 grid(static_cast<unsigned>(k.tiles.ext[0]), static_cast<unsigned>(k.tiles.ext[1]),
                    static_cast<unsigned>(k.tiles.ext[2]));
    psm_fused_kernel<kMinBlocks><<<grid, Kern::kCells, 0, ex.stream()>>>(k);
    LBDEM_CUDA_CHECK(cudaGetLastError());
    return;
#else
    (void)schedule;
    (void)persistent_blocks;
    throw_not_compiled_for_cuda("psm fused step");
#endif
  }
  run_fused_host(k);
}

struct FusedArgs {
  const lbm::LbmSetup* setup;
  const lbm::LbmRaw* raw;
  TileView tv;
  CellBox tiles;  // box of tiles to update
  SphereView p;
  const PsmOptions* opt;
  const float* table;  // table values on the Exec's backend (Table method)
  int K;
};

template <class L, class T, lbm::StreamKind S, int P, bool B, bool Force, PsmVariant V, FractionMethod M>
void fused_launch(const Exec& ex, const FusedArgs& a) {
  using Frac = FractionOf<L::D, M, PointerTableAccess, lbm::compute_t<T>>;  // fractions in the lattice's compute precision
  PsmFusedKernel<L, T, S, P, B, Force, V, Frac> k;
  k.set_lattice(*a.raw, a.setup->tau, a.opt->weight, a.opt->body_force_on_solid, a.opt->even_relaxation);
  k.K = a.K;
  k.tv = a.tv;
  k.tiles = a.tiles;
  for (int d = 0; d < 3; ++d) {
    k.own_lo[d] = a.raw->owned.lo[d];
    k.own_hi[d] = a.raw->owned.lo[d] + a.raw->owned.ext[d];
  }
  k.p = a.p;
  k.frac = Frac{};
  k.frac.linear_normalised = a.opt->map.linear_normalised;
  if (M == FractionMethod::Table) {
    k.frac.g = a.opt->map.table->geometry;
    k.frac.tab.p = a.table;
  }
  if (a.tv.t.tx != k.kTX || a.tv.t.ty != k.kTY || a.tv.t.tz != k.kTZ)
    throw ConfigError("psm fused step: the tile map's tiles are not the kernel's " + std::to_string(k.kTX) + "x" +
                      std::to_string(k.kTY) + "x" + std::to_string(k.kTZ));
  launch_fused(ex, k, a.opt->fused_schedule, a.opt->persistent_blocks);
}

template <class L, class T>
void fused_step_typed(const Exec& ex, const FusedArgs& a) {
  const FractionMethod m = a.opt->map.method;
  if (m != FractionMethod::Table && m != FractionMethod::Linear)
    throw ConfigError("psm fused step: the fused pipeline evaluates table or linear fractions, not exact");
  lbm::dispatch_step(a.setup->streaming, a.raw->step, a.raw->has_boundaries, lbm::has_body_force(a.raw->body_force),
                     [&](auto S, auto P, auto B, auto F) {
                       dispatch_variant(a.opt->variant, [&](auto V) {
                         constexpr auto s = decltype(S)::value;
                         constexpr int p = decltype(P)::value;
                         constexpr bool b = decltype(B)::value, f = decltype(F)::value;
                         constexpr PsmVariant v = decltype(V)::value;
                         if (m == FractionMethod::Table) fused_launch<L, T, s, p, b, f, v, FractionMethod::Table>(ex, a);
                         else fused_launch<L, T, s, p, b, f, v, FractionMethod::Linear>(ex, a);
                       });
                     });
}

}  // namespace lbdem::imb
