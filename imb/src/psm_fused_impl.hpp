#pragma once
// The fused PSM step as a CUDA kernel (one block per tile) and its dispatch:
// runtime choices -> template parameters, instantiated per (lattice,
// precision) in psm_fused_*.cu. The per-cell physics is in imb/psm_fused.hpp.
#include "core/exec.hpp"
#include "imb/psm_coupling.hpp"
#include "imb/psm_fused.hpp"
#include "lbm/dispatch.hpp"

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

template <class Kern>
void launch_fused(const Exec& ex, const Kern& k) {
  if (ex.on_device()) {
#if defined(__CUDACC__)
    // Blocks of 256 per multiprocessor: 4 in fp32 (64 registers), 2 in fp64.
    // More blocks leave too few registers: the kernel spills and runs slower.
    constexpr int kMinBlocks = (sizeof(typename Kern::R) == 4 ? 4 : 2) * 256 / Kern::kCells;
    if (k.tiles.empty()) return;
    if (k.tiles.ext[1] > 65535 || k.tiles.ext[2] > 65535)
      throw ConfigError("psm fused step: " + std::to_string(k.tiles.ext[1]) + " x " + std::to_string(k.tiles.ext[2]) +
                        " tiles along y and z exceed the launch grid (65535 each); use psm.pipeline: mapped");
    const dim3 grid(static_cast<unsigned>(k.tiles.ext[0]), static_cast<unsigned>(k.tiles.ext[1]),
                    static_cast<unsigned>(k.tiles.ext[2]));
    psm_fused_kernel<kMinBlocks><<<grid, Kern::kCells, 0, ex.stream()>>>(k);
    LBDEM_CUDA_CHECK(cudaGetLastError());
    return;
#else
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
  launch_fused(ex, k);
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
