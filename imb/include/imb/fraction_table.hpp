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
#include <type_traits>
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
  LBDEM_HD int floats() const { return 2 * nodes(); }  // [v][u][t][coef]: a node's (e0, e1) side by side
};

// Reads table entries from a plain pointer (the host copy, or a global-memory
// copy on the device): node i's coefficients (e0, e1), stored side by side. On
// the device both come in one 8-byte read through the read-only cache (__ldg):
// the copy must be 8-byte aligned (cudaMalloc'd) and not change during the kernel.
struct PointerTableAccess {
  const float* p = nullptr;
  LBDEM_HD void pair(int i, float& e0, float& e1) const {
#if defined(__CUDA_ARCH__)
    const float2 v = __ldg(reinterpret_cast<const float2*>(p) + i);
    e0 = v.x;
    e1 = v.y;
#else
    e0 = p[2 * i];
    e1 = p[2 * i + 1];
#endif
  }
};

namespace detail {
template <class Real>
LBDEM_HD inline void grid_coord(Real x, Real lo, Real hi, int n, int& i0, Real& f) {
  if (n <= 1) { i0 = 0; f = Real(0); return; }
  Real s = (x - lo) * ((n - 1) / (hi - lo));  // folds to a multiplication for (lo, hi) = (0, 1)
  s = s < Real(0) ? Real(0) : (s > Real(n - 1) ? Real(n - 1) : s);
  i0 = static_cast<int>(s);
  if (i0 > n - 2) i0 = n - 2;
  f = s - i0;
}
template <class Real>
LBDEM_HD inline Real clamp01(Real v) { return v < Real(0) ? Real(0) : (v > Real(1) ? Real(1) : v); }
}  // namespace detail

// Band and orientation coordinates of a cell centre r for radius R.
template <class Real = double>
struct TableCoordT {
  Real t, u, v;
};
using TableCoord = TableCoordT<double>;

template <class Real = double>
LBDEM_HD inline TableCoordT<Real> table_coord(Real rx, Real ry, Real rz, Real R) {
  Real a = fabs(rx), b = fabs(ry), c = fabs(rz), tmp;
  if (a < b) { tmp = a; a = b; b = tmp; }
  if (b < c) { tmp = b; b = c; c = tmp; }
  if (a < b) { tmp = a; a = b; b = tmp; }
  const Real d = sqrt(a * a + b * b + c * c);
  // t = (d - R) / h with h = (a + b + c) / (2 d): one division instead of two.
  return {(d - R) * (Real(2) * d) / (a + b + c), a > Real(0) ? b / a : Real(0), b > Real(0) ? c / b : Real(0)};
}

// The same coordinates with one division (the fused kernel's lookup, float or
// double; the slot map keeps the three divisions of table_coord): with
// P = a b s, s = a + b + c, and inv = 1 / (P R): u = b² s R inv, v = c a s R inv,
// t = 2 d (d - R) a b R inv, and 1 / R = P inv (returned in inv_r). A few ulp
// from table_coord. b = 0 (then c = 0): u = v = 0 and b is taken as 1 in P.
template <class Real>
LBDEM_HD inline TableCoordT<Real> table_coord_one_div(Real rx, Real ry, Real rz, Real R, Real& inv_r) {
  Real a = fabs(rx), b = fabs(ry), c = fabs(rz), tmp;
  if (a < b) { tmp = a; a = b; b = tmp; }
  if (b < c) { tmp = b; b = c; c = tmp; }
  if (a < b) { tmp = a; a = b; b = tmp; }
  const Real d = sqrt(a * a + b * b + c * c);
  const Real s = a + b + c;
  const bool flat = !(b > Real(0));
  const Real ab = a * (flat ? Real(1) : b);
  const Real P = ab * s;
  const Real inv = Real(1) / (P * R);
  inv_r = P * inv;
  const Real sRi = s * R * inv;  // 1 / (a b)
  return {(d - R) * (Real(2) * d) * (ab * R * inv), flat ? Real(0) : b * b * sRi, flat ? Real(0) : c * a * sRi};
}

// The table cell holding (t, u, v): first node (it, iu, iv) and the offsets in it.
template <class Real>
LBDEM_HD inline void table_cell(const TableGeometry& g, const TableCoordT<Real>& q, int& it, int& iu, int& iv, Real& ft,
                                Real& fu, Real& fv) {
  detail::grid_coord<Real>(q.t, Real(g.t_min), Real(g.t_max), g.nt, it, ft);
  detail::grid_coord<Real>(q.u, Real(0), Real(1), g.nu, iu, fu);
  detail::grid_coord<Real>(q.v, Real(0), Real(1), g.nv, iv, fv);
}

// Interpolated table value at (t, u, v) for 1 / R = inv_r (no in/out test, no clamp).
template <class Access, class Real = double>
LBDEM_HD inline Real table_interpolate_inv(const TableGeometry& g, const Access& tab, const TableCoordT<Real>& q,
                                           Real inv_r) {
  int it, iu, iv;
  Real ft, fu, fv;
  table_cell<Real>(g, q, it, iu, iv, ft, fu, fv);
  Real acc = 0;
  const int kv_end = g.nv > 1 ? 2 : 1;
  for (int kv = 0; kv < kv_end; ++kv) {
    const Real wv = g.nv > 1 ? (kv ? fv : Real(1) - fv) : Real(1);
    for (int ku = 0; ku < 2; ++ku) {
      const Real wu = ku ? fu : Real(1) - fu;
      for (int kt = 0; kt < 2; ++kt) {
        const Real w = wv * wu * (kt ? ft : Real(1) - ft);
        const int idx = ((iv + kv) * g.nu + (iu + ku)) * g.nt + (it + kt);
        float e0, e1;
        tab.pair(idx, e0, e1);  // one 8-byte read where the access allows it
        acc += w * (static_cast<Real>(e0) + static_cast<Real>(e1) * inv_r);
      }
    }
  }
  return acc;
}

