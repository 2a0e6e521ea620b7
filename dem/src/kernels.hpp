#pragma once
// DEM kernel bodies: small trivially-copyable functors run by for_each on
// either backend. Include only from kernel translation units (*.cu).
#include <cstdint>

#include "atomics.hpp"
#include "core/exec.hpp"
#include "core/hd.hpp"
#include "dem/contact.hpp"
#include "dem/geometry.hpp"
#include "dem/particle_view.hpp"

namespace lbdem::dem {

struct PairIJ {
  int i, j;
};

// Everything a per-particle or per-pair kernel reads, by pointer.
struct State {
  Real4 *pos, *vel, *omg, *frc, *trq;
  Real4 *frc_old, *trq_old;  // forces of the previous step (velocity predictor)
  Real4 *vpr, *wpr;          // predicted velocity / angular velocity at the force time (w: 1/m, 1/I)
  const Real4 *extf, *extt;  // null when no coupling input
  Real4* x0;                 // positions at the last build
  const std::int64_t* gid;
  int* nbr;
  int* ncount;
  Vec3d* hist;   // [s * n + i] tangential history (friction)
  Vec3d* whist;  // [w * n + i]
  Index n;
  int cap;
  Box box;
  Walls walls;
  ContactLaw pp, pw;
  Vec3d gravity, body;
  double dt, half_skin2, skin;
  int* flags;  // [0] neighbour list overflow, [1] largest neighbour count seen (list build)
};

// What the host needs for its rebuild decisions (system.cu, "Rebuild
// decisions"), reduced over the particles on the device and copied to the
// host asynchronously. Values are squares, as float bits rounded up
// (detail::float_bits_up), so that an integer atomic max reduces them.
struct StatusRecord {
  std::uint32_t disp2 = 0;   // max |x - x0|^2 at the report step (x0: position at the last build) [m^2]
  std::uint32_t speed2 = 0;  // max |v|^2 (the velocity of the report step's drift) [m^2/s^2]
  std::uint32_t accel2 = 0;  // max |F/m|^2 (the force of its kick, all contributions) [m^2/s^4]
  // Largest |x - x0|^2 above (skin/2)^2 seen at a step that did not rebuild,
  // since the previous report; 0: none. Lookahead: the list was stale (an
  // error); every-step check: the rebuild request of this step.
  std::uint32_t over2 = 0;
};

// One particle's contribution to a report.
LBDEM_HD LBDEM_FORCEINLINE void report_particle(StatusRecord* rec, double d2, const Real4& v, const Real4& f) {
  const double a2 = (f.x * f.x + f.y * f.y + f.z * f.z) * (v.w * v.w);  // v.w = 1/m
  detail::atomic_max_u32(&rec->disp2, detail::float_bits_up(d2));
  detail::atomic_max_u32(&rec->speed2, detail::float_bits_up(v.x * v.x + v.y * v.y + v.z * v.z));
  detail::atomic_max_u32(&rec->accel2, detail::float_bits_up(a2));
}

// Uniform cell grid over the box; cells at least the largest cutoff wide.
struct Grid {
  double lo[3];
  double inv_cl[3];
  int nc[3];
  int periodic[3];
  LBDEM_HD int coord(double x, int k) const {
    int c = static_cast<int>(floor((x - lo[k]) * inv_cl[k]));
    return c < 0 ? 0 : (c >= nc[k] ? nc[k] - 1 : c);
  }
  LBDEM_HD std::uint32_t cell(const Real4& p) const {
    return static_cast<std::uint32_t>(coord(p.x, 0) + nc[0] * (coord(p.y, 1) + nc[1] * coord(p.z, 2)));
  }
};

// ---------------------------------------------------------------- integration
// Velocity Verlet with a velocity predictor for the velocity-dependent
// contact forces (dashpot, tangential slip):
//   v_{n+1/2} = v_n + dt/2 a_n,  x_{n+1} = x_n + dt v_{n+1/2},
//   forces at x_{n+1} and v~_{n+1} = v_{n+1/2} + dt/2 (2 a_n - a_{n-1}),
//   v_{n+1} = v_{n+1/2} + dt/2 a_{n+1}.
// The predictor extrapolates the acceleration linearly, so v~ is third-order
// accurate and the dashpot impulse error drops to the level of the spring's
// (a first-order predictor v_{n+1/2} + dt/2 a_n leaves 0.6 % restitution
// error at e = 0.1, t_c/50; this one ~0.1 %). Without damping or friction the
// forces do not read v~ and this is plain velocity Verlet (symplectic).
// Between steps `vel` holds v_{n+1/2}: the closing half kick of one step and
// the opening half kick of the next are fused here (synced = 1 when `vel`
// holds v_n, at the start of advance()); `extrap` = 0 when a_{n-1} is not
// known (first step after a fresh force evaluation).
// Also the rebuild bookkeeping: with `check`, a particle displaced more than
// skin/2 since the last build is recorded in rec->over2; with `report`, the
// largest displacement, speed and acceleration go into *rec and the next
// ring slot is zeroed for the steps after this one (its previous contents
// were copied to the host by an earlier, stream-ordered copy).
template <bool Friction>
struct KickDrift {
  State s;
  int synced, extrap;
  StatusRecord* rec;   // the report being accumulated
  StatusRecord* next;  // the report after it (zeroed by particle 0 when `report`)
  int report;          // 1: record maxima into *rec (a report step)
  int check;           // 1: record displacements > skin/2 (no rebuild follows this step, or the every-step test)
  LBDEM_HD void operator()(Index i) const {
    Real4 v = s.vel[i];
    const Real4 f = s.frc[i];
    Real4 p = s.pos[i];
    const double h = 0.5 * s.dt * v.w;
    const double k1 = synced ? h : 2.0 * h;
    v.x += k1 * f.x; v.y += k1 * f.y; v.z += k1 * f.z;
    Vec3d x{p.x + s.dt * v.x, p.y + s.dt * v.y, p.z + s.dt * v.z};
    x = s.box.wrap(x);
    set_xyz(p, x);
    s.vel[i] = v;
    s.pos[i] = p;
    Real4 vp = v;
    if (extrap) {
      const Real4 fo = s.frc_old[i];
      vp.x += h * (2.0 * f.x - fo.x); vp.y += h * (2.0 * f.y - fo.y); vp.z += h * (2.0 * f.z - fo.z);
    } else {
      vp.x += h * f.x; vp.y += h * f.y; vp.z += h * f.z;
    }
    s.vpr[i] = vp;
    if constexpr (Friction) {
      Real4 w = s.omg[i];
      const Real4 t = s.trq[i];
      const double b = 0.5 * s.dt * w.w;
      const double b1 = synced ? b : 2.0 * b;
      w.x += b1 * t.x; w.y += b1 * t.y; w.z += b1 * t.z;
      s.omg[i] = w;
      Real4 wp = w;
      if (extrap) {
        const Real4 to = s.trq_old[i];
        wp.x += b * (2.0 * t.x - to.x); wp.y += b * (2.0 * t.y - to.y); wp.z += b * (2.0 * t.z - to.z);
      } else {
        wp.x += b * t.x; wp.y += b * t.y; wp.z += b * t.z;
      }
      s.wpr[i] = wp;
    }
    const Vec3d d = s.box.min_image(x - xyz(s.x0[i]));
    const double d2 = dot(d, d);
    if (check && d2 > s.half_skin2) detail::atomic_max_u32(&rec->over2, detail::float_bits_up(d2));
    if (report) {
      if (i == 0) *next = StatusRecord{};
      report_particle(rec, d2, v, f);
    }
  }
};

// A report of the current state outside the time loop (first advance()):
// displacement since the build, synchronised velocity, last force.
struct Report {
  State s;
  StatusRecord *rec, *next;
  LBDEM_HD void operator()(Index i) const {
    if (i == 0) *next = StatusRecord{};
    const Vec3d d = s.box.min_image(xyz(s.pos[i]) - xyz(s.x0[i]));
    report_particle(rec, dot(d, d), s.vel[i], s.frc[i]);
  }
};

// Closing half kick: v_{n+1} = v_{n+1/2} + dt/2 a_{n+1}.
template <bool Friction>
struct Kick {
  State s;
  LBDEM_HD void operator()(Index i) const {
    Real4 v = s.vel[i];
    const Real4 f = s.frc[i];
    const double h = 0.5 * s.dt * v.w;
    v.x += h * f.x; v.y += h * f.y; v.z += h * f.z;
    s.vel[i] = v;
    if constexpr (Friction) {
      Real4 w = s.omg[i];
      const Real4 t = s.trq[i];
      const double b = 0.5 * s.dt * w.w;
      w.x += b * t.x; w.y += b * t.y; w.z += b * t.z;
      s.omg[i] = w;
    }
  }
};

// Predictor = current (synchronised) velocities, for a force evaluation at
// the current state outside the time loop.
template <bool Friction>
struct SyncPredictor {
  State s;
  LBDEM_HD void operator()(Index i) const {
    s.vpr[i] = s.vel[i];
    if constexpr (Friction) s.wpr[i] = s.omg[i];
  }
};

// for_each, but tiny host problems run serially (an OpenMP region costs more
// than a two-particle step, and the verification tests are tiny).
template <class F>
void launch(const Exec& ex, Index n, const F& f) {
  if (!ex.on_device() && n < 4096) {
    for (Index i = 0; i < n; ++i) f(i);
    return;
  }
  for_each(ex, n, f);
}

// ------------------------------------------------------------------- cell list
struct CellKey {
  const Real4* pos;
  Grid g;
  std::uint32_t* key;
  int* idx;
  LBDEM_HD void operator()(Index i) const {
    key[i] = g.cell(pos[i]);
    idx[i] = static_cast<int>(i);
  }
};

// Empties the cells occupied at the previous build (keys still sorted from
// it): O(N) instead of O(cells), which matters for big, sparse boxes.
struct ClearCells {
  const std::uint32_t* old_key;
  int *start, *end;
  LBDEM_HD void operator()(Index i) const {
    const std::uint32_t c = old_key[i];
    start[c] = 0;
    end[c] = 0;
  }
};

// Sorted keys -> [start, end) of each occupied cell.
struct CellRange {
  const std::uint32_t* key;
  int *start, *end;
  Index n;
  LBDEM_HD void operator()(Index i) const {
    const std::uint32_t k = key[i];
    if (i == 0 || key[i - 1] != k) start[k] = static_cast<int>(i);
    if (i == n - 1 || key[i + 1] != k) end[k] = static_cast<int>(i + 1);
  }
};

// Reorders every per-particle array into cell order: dst[i] = src[perm[i]].
struct Gather {
  const int* perm;
  const Real4 *pos, *vel, *omg, *frc, *trq, *frco, *trqo, *vpr, *wpr, *extf, *extt;
  Real4 *pos2, *vel2, *omg2, *frc2, *trq2, *frco2, *trqo2, *vpr2, *wpr2, *extf2, *extt2;
  const std::int64_t* gid;
  std::int64_t* gid2;
  const int* type;
  int* type2;
  const Vec3d* whist;
  Vec3d* whist2;
  int nwalls;
  Index n;
  LBDEM_HD void operator()(Index i) const {
    const Index o = perm[i];
    pos2[i] = pos[o]; vel2[i] = vel[o]; omg2[i] = omg[o]; frc2[i] = frc[o]; trq2[i] = trq[o];
    frco2[i] = frco[o]; trqo2[i] = trqo[o]; vpr2[i] = vpr[o];
    if (wpr) wpr2[i] = wpr[o];
    if (extf) { extf2[i] = extf[o]; extt2[i] = extt[o]; }
    gid2[i] = gid[o];
    type2[i] = type[o];
    if (whist)
      for (int w = 0; w < nwalls; ++w) whist2[w * n + i] = whist[w * n + o];
  }
};

// Verlet list: every j with |x_j - x_i| < r_i + r_j + skin, scanning the 27
// (fewer on thin periodic axes) surrounding cells. With friction, each slot's
// history is looked up by partner global id in the previous list: in i's own
// old row, else in the partner's old row (negated, the pair path keeps only
// the i<j copy).
template <bool Friction>
struct BuildList {
  State s;
  Grid g;
  const int *cstart, *cend;
  // Previous list (friction): indexed by the old order.
  const int* perm;
  const int *nbr_prev, *ncount_prev;
  const Vec3d* hist_prev;
  const std::int64_t* gid_prev;
  int have_prev;
  int prev_full;  // 1: both copies valid (particle path); 0: only partner old index > own

