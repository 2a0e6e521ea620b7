#pragma once
// Plane walls made of partially saturated cells: the one-dimensional problem
// behind the PSM drag error (bench/imb/NOTES.md, "Where the PSM wall sits").
//
// A column of n cells along y (D3Q19; x and z are periodic with one cell, so
// the flow is exactly one-dimensional), periodic along y, holds a solid slab
// [y_lo - T, y_lo) and a fluid gap [y_lo, y_lo + W) of width W. A cell j covers
// [j, j + 1); its solid fraction eps_j is the length of its overlap with the
// slab. The collision is the code's PSM collision (imb::psm_collide with the
// TRT collider of lbm/collision.hpp), so what is measured here is what the
// particle scenes run.
//
// Poiseuille: the slab at rest, body force g along x. In fully fluid cells the
// TRT solution of this flow is a parabola of curvature -g/nu, so a fit of
// u + g y^2 / (2 nu) = b y + c over the cells at least two cells from any
// partial cell gives the effective walls as the roots of
// g/(2 nu) (y - Y0)(Y1 - y).
// Couette: two slabs moving at +U and -U (the period holds two gaps); the
// linear profile of the first gap extrapolated to the wall velocities.
//
// Wall shift delta = (effective gap - W) / 2: positive when the effective wall
// lies inside the solid (a wider channel: less drag), negative when inside the fluid.
#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "imb/psm.hpp"
#include "lbm/collision.hpp"
#include "lbm/lattice.hpp"

