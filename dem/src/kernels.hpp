#pragma once
// Velocity-Verlet kernel bodies and the rebuild report they reduce: small
// trivially-copyable functors run by launch() on either backend. Include only
// from kernel translation units (*.cu).
#include <cstdint>

#include "atomics.hpp"
#include "report.hpp"
#include "state.hpp"

namespace lbdem::dem {

// ---------------------------------------------------------------- integration
// Velocity Verlet with a velocity predictor for the velocity-dependent
// contact forces (dashpot, tangential slip):
//   v_{n+1/2} = v_n + dt/2 a_n,  x_{n+1} = x_n + dt v_{n+1/2},
//   forces at x_{n+1} and v~_{n+1} = v_{n+1/2} + dt/2 (2 a_n - a_{n-1}),
//   v_{n+1} = v_{n+1/2} + dt/2 a_{n+1}.
// The predictor extrapolates the acceleration linearly, so v~ is third-order
// accurate and the dashpot impulse error drops to the level of the spring's
// (the first-order predictor v_{n+1/2} + dt/2 a_n leaves a restitution error
// several times larger under strong damping). Without damping or friction the
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
  // Particle i's kick-drift from its position p0 (s.pos[i]), force f
  // (s.frc[i]) and torque t (s.trq[i]; unused without friction); the new
  // position and predicted velocities go to pos_out, vpr_out and wpr_out:
  // s.pos, s.vpr and s.wpr here, the other copies in the fused sub-step
  // (ForceKickDrift), whose force evaluation still reads these of other
  // particles.
  LBDEM_HD LBDEM_FORCEINLINE void step(Index i, const Real4& p0, const Real4& f, const Real4& t, Real4* pos_out,
                                       Real4* vpr_out, Real4* wpr_out) const {
    Real4 v = s.vel[i];
    Real4 p = p0;
    const double h = 0.5 * s.dt * v.w;
    const double k1 = synced ? h : 2.0 * h;
    v.x += k1 * f.x; v.y += k1 * f.y; v.z += k1 * f.z;
    Vec3d x{p.x + s.dt * v.x, p.y + s.dt * v.y, p.z + s.dt * v.z};
    x = s.box.wrap(x);
    set_xyz(p, x);
    s.vel[i] = v;
    pos_out[i] = p;
    Real4 vp = v;
    if (extrap) {
      const Real4 fo = s.frc_old[i];
      vp.x += h * (2.0 * f.x - fo.x); vp.y += h * (2.0 * f.y - fo.y); vp.z += h * (2.0 * f.z - fo.z);
    } else {
      vp.x += h * f.x; vp.y += h * f.y; vp.z += h * f.z;
    }
    vpr_out[i] = vp;
    if constexpr (Friction) {
      Real4 w = s.omg[i];
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
      wpr_out[i] = wp;
    } else {
      (void)t;
      (void)wpr_out;
    }
    const Vec3d d = s.box.min_image(x - xyz(s.x0[i]));
    const double d2 = dot(d, d);
    if (check && d2 > s.half_skin2) detail::atomic_max_u32(&rec->over2, detail::float_bits_up(d2));
    if (report) {
      if (i == 0) *next = StatusRecord{};
      report_particle(rec, d2, v, f);
    }
  }
  LBDEM_HD void operator()(Index i) const {
    const Real4 f = s.frc[i];
    const Real4 p = s.pos[i];
    Real4 t{0, 0, 0, 0};
    if constexpr (Friction) t = s.trq[i];
    step(i, p, f, t, s.pos, s.vpr, s.wpr);
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

}  // namespace lbdem::dem
