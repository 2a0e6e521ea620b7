#pragma once
// Solid volume fraction of the gas cells from the particles, and the same
// weights for moving cell quantities back to the particles.
//
// Schemes (per axis; the 3-D weight is the product):
//  * Centroid (PCM, as Yu et al. 2024 Eq. 3): a particle's whole volume goes
//    to the cell holding its centre.
//  * Linear: cloud-in-cell, the hat function of width 2 cells centred on the
//    particle: the 2 nearest cell centres per axis (8 cells).
//  * Quadratic: the quadratic B-spline of width 3 cells (27 cells), smoother
//    (continuous first derivative of the weights).
// The weights of one particle sum to one. Near a non-periodic face a weight
// that falls outside the box is reflected into the cell mirrored at the face
// (an image particle), so no volume leaves the domain; on a periodic axis it
// wraps. Weights depend only on the particle's position in the global grid,
// never on which rank or in which order particles are processed.
//
// Exact conservation and order independence: contributions are summed in
// 64-bit fixed point (quantum 2^-40 of the deposited quantity, range 2^23).
// Each particle's total is rounded once and split so that its parts add up to
// exactly that total; integer addition is associative, so the cell sums are
// the same bits for any particle order and any thread schedule, and the sum
// over cells equals the sum over particles exactly (in quanta).
#include <cmath>
#include <string>

#include "cfd/gas_grid.hpp"
#include "core/buffer.hpp"
#include "core/error.hpp"
#include "dem/particle_view.hpp"

