#pragma once
// Contact-force kernel bodies: per-particle loads and walls, the
// particle-parallel path, and the three stages of the pair path. Include only
// from kernel translation units (*.cu).
#include "atomics.hpp"
#include "kernels.hpp"
#include "state.hpp"

namespace lbdem::dem {

// ------------------------------------------------------------------- forces
// Body force, gravity, coupling input and walls on particle i.
template <bool Friction>
LBDEM_HD LBDEM_FORCEINLINE void particle_forces(const State& s, Index i, const Real4& p, const Real4& v,
                                                const Real4& w, Vec3d& F, Vec3d& T) {
  const double m = 1.0 / v.w;
  F = s.body + s.gravity * m;
  T = Vec3d{};
  if (s.extf) {
    F += xyz(s.extf[i]);
    T += xyz(s.extt[i]);
  }
  // Friction: wall k's history is read one wall ahead, before wall k - 1's is
  // written (another row of whist: the same values), so the reads overlap.
  Vec3d wh{};
  if constexpr (Friction)
    if (s.walls.count > 0) wh = s.whist[i];
  for (int k = 0; k < s.walls.count; ++k) {
    const Wall& wl = s.walls.w[k];
    const double h = dot(xyz(p) - wl.point, wl.normal);
    const double delta = p.w - h;
    Vec3d* xi = Friction ? &s.whist[k * s.n + i] : nullptr;
    Vec3d wh_next{};
    if constexpr (Friction)
      if (k + 1 < s.walls.count) wh_next = s.whist[(k + 1) * s.n + i];
    if (delta > 0.0) {
      const Vec3d nv = -wl.normal;  // towards the wall
      Vec3d vrel = xyz(v);
      Vec3d hist{}, ft{};
      if constexpr (Friction) {
        vrel += cross(xyz(w) * p.w, nv);
        hist = wh;
      }
      F += contact_force<Friction>(s.pw, nv, delta, m, vrel, hist, s.dt, ft);
      if constexpr (Friction) {
        T += cross(nv * p.w, ft);
        *xi = hist;
      }
    } else if constexpr (Friction) {
      if (wh.x != 0.0 || wh.y != 0.0 || wh.z != 0.0) *xi = Vec3d{};
    }
    wh = wh_next;
  }
}

// Slot `slot` (partner j at pj) of particle i's contact sum: the contact force
// and torque added to F and T when the spheres overlap; else a stale
// tangential history is cleared. Both particle-path kernels use it.
template <bool Friction>
LBDEM_HD LBDEM_FORCEINLINE void slot_contact(const State& s, const Real4& p, const Real4& v, const Real4& w, Index slot,
                                             int j, const Real4& pj, Vec3d& F, Vec3d& T) {
  const Vec3d d = s.box.min_image(xyz(pj) - xyz(p));
  const double rs = p.w + pj.w;
  const double d2 = dot(d, d);
  if (d2 < rs * rs) {
    const double dist = sqrt(d2);
    const Vec3d nv = d * (1.0 / dist);
    const Real4 vj = s.vpr[j];
    const double meff = 1.0 / (v.w + vj.w);
    Vec3d vrel = xyz(v) - xyz(vj);
    Vec3d hist{}, ft{};
    if constexpr (Friction) {
      const Real4 wj = s.wpr[j];
      vrel += cross(xyz(w) * p.w + xyz(wj) * pj.w, nv);
      hist = s.hist[slot];
    }
    F += contact_force<Friction>(s.pp, nv, rs - dist, meff, vrel, hist, s.dt, ft);
    if constexpr (Friction) {
      T += cross(nv * p.w, ft);
      s.hist[slot] = hist;
    }
  } else if constexpr (Friction) {
    const Vec3d h = s.hist[slot];
    if (h.x != 0.0 || h.y != 0.0 || h.z != 0.0) s.hist[slot] = Vec3d{};
  }
}

// Adds to F and T the contacts of particle i in its list slots first, first +
// stride, ... below cnt, in that order. The next partner's index and position
// are read before this contact's history is written (neither array is written
// by the force kernels, so the values are those of a read after it): the
// device overlaps their memory latency with this contact's work instead of
// waiting for them at the top of each iteration.
template <bool Friction>
LBDEM_HD LBDEM_FORCEINLINE void list_contacts(const State& s, Index i, const Real4& p, const Real4& v, const Real4& w,
                                              int cnt, int first, int stride, Vec3d& F, Vec3d& T) {
  int j = 0;
  Real4 pj{0, 0, 0, 0};
  if (first < cnt) {
    j = s.nbr[first * s.n + i];
    pj = s.pos[j];
  }
  for (int q = first; q < cnt; q += stride) {
    const Index slot = q * s.n + i;
    int j_next = 0;
    Real4 p_next{0, 0, 0, 0};
    if (q + stride < cnt) {
      j_next = s.nbr[slot + stride * s.n];
      p_next = s.pos[j_next];
    }
    slot_contact<Friction>(s, p, v, w, slot, j, pj, F, T);
    j = j_next;
    pj = p_next;
  }
}

// Particle i's own values that its contact sums read: position and radius,
// predicted velocity and 1/m, predicted angular velocity and 1/I (zero
// without friction). Every particle-path force kernel loads them here.
struct ParticleLoad {
  Real4 p, v, w;
};
template <bool Friction>
LBDEM_HD LBDEM_FORCEINLINE ParticleLoad load_particle(const State& s, Index i) {
  ParticleLoad l{s.pos[i], s.vpr[i], Real4{0, 0, 0, 0}};
  if constexpr (Friction) l.w = s.wpr[i];
  return l;
}

// Stores particle i's force and torque sums (the torque with friction only)
// and returns them in f and t, the records a kick-drift takes.
template <bool Friction>
LBDEM_HD LBDEM_FORCEINLINE void store_forces(const State& s, Index i, const Vec3d& F, const Vec3d& T, Real4& f,
                                             Real4& t) {
  f = Real4{F.x, F.y, F.z, 0.0};
  t = Real4{0, 0, 0, 0};
  s.frc[i] = f;
  if constexpr (Friction) {
    t = Real4{T.x, T.y, T.z, 0.0};
    s.trq[i] = t;
  }
}

// Particle i's whole force evaluation on one thread (walls, body force,
// coupling input, then its list in order), stored, and returned in f and t;
// returns the particle's position as loaded. The body of ForceParticle and
// the force part of ForceKickDrift.
template <bool Friction>
LBDEM_HD LBDEM_FORCEINLINE Real4 particle_sum(const State& s, Index i, Real4& f, Real4& t) {
  const ParticleLoad l = load_particle<Friction>(s, i);
  Vec3d F, T;
  particle_forces<Friction>(s, i, l.p, l.v, l.w, F, T);
  list_contacts<Friction>(s, i, l.p, l.v, l.w, s.ncount[i], 0, 1, F, T);
  store_forces<Friction>(s, i, F, T, f, t);
  return l.p;
}

// Particle-parallel: particle i sums all its contacts over its full list.
// Deterministic: fixed summation order, no atomics.
template <bool Friction>
struct ForceParticle {
  State s;
  LBDEM_HD void operator()(Index i) const {
    Real4 f, t;
    (void)particle_sum<Friction>(s, i, f, t);
  }
};

// The fused sub-step (dem/README.md, "Fused sub-steps"): the forces of the
// state in k.s, exactly as ForceParticle computes and stores them, then the
// next sub-step's kick-drift of the same particle from those forces still in
// registers (KickDrift::step). The forces of other particles read this
// state's positions and predicted velocities (k.s.pos, k.s.vpr, k.s.wpr), so
// the kick-drift writes its positions and predictors into the other copies
// (pos_out, vpr_out, wpr_out), which the store then swaps in. Every other
// array the kick-drift writes (vel, omg) is particle i's own and read by no
// force of another particle. The arithmetic is that of the two kernels run
// one after the other (the same inline functions: particle_sum, then
// KickDrift::step), and the kernel translation units are compiled without
// contraction of a * b + c into one fused multiply-add (dem/CMakeLists.txt):
// with it, the device compiler chooses which products to fuse from each
// kernel's whole body, so the same expressions in the fused and the separate
// kernels could round differently. The same bits.
template <bool Friction>
struct ForceKickDrift {
  KickDrift<Friction> k;
  Real4 *pos_out, *vpr_out, *wpr_out;
  LBDEM_HD void operator()(Index i) const {
    Real4 f, t;
    const Real4 p = particle_sum<Friction>(k.s, i, f, t);
    k.step(i, p, f, t, pos_out, vpr_out, wpr_out);
  }
};

#if defined(__CUDACC__)
// Particle-parallel with L lanes per particle (State::lanes, DemParams::
// force_lanes): lane l sums the list slots l, l + L, ... and lane 0 also the
// body force and the walls; the L partial sums are then added by a butterfly
// of warp shuffles (a fixed order: every lane ends with the same bits, and a
// run is deterministic). For small systems (a bed of ~10^4 particles is a few
// warps per multiprocessor) this divides the dependent chain of list loads by
// L and gives the device L times the warps to hide their latency. The sums
// differ from ForceParticle's sequential order by rounding only.
// Particle i's forces summed by its L lanes (lane = t % L of thread t):
// every lane of the warp must call it (the shuffles), i >= n included; F and
// T end with the same bits in every lane of a particle.
template <bool Friction, int L>
__device__ __forceinline__ void lanes_forces(const State& s, Index n, Index i, int lane, Vec3d& F, Vec3d& T) {
  static_assert(L >= 2 && L <= 32 && (L & (L - 1)) == 0, "lanes: a power of two up to a warp");
  F = Vec3d{};
  T = Vec3d{};
  if (i < n) {  // no early return: every lane of the warp takes part in the shuffles
    const ParticleLoad l = load_particle<Friction>(s, i);
    if (lane == 0) particle_forces<Friction>(s, i, l.p, l.v, l.w, F, T);
    list_contacts<Friction>(s, i, l.p, l.v, l.w, s.ncount[i], lane, L, F, T);
  }
#pragma unroll
  for (int off = L / 2; off > 0; off >>= 1) {
    F.x += __shfl_xor_sync(0xffffffffu, F.x, off);
    F.y += __shfl_xor_sync(0xffffffffu, F.y, off);
    F.z += __shfl_xor_sync(0xffffffffu, F.z, off);
    if constexpr (Friction) {
      T.x += __shfl_xor_sync(0xffffffffu, T.x, off);
      T.y += __shfl_xor_sync(0xffffffffu, T.y, off);
      T.z += __shfl_xor_sync(0xffffffffu, T.z, off);
    }
  }
}

template <bool Friction, int L>
__global__ void __launch_bounds__(256) force_lanes_kernel(const State s, Index n) {
  const Index t = static_cast<Index>(blockIdx.x) * blockDim.x + threadIdx.x;
  const Index i = t / L;
  const int lane = static_cast<int>(t % L);
  Vec3d F, T;
  lanes_forces<Friction, L>(s, n, i, lane, F, T);
  if (i < n && lane == 0) {
    Real4 f, tq;
    store_forces<Friction>(s, i, F, T, f, tq);
  }
}

// ForceKickDrift with L lanes per particle: the lanes' forces as
// force_lanes_kernel sums them, then lane 0 stores them and runs the
// particle's kick-drift.
template <bool Friction, int L>
__global__ void __launch_bounds__(256) force_lanes_kick_drift_kernel(const ForceKickDrift<Friction> fk, Index n) {
  const Index t = static_cast<Index>(blockIdx.x) * blockDim.x + threadIdx.x;
  const Index i = t / L;
  const int lane = static_cast<int>(t % L);
  const State& s = fk.k.s;
  Vec3d F, T;
  lanes_forces<Friction, L>(s, n, i, lane, F, T);
  if (i < n && lane == 0) {
    Real4 f, tq;
    store_forces<Friction>(s, i, F, T, f, tq);
    fk.k.step(i, s.pos[i], f, tq, fk.pos_out, fk.vpr_out, fk.wpr_out);
  }
}
#endif

// Pair path, stage 1: per-particle forces (body, walls) and the number of
// overlapping partners j > i (resets the history of non-touching ones).
template <bool Friction>
struct PairInit {
  State s;
  int* ccount;
  LBDEM_HD void operator()(Index i) const {
    const ParticleLoad l = load_particle<Friction>(s, i);
    const Real4& p = l.p;
    Vec3d F, T;
    particle_forces<Friction>(s, i, l.p, l.v, l.w, F, T);
    Real4 f, t;
    store_forces<Friction>(s, i, F, T, f, t);
    int c = 0;
    const int cnt = s.ncount[i];
    for (int q = 0; q < cnt; ++q) {
      const Index slot = q * s.n + i;
      const int j = s.nbr[slot];
      if (j < i) continue;
      const Real4 pj = s.pos[j];
      const Vec3d d = s.box.min_image(xyz(pj) - xyz(p));
      const double rs = p.w + pj.w;
      if (dot(d, d) < rs * rs) ++c;
      else if constexpr (Friction) {
        const Vec3d h = s.hist[slot];
        if (h.x != 0.0 || h.y != 0.0 || h.z != 0.0) s.hist[slot] = Vec3d{};
      }
    }
    ccount[i] = c;
  }
};

// Stage 2 (after the exclusive scan): write the compacted pairs. pairs[k].j
// holds the list slot q (the partner is nbr[q * n + i]) so the history is found.
struct PairFill {
  State s;
  const int* coffs;
  PairIJ* pairs;
  LBDEM_HD void operator()(Index i) const {
    int k = coffs[i];
    const Real4 p = s.pos[i];
    const int cnt = s.ncount[i];
    for (int q = 0; q < cnt; ++q) {
      const int j = s.nbr[q * s.n + i];
      if (j < i) continue;
      const Real4 pj = s.pos[j];
      const Vec3d d = s.box.min_image(xyz(pj) - xyz(p));
      const double rs = p.w + pj.w;
      if (dot(d, d) < rs * rs) pairs[k++] = PairIJ{static_cast<int>(i), q};
    }
  }
};

// Stage 3: one pair per thread (grid-stride over the device-held total), the
// force added to both particles with atomics.
template <bool Friction>
struct PairForce {
  State s;
  const PairIJ* pairs;
  const int* total;
  Index workers;
  LBDEM_HD void operator()(Index w0) const {
    const Index np = *total;
    for (Index k = w0; k < np; k += workers) {
      const PairIJ pr = pairs[k];
      const Index i = pr.i;
      const Index slot = static_cast<Index>(pr.j) * s.n + i;
      const int j = s.nbr[slot];
      const Real4 p = s.pos[i], pj = s.pos[j];
      const Real4 v = s.vpr[i], vj = s.vpr[j];
      const Vec3d d = s.box.min_image(xyz(pj) - xyz(p));
      const double rs = p.w + pj.w;
      const double dist = sqrt(dot(d, d));
      const Vec3d nv = d * (1.0 / dist);
      const double meff = 1.0 / (v.w + vj.w);
      Vec3d vrel = xyz(v) - xyz(vj);
      Vec3d hist{}, ft{};
      if constexpr (Friction) {
        vrel += cross(xyz(s.wpr[i]) * p.w + xyz(s.wpr[j]) * pj.w, nv);
        hist = s.hist[slot];
      }
      const Vec3d f = contact_force<Friction>(s.pp, nv, rs - dist, meff, vrel, hist, s.dt, ft);
      detail::atomic_add(&s.frc[i].x, f.x);
      detail::atomic_add(&s.frc[i].y, f.y);
      detail::atomic_add(&s.frc[i].z, f.z);
      detail::atomic_add(&s.frc[j].x, -f.x);
      detail::atomic_add(&s.frc[j].y, -f.y);
      detail::atomic_add(&s.frc[j].z, -f.z);
      if constexpr (Friction) {
        s.hist[slot] = hist;
        const Vec3d ti = cross(nv * p.w, ft);
        const Vec3d tj = cross(nv * pj.w, ft);
        detail::atomic_add(&s.trq[i].x, ti.x);
        detail::atomic_add(&s.trq[i].y, ti.y);
        detail::atomic_add(&s.trq[i].z, ti.z);
        detail::atomic_add(&s.trq[j].x, tj.x);
        detail::atomic_add(&s.trq[j].y, tj.y);
        detail::atomic_add(&s.trq[j].z, tj.z);
      }
    }
  }
};

}  // namespace lbdem::dem
