#pragma once
// The normal force a PSM sphere misses in a gap of a few cells from a plane
// no-slip wall (issue 29), and its correction.
//
// A sphere of radius a approaching a wall at speed U with gap g (surface to
// wall plane) feels F = 6 pi mu a U lambda(h / a), h = a + g (Brenner 1961);
// as g -> 0, lambda -> a / g + (1/5) ln(a / g) + 0.971 (Cox & Brenner 1967):
// the force is carried by the squeeze flow in the gap, a radial Poiseuille
// flow through the local gap g + r^2 / (2a). Resolved with partially
// saturated cells, the flow in the gap also passes through the sphere's
// partially covered cells (permeable where B < 1), so where the gap is a
// cell or two the resolved gap carries too much flux for its pressure and
// the drag falls short of Brenner's. With the rule's Lambda the shortfall
// is set by the gap in cells rather than by g / a (at a one-cell gap it is
// the same fraction of the lubrication term a / g at d/l 6 and 10), and it
// falls off steeply with the gap (like g^-p, p about 2.6, against g^-2 for a
// fixed offset of the surface): a discretisation error of the gap flow
// (bench/imb/NOTES.md, "Walls: the gap").
//
// The correction adds, along the wall normal, the missing part
//   dF = -6 pi mu a U_n * c a g^-p    (lattice units: lengths in cells),
// with U_n the sphere's velocity toward the wall (negative: away) and the
// constants fitted to the resolved drag against Brenner at d/l 6 and 10,
// tau 0.8, the default weighting and Lambda, gaps 1 to 8 cells. It is a
// calibration, like Nguyen & Ladd's (2002) lubrication cut-off h_c: their
// form 6 pi mu a^2 U (1/g - 1/h_c), added below h_c, assumes a resolved force
// that stops growing below h_c; the PSM force keeps following Brenner's
// shape with a deficit that shrinks smoothly, which a single cut-off cannot
// match between one and two cells (NOTES.md). The deficit is the balance of
// two Lambda-dependent fluxes (the bounce-back wall's TRT slip narrows a
// one-node channel unless Lambda = 3/16, the partial cells widen it), so the
// constants hold for the rule's Lambda where it was fitted (0.06-0.17: d/l 6-10
// at tau 0.8, d/l 6 at tau 1; the correction is 0 outside, WallLubrication::
// magic_min/max): with Lambda 1e-4 a one-cell gap has 70 % too much drag, with
// 3/16 15 % too little, with the rule's 0.010 at tau 0.6 0.7 % too little, at
// d/l 6. Outside the fitted range (gaps below one
// cell, other weightings or Lambda, tau far from 0.8) they are unverified.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "core/exec.hpp"
#include "core/grid.hpp"
#include "core/hd.hpp"
#include "imb/particle_view.hpp"
#include "imb/psm.hpp"