// The same value by nested lerps (4 along t, 2 along u, 1 along v: fewer
// multiplications than the weighted sum; the same up to round-off). A 3D
// table with one v node reads its v = 0 nodes twice (fv = 0).
template <class Access, class Real>
LBDEM_HD inline Real table_interpolate_lerp(const TableGeometry& g, const Access& tab, const TableCoordT<Real>& q,
                                            Real inv_r) {
  int it, iu, iv;
  Real ft, fu, fv;
  table_cell<Real>(g, q, it, iu, iv, ft, fu, fv);
  const int du = g.nt, dv = g.nv > 1 ? g.nu * g.nt : 0;
  const int i0 = (iv * g.nu + iu) * g.nt + it;
  auto node = [&](int i) {
    float e0, e1;
    tab.pair(i, e0, e1);
    return static_cast<Real>(e0) + static_cast<Real>(e1) * inv_r;
  };
  auto lerp = [](Real a, Real b, Real f) { return a + f * (b - a); };
  const Real c00 = lerp(node(i0), node(i0 + 1), ft), c10 = lerp(node(i0 + du), node(i0 + du + 1), ft);
  const Real c01 = lerp(node(i0 + dv), node(i0 + dv + 1), ft), c11 = lerp(node(i0 + dv + du), node(i0 + dv + du + 1), ft);
  return lerp(lerp(c00, c10, fu), lerp(c01, c11, fu), fv);
}

// The same for radius R.
template <class Access, class Real = double>
LBDEM_HD inline Real table_interpolate(const TableGeometry& g, const Access& tab, const TableCoordT<Real>& q, Real R) {
  return table_interpolate_inv<Access, Real>(g, tab, q, Real(1) / R);
}

// Squared distances from the centre to the nearest point / farthest corner of
// the unit cell at r (Real-typed twins of cell_near2 / cell_far2).
template <class Real>
LBDEM_HD inline Real cell_near2_t(Real rx, Real ry, Real rz) {
  const Real h = Real(0.5);
  const Real dx = fabs(rx) > h ? fabs(rx) - h : Real(0), dy = fabs(ry) > h ? fabs(ry) - h : Real(0),
             dz = fabs(rz) > h ? fabs(rz) - h : Real(0);
  return dx * dx + dy * dy + dz * dz;
}
template <class Real>
LBDEM_HD inline Real cell_far2_t(Real rx, Real ry, Real rz) {
  const Real dx = fabs(rx) + Real(0.5), dy = fabs(ry) + Real(0.5), dz = fabs(rz) + Real(0.5);
  return dx * dx + dy * dy + dz * dz;
}

// Table fractions. Double everywhere the slot map uses them, so that the mapped
// pipeline's host and GPU fractions agree to round-off in double (in float, FMA
// contraction on the GPU alone moves eps by ~1e-6). The fused kernel evaluates
// them in the lattice's precision (Real = float in fp32 runs: the fraction
// then carries float round-off, as every other quantity of such a run).
template <class Access, class Real = double>
LBDEM_HD inline Real table_fraction_3d(const TableGeometry& g, const Access& tab, Real rx, Real ry, Real rz, Real R) {
  if constexpr (std::is_same_v<Real, double>) {
    if (cell_near2(rx, ry, rz) >= R * R) return 0.0;
    if (cell_far2(rx, ry, rz) <= R * R) return 1.0;
  } else {
    if (cell_near2_t(rx, ry, rz) >= R * R) return Real(0);
    if (cell_far2_t(rx, ry, rz) <= R * R) return Real(1);
  }
  return detail::clamp01<Real>(table_interpolate<Access, Real>(g, tab, table_coord<Real>(rx, ry, rz, R), R));
}

// 3D table fraction with the one-division coordinates and the nested lerps:
// the fused kernel's lookup, in the lattice's precision.
template <class Access, class Real>
LBDEM_HD inline Real table_fraction_3d_one_div(const TableGeometry& g, const Access& tab, Real rx, Real ry, Real rz,
                                               Real R) {
  if (cell_near2_t(rx, ry, rz) >= R * R) return Real(0);
  if (cell_far2_t(rx, ry, rz) <= R * R) return Real(1);
  Real inv_r;
  const TableCoordT<Real> q = table_coord_one_div<Real>(rx, ry, rz, R, inv_r);
  return detail::clamp01<Real>(table_interpolate_lerp<Access, Real>(g, tab, q, inv_r));
}

template <class Access, class Real = double>
LBDEM_HD inline Real table_fraction_2d(const TableGeometry& g, const Access& tab, Real rx, Real ry, Real R) {
  if constexpr (std::is_same_v<Real, double>) {
    if (cell_near2(rx, ry, 0.0) >= R * R) return 0.0;
  } else {
    if (cell_near2_t(rx, ry, Real(0)) >= R * R) return Real(0);
  }
  const Real fx = fabs(rx) + Real(0.5), fy = fabs(ry) + Real(0.5);
  if (fx * fx + fy * fy <= R * R) return Real(1);
  return detail::clamp01<Real>(table_interpolate<Access, Real>(g, tab, table_coord<Real>(rx, ry, Real(0), R), R));
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