namespace lbdem::cfd {

enum class Deposition { Centroid, Linear, Quadratic };

inline const char* to_string(Deposition d) {
  switch (d) {
    case Deposition::Centroid: return "centroid";
    case Deposition::Linear: return "linear";
    case Deposition::Quadratic: return "quadratic";
  }
  return "?";
}
inline Deposition parse_deposition(const std::string& key, const std::string& value) {
  for (Deposition d : {Deposition::Centroid, Deposition::Linear, Deposition::Quadratic})
    if (value == to_string(d)) return d;
  throw ConfigError(key + ": unknown void-fraction scheme '" + value + "' (valid: centroid, linear, quadratic)");
}

// Cells and weights along one axis.
struct Stencil1D {
  int m = 1;  // entries used
  int idx[3] = {0, 0, 0};
  double w[3] = {1, 0, 0};
};

// Maps a cell index that may lie one or two cells outside [0, n) into the box:
// wrap on a periodic axis, mirror at a closed face.
LBDEM_HD inline int fold_index(int i, int n, bool periodic) {
  if (periodic) {
    i %= n;
    return i < 0 ? i + n : i;
  }
  if (i < 0) i = -1 - i;
  if (i >= n) i = 2 * n - 1 - i;
  return i < 0 ? 0 : (i >= n ? n - 1 : i);  // grids narrower than the stencil
}

// s: the position along the axis in cell units from the grid's lower face.
LBDEM_HD inline Stencil1D stencil_1d(Deposition scheme, double s, int n, bool periodic) {
  Stencil1D st;
  if (periodic) {
    s = s - n * std::floor(s / n);
  } else {
    s = s < 0 ? 0 : (s > n ? n : s);
  }
  if (scheme == Deposition::Centroid) {
    int i = static_cast<int>(std::floor(s));
    if (!periodic && i >= n) i = n - 1;  // a centre exactly on the upper face
    st.m = 1;
    st.idx[0] = fold_index(i, n, periodic);
    st.w[0] = 1;
  } else if (scheme == Deposition::Linear) {
    const double c = s - 0.5;  // in cell-centre coordinates
    const double f0 = std::floor(c);
    const double f = c - f0;
    const int i0 = static_cast<int>(f0);
    st.m = 2;
    st.idx[0] = fold_index(i0, n, periodic);
    st.idx[1] = fold_index(i0 + 1, n, periodic);
    st.w[0] = 1 - f;
    st.w[1] = f;
  } else {
    const double c = s - 0.5;
    const double fc = std::floor(c + 0.5);  // nearest cell centre
    const double f = c - fc;                // in [-1/2, 1/2)
    const int ic = static_cast<int>(fc);
    st.m = 3;
    st.idx[0] = fold_index(ic - 1, n, periodic);
    st.idx[1] = fold_index(ic, n, periodic);
    st.idx[2] = fold_index(ic + 1, n, periodic);
    st.w[0] = 0.5 * (0.5 - f) * (0.5 - f);
    st.w[1] = 0.75 - f * f;
    st.w[2] = 0.5 * (0.5 + f) * (0.5 + f);
  }
  return st;
}

struct Stencil3D {
  Stencil1D a[3];
  LBDEM_HD int size() const { return a[0].m * a[1].m * a[2].m; }
  // The t-th entry (x fastest): cell index and weight.
  LBDEM_HD void entry(const GasGridView& g, int t, Index& cell, double& w) const {
    const int tx = t % a[0].m, ty = (t / a[0].m) % a[1].m, tz = t / (a[0].m * a[1].m);
    cell = g.index(a[0].idx[tx], a[1].idx[ty], a[2].idx[tz]);
    w = a[0].w[tx] * a[1].w[ty] * a[2].w[tz];
  }
};

LBDEM_HD inline Stencil3D stencil_3d(const GasGridView& g, Deposition scheme, const Vec3d& x) {
  Stencil3D s;
  for (int d = 0; d < 3; ++d) s.a[d] = stencil_1d(scheme, (x[d] - g.origin[d]) / g.h, g.n[d], g.periodic[d]);
  return s;
}

// Interpolation of a cell field to a point with the deposition weights.
LBDEM_HD inline double interpolate(const GasGridView& g, Deposition scheme, const double* field, const Vec3d& x) {
  const Stencil3D s = stencil_3d(g, scheme, x);
  double r = 0;
  for (int t = 0; t < s.size(); ++t) {
    Index c;
    double w;
    s.entry(g, t, c, w);
    r += w * field[c];
  }
  return r;
}

// 64-bit fixed point.
constexpr double kFixedQuantum = 9.094947017729282379150390625e-13;  // 2^-40
constexpr double kFixedScale = 1099511627776.0;                       // 2^40

// Round to nearest (ties to even) on both backends.
LBDEM_HD inline long long round_fixed(double x) {
#if defined(__CUDA_ARCH__)
  return __double2ll_rn(x);
#else
  return std::llrint(x);
#endif
}

LBDEM_HD inline void atomic_add_fixed(unsigned long long* p, long long v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(p, static_cast<unsigned long long>(v));
#else
  __atomic_fetch_add(p, static_cast<unsigned long long>(v), __ATOMIC_RELAXED);
#endif
}

// Adds `value` (in units of quantum) times the stencil weights into acc,
// split so that the parts sum to exactly round(value / quantum).
LBDEM_HD inline void deposit_fixed(const GasGridView& g, const Stencil3D& s, double value_over_quantum,
                                   unsigned long long* acc) {
  const long long total = round_fixed(value_over_quantum);
  long long given = 0;
  const int K = s.size();
  for (int t = 0; t < K; ++t) {
    Index c;
    double w;
    s.entry(g, t, c, w);
    const long long q = t + 1 < K ? round_fixed(value_over_quantum * w) : total - given;
    given += q;
    if (q != 0) atomic_add_fixed(acc + c, q);
  }
}

// Solid fraction per gas cell from the particles (Yu et al. 2024 Eq. 3 with
// the chosen weights).
class VoidFraction {
 public:
  VoidFraction(const Exec& ex, const GasGridView& g, Deposition scheme);
  // Deposits the particles' volumes; solid()[c] = sum of V_p w / V_c.
  void deposit(const dem::ParticleView& p);
  const Buffer<double>& solid() const { return solid_; }
  // The raw fixed-point sums (quanta of 2^-40), for exact checks.
  const Buffer<unsigned long long>& fixed() const { return acc_; }
  const GasGridView& grid() const { return g_; }
  Deposition scheme() const { return scheme_; }

 private:
  Exec ex_;
  GasGridView g_;
  Deposition scheme_;
  Buffer<unsigned long long> acc_;
  Buffer<double> solid_;
};

}  // namespace lbdem::cfd
