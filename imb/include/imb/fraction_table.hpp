#pragma once
// Table lookup of the solid fraction, after Xiong et al. (first paper, Eq. 6 and
// Fig. 1): ε = φ(d, θ), precomputed with the exact method and read from GPU
// constant memory (a host copy serves the host backend).
//
// Coordinates of a lookup, for the cell centre r relative to the particle centre:
//   a ≥ b ≥ c  the sorted |r_x|, |r_y|, |r_z| (cube symmetry folds every
//              direction into the wedge 0 ≤ c ≤ b ≤ a; in 2D a ≥ b, θ ∈ [0, π/4])
//   d = |r|,   h = (a + b + c)/(2d)  the half-width of the cell along r̂ (the
//              interface band of a plane cutting the cell is |d − R| < h)
//   t = (d − R)/h ∈ [t_min, t_max]   band coordinate, node-spaced uniformly
//   u = b/a = tan θ ∈ [0, 1],  v = c/b ∈ [0, 1] (3D only)  orientation
// Radius dependence: at fixed (t, u, v) ε depends on R only through the
// curvature of the surface across the cell, so each node stores two
// coefficients, ε ≈ e0 + e1/R, fitted exactly at two radii R_a, R_b (one table
// serves every radius; the residual is O((1/R − 1/R_a)(1/R − 1/R_b))). Linear
// (2D: bilinear; 3D: trilinear) interpolation between nodes. Cells outside the
// band get the exact 0 or 1 from a corner test before the table is consulted.
//
// Memory: at most kTableCapacity floats = 32 KB of the 64 KB constant memory.
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/hd.hpp"
#include "imb/solid_fraction.hpp"

namespace lbdem::imb {

inline constexpr int kTableCapacity = 8192;  // floats: 32 KB

// Trivially copyable description of a table; passed by value into kernels.
struct TableGeometry {
  int dim = 3;
  int nt = 0, nu = 0, nv = 1;  // nodes per coordinate (nv = 1 in 2D)
  float t_min = -1.25f, t_max = 1.0f;
  LBDEM_HD int nodes() const { return nt * nu * nv; }
  LBDEM_HD int floats() const { return 2 * nodes(); }  // [coef][v][u][t]
};

// Reads table entries from a plain pointer (host copy, or any device pointer).
struct PointerTableAccess {
  const float* p = nullptr;
  LBDEM_HD float operator()(int i) const { return p[i]; }
};

namespace detail {
LBDEM_HD inline void grid_coord(double x, double lo, double hi, int n, int& i0, double& f) {
  if (n <= 1) { i0 = 0; f = 0.0; return; }
  double s = (x - lo) * ((n - 1) / (hi - lo));  // folds to a multiplication for (lo, hi) = (0, 1)
  s = clampd(s, 0.0, static_cast<double>(n - 1));
  i0 = static_cast<int>(s);
  if (i0 > n - 2) i0 = n - 2;
  f = s - i0;
}
}  // namespace detail

// Band and orientation coordinates of a cell centre r for radius R.
struct TableCoord {
  double t, u, v;
};
LBDEM_HD inline TableCoord table_coord(double rx, double ry, double rz, double R) {
  double a = fabs(rx), b = fabs(ry), c = fabs(rz), tmp;
  if (a < b) { tmp = a; a = b; b = tmp; }
  if (b < c) { tmp = b; b = c; c = tmp; }
  if (a < b) { tmp = a; a = b; b = tmp; }
  const double d = sqrt(a * a + b * b + c * c);
  // t = (d - R) / h with h = (a + b + c) / (2 d): one division instead of two.
  return {(d - R) * (2.0 * d) / (a + b + c), a > 0.0 ? b / a : 0.0, b > 0.0 ? c / b : 0.0};
}

// Interpolated table value at (t, u, v) for radius R (no in/out test, no clamp).
template <class Access>
LBDEM_HD inline double table_interpolate(const TableGeometry& g, const Access& tab, const TableCoord& q, double R) {
  int it, iu, iv;
  double ft, fu, fv;
  detail::grid_coord(q.t, g.t_min, g.t_max, g.nt, it, ft);
  detail::grid_coord(q.u, 0.0, 1.0, g.nu, iu, fu);
  detail::grid_coord(q.v, 0.0, 1.0, g.nv, iv, fv);
  const int nodes = g.nodes();
  const double inv_r = 1.0 / R;
  double acc = 0.0;
  const int kv_end = g.nv > 1 ? 2 : 1;
  for (int kv = 0; kv < kv_end; ++kv) {
    const double wv = g.nv > 1 ? (kv ? fv : 1.0 - fv) : 1.0;
    for (int ku = 0; ku < 2; ++ku) {
      const double wu = ku ? fu : 1.0 - fu;
      for (int kt = 0; kt < 2; ++kt) {
        const double w = wv * wu * (kt ? ft : 1.0 - ft);
        const int idx = ((iv + kv) * g.nu + (iu + ku)) * g.nt + (it + kt);
        acc += w * (static_cast<double>(tab(idx)) + static_cast<double>(tab(nodes + idx)) * inv_r);
      }
    }
  }
  return acc;
}

// Table fractions in double. (Float interpolation made the suspension's map
// 10 % faster, 0.318 against 0.351 ms on the H200, but host and GPU then
// differ by 1e-6 in eps through FMA contraction instead of 1e-12; kept double.)
template <class Access>
LBDEM_HD inline double table_fraction_3d(const TableGeometry& g, const Access& tab, double rx, double ry, double rz,
                                         double R) {
  if (cell_near2(rx, ry, rz) >= R * R) return 0.0;
  if (cell_far2(rx, ry, rz) <= R * R) return 1.0;
  return detail::clampd(table_interpolate(g, tab, table_coord(rx, ry, rz, R), R), 0.0, 1.0);
}

template <class Access>
LBDEM_HD inline double table_fraction_2d(const TableGeometry& g, const Access& tab, double rx, double ry, double R) {
  if (cell_near2(rx, ry, 0.0) >= R * R) return 0.0;
  const double fx = fabs(rx) + 0.5, fy = fabs(ry) + 0.5;
  if (fx * fx + fy * fy <= R * R) return 1.0;
  return detail::clampd(table_interpolate(g, tab, table_coord(rx, ry, 0.0, R), R), 0.0, 1.0);
}

// Host-side table: geometry plus the values (coefficient e0 block, then e1).
struct FractionTable {
  TableGeometry geometry;
  std::vector<float> values;
  double r_fit_a = 0, r_fit_b = 0;  // radii of the exact fit
  std::uint64_t id = 0;              // unique per built table (device upload cache key)
  PointerTableAccess host_access() const { return {values.data()}; }
};

// Builds a table with the exact method. Defaults fit the 32 KB budget:
// 3D 32×11×11 nodes (30,976 B), 2D 64×32 (16,384 B). Throws ConfigError if the
// node counts exceed kTableCapacity or are < 2, or the fit radii are not > 1.
FractionTable build_fraction_table(int dim, int nt = 0, int nu = 0, int nv = 0, double r_fit_a = 4.0,
                                   double r_fit_b = 16.0);

}  // namespace lbdem::imb
