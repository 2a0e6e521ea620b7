#pragma once
// Solid fraction ε of one lattice cell covered by one sphere (3D) or disk (2D).
//
// Convention (lattice units, Δx = 1): cell i covers [i, i+1) along each axis, its
// centre is i + 0.5. Every per-cell function here takes the cell centre *relative
// to the particle centre*, r = x_cell − c, and the radius R; ε is the covered
// volume (area in 2D) of the unit cell [r − ½, r + ½], so 0 ≤ ε ≤ 1.
//
// Three methods (FractionMethod), used in PSM as γ/ε of Noble & Torczynski (1998)
// and of the first paper (Xiong et al., Eq. 6):
//   Exact  — 2D: closed form (segment integrals of √(R²−t²)); 3D: the 2D closed
//            form for each z-slice, integrated in z by Gauss–Legendre on every
//            smooth piece between the z where a slice circle touches an edge or a
//            corner of the cell, after the substitution z = a + (b−a)(3u²−2u³),
//            which turns the (z−z_b)^{k+1/2} end behaviour of each piece into an
//            analytic integrand. 24 points per piece (default): |error| ≤ 4e-12 per
//            cell for R = 3…25, measured against the same rule on 8 sub-slabs
//            (16 points: ≤ 1.2e-10; 12: ≤ 2.6e-9). The pieces are only piecewise
//            analytic with branch points nearby, hence algebraic, not
//            exponential, convergence in N. See test_solid_fraction.cpp.
//   Table  — Xiong et al. Eq. 6: ε = φ(d, θ) from a precomputed table (see
//            imb/fraction_table.hpp).
//   Linear — ε = clamp(R_eff − |r| + ½, 0, 1) with R_eff chosen so that the
//            continuum integral of the ramp equals the particle volume
//            (3D: R_eff³ + R_eff/4 = R³; 2D: R_eff² + 1/12 = R²). With R_eff = R
//            the volume is too large by 1/(4R²) (3D) and 1/(12R²) (2D).
// All functions are LBDEM_HD: the same code runs in CUDA kernels and OpenMP loops.
#include <cmath>

#include "core/hd.hpp"

