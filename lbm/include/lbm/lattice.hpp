#pragma once
// Lattice descriptors as constexpr types. Directions are ordered so that
// opposites pair up: 0 is rest, then (1,2), (3,4), ...: opp(q) = q odd ? q+1 : q-1.
#include "core/hd.hpp"

namespace lbdem::lbm {

namespace detail {
template <class L>
constexpr bool check_moments() {
  // Zeroth: sum w = 1. First: sum w c = 0. Second: sum w c_a c_b = cs^2 delta_ab
  // with cs^2 = 1/3. Third: sum w c_a c_b c_c = 0. Fourth-order isotropy of the
  // kind the Navier-Stokes limit needs: sum w c_a^2 c_b^2 = cs^4 (a != b),
  // sum w c_a^4 = 3 cs^4.
  double s0 = 0;
  for (int q = 0; q < L::Q; ++q) s0 += L::w(q);
  if (s0 < 1 - 1e-15 || s0 > 1 + 1e-15) return false;
  for (int a = 0; a < L::D; ++a) {
    double s1 = 0;
    for (int q = 0; q < L::Q; ++q) s1 += L::w(q) * L::c(q, a);
    if (s1 != 0) return false;
    for (int b = 0; b < L::D; ++b) {
      double s2 = 0, s4 = 0;
      for (int q = 0; q < L::Q; ++q) {
        s2 += L::w(q) * L::c(q, a) * L::c(q, b);
        s4 += L::w(q) * L::c(q, a) * L::c(q, a) * L::c(q, b) * L::c(q, b);
      }
      const double e2 = a == b ? 1.0 / 3.0 : 0.0;
      const double e4 = a == b ? 3.0 / 9.0 : 1.0 / 9.0;
      if (s2 - e2 > 1e-15 || e2 - s2 > 1e-15) return false;
      if (s4 - e4 > 1e-15 || e4 - s4 > 1e-15) return false;
      for (int g = 0; g < L::D; ++g) {
        double s3 = 0;
        for (int q = 0; q < L::Q; ++q) s3 += L::w(q) * L::c(q, a) * L::c(q, b) * L::c(q, g);
        if (s3 != 0) return false;
      }
    }
  }
  for (int q = 0; q < L::Q; ++q) {
    const int o = L::opp(q);
    for (int a = 0; a < 3; ++a)
      if (L::c(o, a) != -L::c(q, a)) return false;
    if (L::w(o) != L::w(q)) return false;
  }
  return true;
}
}  // namespace detail

// Velocity sets and weights, listed once. Device code reads them from
// constexpr locals (folded to immediates in unrolled loops); host code from
// namespace-scope tables (nvcc's host pass does not unroll, and a local table
// would be rebuilt on every call).
#define LBDEM_D2Q9_C {{0, 0, 0}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {1, 1, 0}, {-1, -1, 0}, {1, -1, 0}, {-1, 1, 0}}
#define LBDEM_D2Q9_W {4.0 / 9, 1.0 / 9, 1.0 / 9, 1.0 / 9, 1.0 / 9, 1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36}
#define LBDEM_D3Q19_C                                                                                          \
  {{0, 0, 0},  {1, 0, 0},   {-1, 0, 0}, {0, 1, 0},  {0, -1, 0}, {0, 0, 1},   {0, 0, -1},                     \
   {1, 1, 0},  {-1, -1, 0}, {1, -1, 0}, {-1, 1, 0}, {1, 0, 1},  {-1, 0, -1}, {1, 0, -1},                     \
   {-1, 0, 1}, {0, 1, 1},   {0, -1, -1}, {0, 1, -1}, {0, -1, 1}}
#define LBDEM_D3Q19_W                                                                                          \
  {1.0 / 3,  1.0 / 18, 1.0 / 18, 1.0 / 18, 1.0 / 18, 1.0 / 18, 1.0 / 18, 1.0 / 36, 1.0 / 36, 1.0 / 36,       \
   1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36, 1.0 / 36}
namespace detail {
inline constexpr int d2q9_c[9][3] = LBDEM_D2Q9_C;
inline constexpr double d2q9_w[9] = LBDEM_D2Q9_W;
inline constexpr int d3q19_c[19][3] = LBDEM_D3Q19_C;
inline constexpr double d3q19_w[19] = LBDEM_D3Q19_W;
}  // namespace detail

struct D2Q9 {
  static constexpr int D = 2;
  static constexpr int Q = 9;
  static constexpr const char* name = "D2Q9";
  // c[q] = (cx, cy, cz), cz = 0 in 2D so 2D and 3D share the index arithmetic.
  // Accessors rather than static arrays: constexpr functions are usable in
  // device code, and with unrolled loops every lookup folds to a constant.
  LBDEM_HD static constexpr int c(int q, int a) {
#if defined(__CUDA_ARCH__)
    constexpr int v[Q][3] = LBDEM_D2Q9_C;
    return v[q][a];
#else
    return detail::d2q9_c[q][a];
#endif
  }
  LBDEM_HD static constexpr double w(int q) {
#if defined(__CUDA_ARCH__)
    constexpr double v[Q] = LBDEM_D2Q9_W;
    return v[q];
#else
    return detail::d2q9_w[q];
#endif
  }
  LBDEM_HD static constexpr int opp(int q) { return q == 0 ? 0 : ((q & 1) ? q + 1 : q - 1); }
};

struct D3Q19 {
  static constexpr int D = 3;
  static constexpr int Q = 19;
  static constexpr const char* name = "D3Q19";
  LBDEM_HD static constexpr int c(int q, int a) {
#if defined(__CUDA_ARCH__)
    constexpr int v[Q][3] = LBDEM_D3Q19_C;
    return v[q][a];
#else
    return detail::d3q19_c[q][a];
#endif
  }
  LBDEM_HD static constexpr double w(int q) {
#if defined(__CUDA_ARCH__)
    constexpr double v[Q] = LBDEM_D3Q19_W;
    return v[q];
#else
    return detail::d3q19_w[q];
#endif
  }
  LBDEM_HD static constexpr int opp(int q) { return q == 0 ? 0 : ((q & 1) ? q + 1 : q - 1); }
};

static_assert(detail::check_moments<D2Q9>(), "D2Q9 moment identities");
static_assert(detail::check_moments<D3Q19>(), "D3Q19 moment identities");

// Speed of sound squared in lattice units.
inline constexpr double cs2 = 1.0 / 3.0;

}  // namespace lbdem::lbm