namespace lbdem::imb {

struct WallLubrication {
  double c = 0.11;    // deficit of lambda per unit a at a one-cell gap (of a / g: 11 %)
  double p = 2.6;     // fall-off with the gap in cells
  double g_min = 0.5; // the gap (cells) below which the correction is held at its value there
  // The TRT Lambda range of the fit (the rule's Lambda at d/l 6 tau 1.0, d/l 6
  // and 10 at tau 0.8); outside it the correction is 0: at d/l 6, tau 0.6
  // (Lambda 0.010) the bare one-cell drag is already within 1 % and this c
  // would add 7 %; at 3/16 the deficit is twice c.
  double magic_min = 0.06, magic_max = 0.17;
};

// Whether the correction applies at TRT Lambda `magic`.
inline bool wall_lubrication_applies(double magic, const WallLubrication& w = {}) {
  return magic >= w.magic_min && magic <= w.magic_max;
}

// The missing part of Brenner's lambda (units of 6 pi mu a U) at gap g cells
// for a sphere of radius a cells and TRT Lambda `magic` (0 outside the fit's
// Lambda range).
inline double wall_lubrication_lambda(double a, double g, double magic, const WallLubrication& w = {}) {
  if (!(g > 0) || !wall_lubrication_applies(magic, w)) return 0;
  return w.c * a * std::pow(std::max(g, w.g_min), -w.p);
}

// The correction force along the wall's outward normal (into the fluid) on a
// sphere of radius a at gap g moving toward the wall at U_n (lattice units;
// mu = rho nu): + pushes the sphere away from a wall it approaches.
inline double wall_lubrication_force(double mu, double a, double g, double U_n, double magic,
                                     const WallLubrication& w = {}) {
  return 6.0 * M_PI * mu * a * U_n * wall_lubrication_lambda(a, g, magic, w);
}

// ------------------------------------------------ the coupled step's share
// psm.wall_lubrication: on adds the correction above to the hydrodynamic
// force of every particle the coupled step moves (imb/coupled.hpp), for each
// plane wall of the fluid (the half-way bounce-back faces of the box's closed
// axes), where the particle's gap is below the fit's largest gap. The force
// is along the wall normal through the centre: no torque. It is applied only
// inside the fit (wall_lubrication_fit_note); outside it the run says so once
// and adds nothing.

// The fit's validity (bench/imb/NOTES.md, "Walls: the gap"): fitted at tau 0.8
// (d/l 6-10) and checked at tau 1.0 (d/l 6), the rule's weighting, the NEBB
// operator, exact fractions, gaps 1-8 cells, 3D spheres.
struct WallLubricationFit {
  WallLubrication w;
  double tau_min = 0.8, tau_max = 1.0;
  double g_max = 8.0;  // the largest fitted gap (cells): nothing is added beyond it
};

// A plane wall of the fluid: a point of the plane and its unit normal into
// the fluid (lattice units, the grid's global frame).
struct LubricationWall {
  double point[3] = {0, 0, 0};
  double normal[3] = {0, 0, 0};
};
constexpr int kMaxLubricationWalls = 6;

// What the kernel needs (trivially copyable, passed by value).
struct WallLubricationParams {
  double c = 0, p = 0, g_min = 0, g_max = 0;
  double mu = 0;  // dynamic viscosity rho_f nu (lattice units)
  int count = 0;
  LubricationWall wall[kMaxLubricationWalls];
};

// The setting of a run: asked for (psm.wall_lubrication), applied (inside the
// fit, with walls), the coefficients, and a sentence for the start report and
// summary.json saying what is applied or why nothing is.
struct WallLubricationSetting {
  bool requested = false;
  bool applied = false;
  WallLubricationParams k;
  WallLubricationFit fit;
  double tau = 0, magic = 0;
  std::string note = "off (the default): no wall gap correction";
};

// The half-way bounce-back walls of a grid's closed axes (those that are not
// periodic, below `dim`): the wall cells are the first and last layer along
// the axis, so the planes sit at 1 and n - 1 (cell i spans [i, i + 1]).
inline int closed_box_walls(const Grid& g, int dim, LubricationWall* out) {
  int n = 0;
  for (int a = 0; a < dim && a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    if (g.periodic[k]) continue;
    LubricationWall lo, hi;
    lo.point[a] = 1.0;
    lo.normal[a] = 1.0;
    hi.point[a] = double(g.global[k]) - 1.0;
    hi.normal[a] = -1.0;
    out[n++] = lo;
    out[n++] = hi;
  }
  return n;
}

// Resolves psm.wall_lubrication for a run: `on` as the case file asks, the
// run's dimension, tau, collision (TRT), Lambda, weighting, operator and
// fraction method, the fluid density, and the walls (closed_box_walls).
inline WallLubricationSetting resolve_wall_lubrication(bool on, int dim, double tau, bool trt, double magic,
                                                       PsmWeight weight, PsmVariant variant, FractionMethod method,
                                                       double fluid_density, const LubricationWall* walls, int nwalls,
                                                       const WallLubricationFit& fit = {}) {
  WallLubricationSetting s;
  s.requested = on;
  s.fit = fit;
  s.tau = tau;
  s.magic = magic;
  if (!on) return s;
  auto num = [](double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.4g", v);
    return std::string(b);
  };
  const std::string fitted = "the fit holds for 3D spheres, TRT with Lambda " + num(fit.w.magic_min) + "-" +
                             num(fit.w.magic_max) + ", tau " + num(fit.tau_min) + "-" + num(fit.tau_max) +
                             ", psm.weight: noble_torczynski_wall, psm.operator: nebb, psm.fraction: exact";
  std::string why;
  if (dim != 3) why = "a 2D scene (disks)";
  else if (!trt) why = "fluid.collision: bgk";
  else if (!wall_lubrication_applies(magic, fit.w)) why = "Lambda = " + num(magic);
  else if (!(tau >= fit.tau_min && tau <= fit.tau_max)) why = "tau = " + num(tau);
  else if (weight != PsmWeight::NobleTorczynskiWall) why = "another psm.weight";
  else if (variant != PsmVariant::NEBB) why = "psm.operator: superposition";
  else if (method != FractionMethod::Exact) why = "psm.fraction other than exact";
  else if (nwalls <= 0) why = "no wall (every axis of the domain is periodic)";
  if (!why.empty()) {
    s.note = "on but NOT applied: " + why + " is outside the fitted range (" + fitted +
             "); the run adds no wall gap correction";
    return s;
  }
  s.applied = true;
  s.k.c = fit.w.c;
  s.k.p = fit.w.p;
  s.k.g_min = fit.w.g_min;
  s.k.g_max = fit.g_max;
  s.k.mu = fluid_density * (tau - 0.5) / 3.0;
  s.k.count = std::min(nwalls, kMaxLubricationWalls);
  for (int i = 0; i < s.k.count; ++i) s.k.wall[i] = walls[i];
  s.note = "on: a normal force 6 pi mu a U_n c a g^-p (c = " + num(s.k.c) + ", p = " + num(s.k.p) +
           ", g in cells, held below " + num(s.k.g_min) + ", none from " + num(s.k.g_max) + ") on each particle near " +
           std::to_string(s.k.count) + " wall plane(s), at Lambda = " + num(magic) + ", tau = " + num(tau) + " (" +
           fitted + ")";
  return s;
}

// The correction's force on one sphere of radius a at x moving at v (lattice
// units), summed over the walls, into f (added). The same expression as
// wall_lubrication_force, with the gap held at g_min below it (also in
// contact, g <= 0, where the bench's form gives 0) and none from g_max.
LBDEM_HD inline void wall_lubrication_add(const WallLubricationParams& k, const double x[3], double a,
                                          const double v[3], double f[3]) {
  for (int w = 0; w < k.count; ++w) {
    const LubricationWall& P = k.wall[w];
    const double* n = P.normal;
    const double g = (x[0] - P.point[0]) * n[0] + (x[1] - P.point[1]) * n[1] + (x[2] - P.point[2]) * n[2] - a;
    if (!(g < k.g_max)) continue;
    const double un = -(v[0] * n[0] + v[1] * n[1] + v[2] * n[2]);  // toward the wall: > 0
    const double fn = 6.0 * M_PI * k.mu * a * un * (k.c * a * std::pow(g > k.g_min ? g : k.g_min, -k.p));
    f[0] += fn * n[0];
    f[1] += fn * n[1];
    f[2] += fn * n[2];
  }
}

// Adds the correction to the forces of particles [0, n) of p (positions,
// radii and velocities; stride p.stride) in force[i * fstride + 0..2], on the
// backend of `ex` (asynchronous on the device; no allocation). A particle
// without velocity arrays (p.vx null) is at rest: nothing is added.
void add_wall_lubrication(const Exec& ex, const WallLubricationParams& k, const SphereView& p, Index n,
                          double* force, int fstride);

}  // namespace lbdem::imb