namespace lbdem::bench {

struct PlaneWallSpec {
  double tau = 0.52;
  double magic = 1e-4;         // TRT Lambda
  double wall_eps = 0.5;       // solid fraction of the cell that holds each wall face
  double gap = 16;             // whole fluid cells between the two wall cells (the gap W = gap + 2 - 2 eps)
  int slab = 6;                // solid slab thickness (cells, rounded)
  bool couette = false;
  // Weighting B(eps, tau - 1/2); default the code's (imb::psm_weight, NT).
  std::function<double(double, double)> weight;
  double tol = 1e-11;          // steady state: max change of u per check / max |u|
  long max_steps = 4000000;
};

struct PlaneWallResult {
  double delta_lo = 0, delta_hi = 0;  // shift of each wall (cells, + into the solid)
  double delta = 0;                   // mean
  long steps = 0;
  bool converged = false;
};

// Solid fraction of cell [j, j+1) in the union of intervals [a_k, b_k) (periodic, length n).
inline double overlap_1d(double j, double a, double b) {
  return std::max(0.0, std::min(j + 1.0, b) - std::max(j, a));
}

inline PlaneWallResult run_plane_wall(const PlaneWallSpec& s) {
  using L = lbm::D3Q19;
  using R = double;
  constexpr int Q = L::Q;
  // Geometry: each wall cell holds eps of solid on its solid side.
  const double eps = s.wall_eps;
  const int T = std::max(3, s.slab);
  const int m = std::max(6, static_cast<int>(std::lround(s.gap)));  // whole fluid cells between the wall cells
  // Cells: 0..T-1 solid, T wall cell (solid below y_lo = T + eps), T+1..T+m fluid,
  // T+m+1 wall cell (solid above y_hi = T + m + 1 + (1 - eps)), then period.
  const int n = T + m + 2;
  const double y_lo = T + eps, y_hi = T + m + 1 + (1.0 - eps);
  const double W = y_hi - y_lo;
  // Couette: two slabs moving at +U (lower, cells < T) and -U: the period holds
  // two gaps. Poiseuille: one slab, one gap.
  const int nn = s.couette ? 2 * n : n;
  std::vector<double> eps_c(nn, 0.0), vel(nn, 0.0);
  const double U = 1e-3;
  for (int k = 0; k < (s.couette ? 2 : 1); ++k) {
    const int o = k * n;
    const double vs = s.couette ? (k == 0 ? U : -U) : 0.0;
    for (int j = 0; j < n; ++j) {
      const double y = j;
      // slab of this period: [-(1-eps)-..., y_lo) i.e. [y_hi - n, y_lo)
      double e = overlap_1d(y, y_hi - n, y_lo) + overlap_1d(y, y_hi, y_lo + n);
      eps_c[o + j] = std::min(1.0, e);
      // The last cell's solid is the next slab's (the other velocity).
      if (e > 0) vel[o + j] = j == n - 1 ? -vs : vs;
    }
  }
  const double tm = s.tau - 0.5;
  const double nu = tm / 3.0;
  const double g = s.couette ? 0.0 : 1e-6;
  lbm::Collider<L, R, true> coll;
  const auto rel = lbm::relaxation(lbm::CollisionKind::TRT, s.tau, s.magic);
  coll.omega_p = rel.omega_p;
  coll.omega_m = rel.omega_m;
  coll.F[0] = g;
  auto wfun = s.weight ? s.weight : [](double e, double t) { return imb::psm_weight(e, t, imb::PsmWeight::NobleTorczynski); };
  std::vector<double> B(nn);
  for (int j = 0; j < nn; ++j) B[j] = eps_c[j] > 0 ? wfun(std::min(1.0, eps_c[j]), tm) : 0.0;
  // Initial state: the nominal solution at equilibrium (shifted populations).
  std::vector<double> f(static_cast<std::size_t>(Q) * nn), fn(f.size());
  auto u_nominal = [&](int j) {
    const int k = j / n, jj = j % n;
    const double y = jj + 0.5;
    if (y < y_lo) return s.couette ? (k == 0 ? U : -U) : 0.0;
    if (y > y_hi) return s.couette ? (k == 0 ? -U : U) : 0.0;
    if (s.couette) {
      const double us = k == 0 ? U : -U, ue = -us;  // gap k: from slab k (below) to slab k+1 (above)
      return us + (ue - us) * (y - y_lo) / W;
    }
    return g / (2 * nu) * (y - y_lo) * (y_hi - y);
  };
  for (int j = 0; j < nn; ++j) {
    const double ux = u_nominal(j);
    for (int q = 0; q < Q; ++q) {
      const double cu = L::c(q, 0) * ux;
      f[static_cast<std::size_t>(q) * nn + j] = L::w(q) * (3 * cu + 4.5 * cu * cu - 1.5 * ux * ux);
    }
  }
  std::vector<double> u(nn, 0.0), uold(nn, 0.0);
  PlaneWallResult res;
  const long check = std::max<long>(200, static_cast<long>(0.02 * W * W / nu));
  long step = 0;
  for (; step < s.max_steps; ++step) {
    for (int j = 0; j < nn; ++j) {
      R fc[Q];
      for (int q = 0; q < Q; ++q) fc[q] = f[static_cast<std::size_t>(q) * nn + j];
      R rho, uu[3];
      if (B[j] > 0) {
        const R M1[3] = {B[j] * vel[j], 0, 0};
        const R M2[6] = {B[j] * vel[j] * vel[j], 0, 0, 0, 0, 0};
        imb::psm_collide<L, R, true, imb::PsmVariant::NEBB>(coll, fc, B[j], R(0), M1, M2, rho, uu);
      } else {
        R d;
        coll(fc, d, uu);
      }
      u[j] = uu[0];
      // Stream along y (x and z are periodic with one cell).
      for (int q = 0; q < Q; ++q) {
        const int jd = ((j + L::c(q, 1)) % nn + nn) % nn;
        fn[static_cast<std::size_t>(q) * nn + jd] = fc[q];
      }
    }
    f.swap(fn);
    if ((step + 1) % check == 0) {
      double du = 0, um = 0;
      for (int j = 0; j < nn; ++j) {
        du = std::max(du, std::abs(u[j] - uold[j]));
        um = std::max(um, std::abs(u[j]));
      }
      uold = u;
      if (du < s.tol * um) {
        res.converged = true;
        ++step;
        break;
      }
    }
  }
  res.steps = step;
  // Fit over the cells of gap 0 at least two cells from the wall cells.
  const int j0 = T + 3, j1 = T + m - 2;  // fluid cells T+1 .. T+m; skip two at each end
  double Sy = 0, Syy = 0, Sv = 0, Syv = 0, N = 0;
  for (int j = j0; j <= j1; ++j) {
    const double y = j + 0.5;
    const double v = s.couette ? u[j] : u[j] + g * y * y / (2 * nu);
    Sy += y;
    Syy += y * y;
    Sv += v;
    Syv += y * v;
    N += 1;
  }
  const double b = (N * Syv - Sy * Sv) / (N * Syy - Sy * Sy), c0 = (Sv - b * Sy) / N;
  double Y0, Y1;
  if (s.couette) {  // u = b y + c0: u(Y0) = +U, u(Y1) = -U
    Y0 = (U - c0) / b;
    Y1 = (-U - c0) / b;
  } else {  // -g/(2nu) y^2 + b y + c0 = 0
    const double A = -g / (2 * nu);
    const double disc = std::sqrt(b * b - 4 * A * c0);
    Y0 = (-b + disc) / (2 * A);
    Y1 = (-b - disc) / (2 * A);
    if (Y0 > Y1) std::swap(Y0, Y1);
  }
  res.delta_lo = y_lo - Y0;
  res.delta_hi = Y1 - y_hi;
  res.delta = 0.5 * (res.delta_lo + res.delta_hi);
  return res;
}

}  // namespace lbdem::bench