namespace lbdem::imb {

enum class FractionMethod { Exact, Table, Linear };

inline const char* to_string(FractionMethod m) {
  switch (m) {
    case FractionMethod::Exact: return "exact";
    case FractionMethod::Table: return "table";
    case FractionMethod::Linear: return "linear";
  }
  return "?";
}

namespace detail {

LBDEM_HD inline double clampd(double v, double lo, double hi) { return v < lo ? lo : (v > hi ? hi : v); }

// ∫_0^t √(r² − u²) du for t clamped to [−r, r], r > 0. Written with atan2 and
// √((r−t)(r+t)): asin(t/r) loses ~√ε_mach (1e-8) when t/r rounds near ±1.
LBDEM_HD inline double circle_primitive(double t, double r) {
  t = clampd(t, -r, r);
  const double s = sqrt(fmax((r - t) * (r + t), 0.0));
  return 0.5 * (t * s + r * r * atan2(t, s));
}

// Area of the disk (centre origin, radius r > 0) inside {X ≤ x, Y ≤ y}.
// With x̂ = clamp(x, ±r) and w = √(r² − y²): for y < 0 the chord at abscissa t
// is y + √(r²−t²) on |t| < w; for y ≥ 0 it is the full chord minus the part
// above y on |t| < w. Closed form, no branches on data-dependent arrays.
LBDEM_HD inline double disk_quadrant_area(double r, double x, double y) {
  if (x <= -r || y <= -r) return 0.0;
  const double xh = clampd(x, -r, r);
  const double quarter = 0.25 * 3.14159265358979323846 * r * r;  // P(r) = −P(−r)
  const double full = 2.0 * (circle_primitive(xh, r) + quarter);  // disk ∩ {X ≤ x}
  if (y >= r) return full;
  const double ay = fabs(y);
  const double w = sqrt(fmax((r - ay) * (r + ay), 0.0));
  const double b = clampd(xh, -w, w);
  const double seg = circle_primitive(b, r) + circle_primitive(w, r);  // ∫_{−w}^{b} √(r²−t²) dt
  return y >= 0.0 ? full - (seg - y * (b + w)) : seg + y * (b + w);
}

// Sorts a fixed-size array with an odd–even transposition network: every index
// is a compile-time constant once unrolled, so the array stays in registers on
// the GPU (a data-dependent insertion sort spills to local memory).
template <int M>
LBDEM_HD inline void sort_network(double (&v)[M]) {
  LBDEM_UNROLL
  for (int round = 0; round < M; ++round) {
    LBDEM_UNROLL
    for (int i = round & 1; i + 1 < M; i += 2) {
      const double a = v[i], b = v[i + 1];
      v[i] = fmin(a, b);
      v[i + 1] = fmax(a, b);
    }
  }
}

// Gauss–Legendre rules on [−1, 1], positive half: x[0..N/2), then w[0..N/2).
// Device code reads them from constant memory (all threads of a warp read the
// same node at once: a broadcast), host code from a constexpr array.
#define LBDEM_GL12                                                                                              \
  {0.9815606342467192, 0.9041172563704748, 0.7699026741943047, 0.5873179542866175, 0.3678314989981802,         \
   0.12523340851146894, 0.047175336386511835, 0.10693932599531857, 0.16007832854334633, 0.20316742672306584,  \
   0.23349253653835478, 0.24914704581340288}
#define LBDEM_GL16                                                                                              \
  {0.9894009349916499,   0.9445750230732326,   0.8656312023878318,  0.755404408355003,   0.6178762444026438,     \
   0.45801677765722737,  0.2816035507792589,   0.09501250983763744, 0.027152459411754058, 0.062253523938647776, \
   0.0951585116824929,   0.12462897125553395,  0.14959598881657682, 0.16915651939500256, 0.1826034150449236,    \
   0.18945061045506847}
#define LBDEM_GL24                                                                                               \
  {0.9951872199970213,   0.9747285559713095,   0.9382745520027328,  0.8864155270044011,  0.820001985973903,       \
   0.7401241915785544,   0.6480936519369755,   0.5454214713888396,  0.4337935076260451,  0.3150426796961634,      \
   0.1911188674736163,   0.06405689286260563,  0.012341229799987334, 0.028531388628933813, 0.044277438817419676, \
   0.05929858491543666,  0.07334648141108027,  0.08619016153195322, 0.0976186521041139,  0.10744427011596562,     \
   0.11550566805372561,  0.12167047292780335,  0.12583745634682839, 0.12793819534675224}
#if defined(__CUDACC__)
static __constant__ double c_gauss12[12] = LBDEM_GL12;
static __constant__ double c_gauss16[16] = LBDEM_GL16;
static __constant__ double c_gauss24[24] = LBDEM_GL24;
#endif
template <int N>
struct GaussLegendre;
template <>
struct GaussLegendre<12> {
  static constexpr double host[12] = LBDEM_GL12;
};
template <>
struct GaussLegendre<16> {
  static constexpr double host[16] = LBDEM_GL16;
};
template <>
struct GaussLegendre<24> {
  static constexpr double host[24] = LBDEM_GL24;
};
template <int N>
LBDEM_HD inline const double* gauss_table() {
  static_assert(N == 12 || N == 16 || N == 24, "Gauss–Legendre rule with 12, 16 or 24 points");
#if defined(__CUDA_ARCH__)
  return N == 12 ? c_gauss12 : (N == 16 ? c_gauss16 : c_gauss24);
#else
  return GaussLegendre<N>::host;
#endif
}
#undef LBDEM_GL12
#undef LBDEM_GL16
#undef LBDEM_GL24

// Area of the disk (centre origin, radius r) inside [x0,x1]×[y0,y1], piecewise:
// the x-range is cut where the circle crosses y = y0 and y = y1; on each piece
// the chord is y1 − y0, √(r²−t²) − y0, y1 + √(r²−t²) or 2√(r²−t²), integrated in
// closed form. Only pieces bounded by the circle cost transcendentals (usually
// one or two per call: cheaper than the four-quadrant form).
LBDEM_HD inline double disk_rect_pieces(double r, double x0, double x1, double y0, double y1) {
  if (!(r > 0.0)) return 0.0;
  const double a = fmax(x0, -r), b = fmin(x1, r);
  if (!(a < b) || !(y0 < y1) || y0 >= r || y1 <= -r) return 0.0;
  const double a0 = fabs(y0), a1 = fabs(y1);
  // Crossing abscissae ±w (w = 0 at tangency: still a breakpoint); absent ones clamp to an end.
  const double w0 = a0 <= r ? sqrt(fmax((r - a0) * (r + a0), 0.0)) : 0.0;
  const double w1 = a1 <= r ? sqrt(fmax((r - a1) * (r + a1), 0.0)) : 0.0;
  double t[6] = {a, b, clampd(w0, a, b), clampd(-w0, a, b), clampd(w1, a, b), clampd(-w1, a, b)};
  sort_network(t);
  double area = 0.0;
  LBDEM_UNROLL
  for (int i = 0; i < 5; ++i) {
    const double t0 = t[i], t1 = t[i + 1];
    if (!(t1 > t0)) continue;
    const double tm = 0.5 * (t0 + t1);
    const double s = sqrt(fmax((r - tm) * (r + tm), 0.0));
    const bool top_circle = s < y1, bot_circle = -s > y0;
    const double top = top_circle ? s : y1, bot = bot_circle ? -s : y0;
    if (top <= bot) continue;  // the whole piece lies outside the disk
    const double arc = (top_circle || bot_circle) ? circle_primitive(t1, r) - circle_primitive(t0, r) : 0.0;
    const double wdt = t1 - t0;
    area += (top_circle ? arc : y1 * wdt) - (bot_circle ? -arc : y0 * wdt);
  }
  return area;
}

// ∫ over one smooth piece [a, a+h] of the slice area, after z = a + h(3u²−2u³).
template <int N>
LBDEM_HD inline double slice_piece(double R2, double a, double h, double x0, double x1, double y0, double y1) {
  const double* gl = gauss_table<N>();
  double piece = 0.0;
  for (int i = 0; i < N / 2; ++i) {
    const double xi = gl[i], wi = gl[N / 2 + i];
    LBDEM_UNROLL
    for (int sgn = -1; sgn <= 1; sgn += 2) {
      const double u = 0.5 * (1.0 + sgn * xi);           // node on [0, 1]
      const double z = a + h * u * u * (3.0 - 2.0 * u);  // smoothstep substitution
      const double jac = 6.0 * u * (1.0 - u);
      const double rho = sqrt(fmax(R2 - z * z, 0.0));
      if (rho > 0.0) {
        piece += 0.5 * wi * jac * disk_rect_pieces(rho, x0, x1, y0, y1);
      }
    }
  }
  return piece * h;
}

// Ball ∩ box with the box's z-range [z0, z1] not containing 0 on its inside when
// OneSided (then only the z > 0 events matter: 10 breakpoints, else 18).
template <int N, bool OneSided>
LBDEM_HD inline double ball_box_volume_impl(double R, double x0, double x1, double y0, double y1, double z0,
                                            double z1) {
  const double za = fmax(z0, -R), zb = fmin(z1, R);
  if (!(za < zb)) return 0.0;
  const double R2 = R * R;
  constexpr int M = OneSided ? 10 : 18;
  double zs[M];
  zs[0] = za;
  zs[1] = zb;
  // Events: the slice circle (radius² = R² − z²) touches an edge line (radius = |x| or |y|) or passes a
  // corner (radius² = x² + y²). Events that do not exist or fall outside [za, zb] clamp to an end and
  // make empty pieces.
  const double q[8] = {x0 * x0, x1 * x1, y0 * y0, y1 * y1, x0 * x0 + y0 * y0, x0 * x0 + y1 * y1,
                       x1 * x1 + y0 * y0, x1 * x1 + y1 * y1};
  LBDEM_UNROLL
  for (int e = 0; e < 8; ++e) {
    const double w = q[e] < R2 ? sqrt(R2 - q[e]) : zb;
    zs[2 + e] = clampd(w, za, zb);
    if constexpr (!OneSided) zs[10 + e] = clampd(q[e] < R2 ? -w : za, za, zb);
  }
  sort_network(zs);
  double vol = 0.0;
  for (int p = 0; p + 1 < M; ++p) {
    // zs[p], zs[p+1] through selects over constant indices (keeps zs in registers).
    double a = zs[0], b = zs[1];
    LBDEM_UNROLL
    for (int j = 1; j + 1 < M; ++j) {
      a = j == p ? zs[j] : a;
      b = j == p ? zs[j + 1] : b;
    }
    const double h = b - a;
    if (h > 0.0) vol += slice_piece<N>(R2, a, h, x0, x1, y0, y1);
  }
  return vol;
}

}  // namespace detail

// Area of the disk (centre at the origin, radius r) inside the rectangle
// [x0,x1]×[y0,y1], exact (closed form; detail::disk_quadrant_area gives the
// same by inclusion–exclusion, used in the tests as an independent check).
LBDEM_HD inline double disk_rect_area(double r, double x0, double x1, double y0, double y1) {
  return detail::disk_rect_pieces(r, x0, x1, y0, y1);
}

// Volume of the ball (centre at the origin, radius R) inside the box
// [x0,x1]×[y0,y1]×[z0,z1], by exact slices in z and Gauss–Legendre (N points per
// smooth piece, N ∈ {12, 16, 24}) after the smoothing substitution above.
template <int N = 24>
LBDEM_HD inline double ball_box_volume(double R, double x0, double x1, double y0, double y1, double z0, double z1) {
  if (!(R > 0.0)) return 0.0;
  if (z1 <= 0.0) {  // mirror in z: the ball is symmetric
    const double t = -z0;
    z0 = -z1;
    z1 = t;
  }
  if (z0 >= 0.0) return detail::ball_box_volume_impl<N, true>(R, x0, x1, y0, y1, z0, z1);
  return detail::ball_box_volume_impl<N, false>(R, x0, x1, y0, y1, z0, z1);
}

// --- cheap classification: exact 0 / 1 outside the interface band ----------

// Squared distance from the centre to the nearest point of the unit cell at r.
LBDEM_HD inline double cell_near2(double rx, double ry, double rz) {
  const double dx = fmax(fabs(rx) - 0.5, 0.0), dy = fmax(fabs(ry) - 0.5, 0.0), dz = fmax(fabs(rz) - 0.5, 0.0);
  return dx * dx + dy * dy + dz * dz;
}
// Squared distance from the centre to the farthest corner of the unit cell at r.
LBDEM_HD inline double cell_far2(double rx, double ry, double rz) {
  const double dx = fabs(rx) + 0.5, dy = fabs(ry) + 0.5, dz = fabs(rz) + 0.5;
  return dx * dx + dy * dy + dz * dz;
}

// --- per-cell fractions -------------------------------------------------------

// Exact area fraction of the unit square centred at (rx, ry) covered by a disk of radius R.
LBDEM_HD inline double exact_fraction_2d(double rx, double ry, double R) {
  if (cell_near2(rx, ry, 0.0) >= R * R) return 0.0;
  const double fx = fabs(rx) + 0.5, fy = fabs(ry) + 0.5;
  if (fx * fx + fy * fy <= R * R) return 1.0;
  return detail::clampd(disk_rect_area(R, rx - 0.5, rx + 0.5, ry - 0.5, ry + 0.5), 0.0, 1.0);
}

// Volume fraction of the unit cube centred at r covered by a ball of radius R
// (|error| ≤ 4e-12 with N = 24; ≤ 1.2e-10 with N = 16).
template <int N = 24>
LBDEM_HD inline double exact_fraction_3d(double rx, double ry, double rz, double R) {
  if (cell_near2(rx, ry, rz) >= R * R) return 0.0;
  if (cell_far2(rx, ry, rz) <= R * R) return 1.0;
  // Integrate along the axis where the cell is farthest from the centre: its
  // slices then meet the fewest edge/corner events.
  const double ax = fabs(rx), ay = fabs(ry), az = fabs(rz);
  double u = rx, v = ry, w = rz;
  if (ax >= ay && ax >= az) { u = ry; v = rz; w = rx; }
  else if (ay >= az) { u = rx; v = rz; w = ry; }
  const double vol = ball_box_volume<N>(R, u - 0.5, u + 0.5, v - 0.5, v + 0.5, w - 0.5, w + 0.5);
  return detail::clampd(vol, 0.0, 1.0);
}

// Radius of the linear ramp whose continuum integral equals the particle volume.
LBDEM_HD inline double linear_effective_radius_3d(double R) {
  // Solve Re³ + Re/4 = R³ by Newton from Re = R (converges in 3 steps for R ≥ 0.5).
  double re = R;
  for (int i = 0; i < 4; ++i) re -= (re * re * re + 0.25 * re - R * R * R) / (3.0 * re * re + 0.25);
  return re;
}
LBDEM_HD inline double linear_effective_radius_2d(double R) { return sqrt(fmax(R * R - 1.0 / 12.0, 0.0)); }

// Linear approximation from the signed distance of the cell centre; pass R_eff
// from linear_effective_radius_*() for the volume-normalised variant, or R.
LBDEM_HD inline double linear_fraction(double dist, double R_eff) { return detail::clampd(R_eff - dist + 0.5, 0.0, 1.0); }

}  // namespace lbdem::imb