  LBDEM_HD Vec3d lookup(Index i, Index j) const {
    const Index oi = perm[i], oj = perm[j];
    const std::int64_t gi = s.gid[i], gj = s.gid[j];
    const int ci = ncount_prev[oi];
    for (int q = 0; q < ci; ++q) {
      const int o = nbr_prev[q * s.n + oi];
      if ((prev_full || o > oi) && gid_prev[o] == gj) return hist_prev[q * s.n + oi];
    }
    const int cj = ncount_prev[oj];
    for (int q = 0; q < cj; ++q) {
      const int o = nbr_prev[q * s.n + oj];
      if ((prev_full || o > oj) && gid_prev[o] == gi) return -hist_prev[q * s.n + oj];
    }
    return Vec3d{};
  }

  LBDEM_HD void operator()(Index i) const {
    // Members into locals: the list stores are ints and would otherwise force
    // reloads of every int member (aliasing) in the inner loop.
    const Real4 pi = s.pos[i];
    const Vec3d xi = xyz(pi);
    const Real4* pos = s.pos;
    int* nbr = s.nbr;
    const Index n = s.n;
    const int cap = s.cap;
    const double skin = s.skin;
    const Box box = s.box;
    const int nc0 = g.nc[0], nc1 = g.nc[1], nc2 = g.nc[2];
    const int c[3] = {g.coord(pi.x, 0), g.coord(pi.y, 1), g.coord(pi.z, 2)};
    int lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      if (g.periodic[k] && g.nc[k] < 3) { lo[k] = 0; hi[k] = g.nc[k] - 1; }
      else { lo[k] = -1; hi[k] = 1; }
    }
    // Neighbour cell coordinate: wrapped on periodic axes (one compare: the
    // offset is at most one cell), -1 when outside a closed axis.
    auto wrap = [](int x, int nc, int per) {
      if (x < 0) return per ? x + nc : -1;
      if (x >= nc) return per ? x - nc : -1;
      return x;
    };
    int cnt = 0;
    for (int dz = lo[2]; dz <= hi[2]; ++dz) {
      const int cz = wrap(c[2] + dz, nc2, g.periodic[2]);
      if (cz < 0) continue;
      for (int dy = lo[1]; dy <= hi[1]; ++dy) {
        const int cy = wrap(c[1] + dy, nc1, g.periodic[1]);
        if (cy < 0) continue;
        const int row = nc0 * (cy + nc1 * cz);
        for (int dx = lo[0]; dx <= hi[0]; ++dx) {
          const int cx = wrap(c[0] + dx, nc0, g.periodic[0]);
          if (cx < 0) continue;
          const int cell = cx + row;
          const int e = cend[cell];
          for (int j = cstart[cell]; j < e; ++j) {
            if (j == i) continue;
            const Real4 pj = pos[j];
            const Vec3d d = box.min_image(xyz(pj) - xi);
            const double rc = pi.w + pj.w + skin;
            if (dot(d, d) < rc * rc) {
              if (cnt < cap) {
                nbr[cnt * n + i] = j;
                if constexpr (Friction) s.hist[cnt * n + i] = have_prev ? lookup(i, j) : Vec3d{};
              }
              ++cnt;
            }
          }
        }
      }
    }
    s.ncount[i] = cnt < cap ? cnt : cap;
    if (cnt > cap) {
      detail::atomic_set(&s.flags[0], 1);
      detail::atomic_max(&s.flags[1], cnt);
    }
    s.x0[i] = pi;
  }
};

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
  for (int k = 0; k < s.walls.count; ++k) {
    const Wall& wl = s.walls.w[k];
    const double h = dot(xyz(p) - wl.point, wl.normal);
    const double delta = p.w - h;
    Vec3d* xi = Friction ? &s.whist[k * s.n + i] : nullptr;
    if (delta > 0.0) {
      const Vec3d nv = -wl.normal;  // towards the wall
      Vec3d vrel = xyz(v);
      Vec3d hist{}, ft{};
      if constexpr (Friction) {
        vrel += cross(xyz(w) * p.w, nv);
        hist = *xi;
      }
      F += contact_force<Friction>(s.pw, nv, delta, m, vrel, hist, s.dt, ft);
      if constexpr (Friction) {
        T += cross(nv * p.w, ft);
        *xi = hist;
      }
    } else if constexpr (Friction) {
      if (xi->x != 0.0 || xi->y != 0.0 || xi->z != 0.0) *xi = Vec3d{};
    }
  }
}

// Particle-parallel: particle i sums all its contacts over its full list.
// Deterministic: fixed summation order, no atomics.
template <bool Friction>
struct ForceParticle {
  State s;
  LBDEM_HD void operator()(Index i) const {
    const Real4 p = s.pos[i];
    const Real4 v = s.vpr[i];
    Real4 w{0, 0, 0, 0};
    if constexpr (Friction) w = s.wpr[i];
    Vec3d F, T;
    particle_forces<Friction>(s, i, p, v, w, F, T);
    const int cnt = s.ncount[i];
    for (int q = 0; q < cnt; ++q) {
      const Index slot = q * s.n + i;
      const int j = s.nbr[slot];
      const Real4 pj = s.pos[j];
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
    s.frc[i] = Real4{F.x, F.y, F.z, 0.0};
    if constexpr (Friction) s.trq[i] = Real4{T.x, T.y, T.z, 0.0};
  }
};

// Pair path, stage 1: per-particle forces (body, walls) and the number of
// overlapping partners j > i (resets the history of non-touching ones).
template <bool Friction>
struct PairInit {
  State s;
  int* ccount;
  LBDEM_HD void operator()(Index i) const {
    const Real4 p = s.pos[i];
    const Real4 v = s.vpr[i];
    Real4 w{0, 0, 0, 0};
    if constexpr (Friction) w = s.wpr[i];
    Vec3d F, T;
    particle_forces<Friction>(s, i, p, v, w, F, T);
    s.frc[i] = Real4{F.x, F.y, F.z, 0.0};
    if constexpr (Friction) s.trq[i] = Real4{T.x, T.y, T.z, 0.0};
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
