#pragma once
// The start-up of a sphere from rest in unbounded Stokes flow (issue 29): the
// exact velocity history of the Maxey-Riley equation at Re -> 0 with added
// mass and the Basset history force, and the Faddeeva function it needs.
//
// Equation (Maxey & Riley 1983 with the fluid at rest; Basset 1888): a sphere
// of radius a and density rho_p in a fluid of density rho and viscosity
// mu = rho nu, at rest until t = 0, then pulled by a constant force F (net of
// buoyancy):
//   m_p dv/dt = F - 6 pi mu a v - m_a dv/dt - 6 a^2 sqrt(pi rho mu) int_0^t v'(s) / sqrt(t - s) ds,
//   m_p = rho_p V_p, m_a = rho V_p / 2, V_p = 4/3 pi a^3, v(0) = 0.
// In the units u_T = F / (6 pi mu a) (Stokes's terminal velocity) and
// t_nu = a^2 / nu (T = t / t_nu), with beta = (m_p + m_a) / (6 pi mu a t_nu)
// = (2 r + 1) / 9, r = rho_p / rho:
//   beta u'(T) = 1 - u - pi^{-1/2} int_0^T u'(S) / sqrt(T - S) dS.          (1)
// Laplace transform (u(0) = 0; the transform of T^{-1/2} is sqrt(pi / s), so
// the history term becomes sqrt(s) s U):
//   U(s) = 1 / (s (beta s + sqrt(s) + 1)).
// With x = sqrt(s), beta x^2 + x + 1 = beta (x - x1)(x - x2),
// x1,2 = (-1 +- sqrt(1 - 4 beta)) / (2 beta) (complex conjugates for
// beta > 1/4, i.e. r > 5/8; real and negative below), x1 x2 = 1 / beta.
// Partial fractions in x:
//   1 / (x^2 (x - x1)(x - x2)) = A / x + B / x^2 + C / (x - x1) + D / (x - x2),
//   B = 1 / (x1 x2), A = B (1/x1 + 1/x2), C = 1 / (x1^2 (x1 - x2)), D = 1 / (x2^2 (x2 - x1)),
// A + C + D = 0 (no 1/x term at large x). With the transforms
// L^{-1}[1/s] = 1, L^{-1}[1/sqrt(s)] = 1/sqrt(pi T) and
// L^{-1}[1/(sqrt(s) - alpha)] = 1/sqrt(pi T) + alpha exp(alpha^2 T) erfc(-alpha sqrt(T))
// (Abramowitz & Stegun 29.3.43), the 1/sqrt(pi T) terms cancel and
//   u(T) / u_T = 1 + (C x1 E(x1) + D x2 E(x2)) / beta,   E(alpha) = exp(alpha^2 T) erfc(-alpha sqrt(T)).  (2)
// Since Re x1,2 < 0, z = -alpha sqrt(T) has Re z >= 0 and
// E = exp(z^2) erfc(z) = w(i z), the Faddeeva function at i z in the closed
// upper half-plane, where it is bounded (|w| <= 1) and evaluated without
// overflow. beta = 1/4 exactly (a double root, r = 5/8) is excluded.
//
// Limits (tests/imb/test_startup_reference.cpp checks (2) against each):
//   short time: U ~ 1/(beta s^2) (1 - 1/(beta sqrt(s))): u/u_T = T/beta - 4 T^{3/2} / (3 sqrt(pi) beta^2) + O(T^2),
//     i.e. u = F t / (m_p + m_a) to leading order;
//   long time: U = 1/s - 1/sqrt(s) + (1 - beta) + (2 beta - 1) sqrt(s) + ...:
//     u/u_T = 1 - 1/sqrt(pi T) - (2 beta - 1) T^{-3/2} / (2 sqrt(pi)) + O(T^{-5/2}),
//     in dimensional form u_T (1 - c / sqrt(t)) with c = a / sqrt(pi nu), whatever the density ratio;
//   the direct integration of (1) (startup_brute_force below).
#include <cmath>
#include <complex>
#include <stdexcept>
#include <vector>

namespace lbdem::bench {

// The Faddeeva function w(z) = exp(-z^2) erfc(-i z) for Im z >= 0.
//
// |z| >= 8: Laplace's continued fraction (Gautschi 1970, SIAM J. Numer. Anal.
//   7, 187; Abramowitz & Stegun 7.1.4 with the integral of 7.1.4):
//     w(z) = (i / sqrt(pi)) / (z - (1/2) / (z - 1 / (z - (3/2) / (z - 2 / (z - ...))))),
//   evaluated from a tail of 60 levels (at |z| >= 8 the fraction has converged
//   to round-off within ~40 levels everywhere in the closed upper half-plane,
//   the real axis the slowest).
// |z| < 8: the trapezoidal rule with step h on the integral representation
//     w(z) = (i / pi) int e^{-t^2} / (z - t) dt          (Im z > 0),
//   plus the exact contribution of the integrand's pole at t = z (Chiarella &
//   Reichel 1968; Matta & Reichel 1971, Math. Comp. 25, 339): the trapezoid
//   sum h sum_n f(nh) of f(t) = e^{-t^2}/(z - t) equals (1/2i) times the
//   contour integral of f(t) cot(pi t / h) around the real axis; splitting
//   cot into -i (upper line) and +i (lower line) gives the integral itself,
//   and what is left is the residue of f (cot + i) at the pole t = z (upper
//   line moved to +i infinity) plus the lower line moved to Im t = -pi/h,
//   which is O(exp(-pi^2 / h^2)). Hence
//     w(z) = (i h / pi) sum_n e^{-n^2 h^2} / (z - n h) + 2 e^{-z^2} / (1 - e^{-2 pi i z / h}) + O(e^{-pi^2/h^2}).
//   h = 1/2: e^{-pi^2/h^2} = 7e-18; terms to |n| h <= 6.5 (e^{-42} of the
//   largest). The formula holds on the real axis too (the pole term is then
//   the principal value's jump); at z = n h exactly the sum's term and the
//   pole term are both singular, so such points are nudged by 1e-9 h (w is
//   smooth there: a relative change of ~1e-9 h |w'| / |w| < 1e-8).
//   The pole term's size e^{y^2 - x^2 - 2 pi y / h} stays below 1 for |z| < 8,
//   so no cancellation loses digits.
// The two parts are separate functions so that a test can compare them where
// both hold (an annulus around |z| = 8).
inline std::complex<double> faddeeva_w_fraction(std::complex<double> z) {
  std::complex<double> f = z;
  for (int k = 60; k >= 1; --k) f = z - (0.5 * k) / f;
  return std::complex<double>(0, 1.0 / std::sqrt(3.14159265358979323846)) / f;
}

inline std::complex<double> faddeeva_w_trapezoid(std::complex<double> z) {
  using C = std::complex<double>;
  const double pi = 3.14159265358979323846;
  const double h = 0.5;
  const int N = 13;  // |t_n| <= 6.5 + h
  // Nodes t_n = (n + s) h with s = 0 or 1/2, whichever lies farther from Re z.
  const double q = z.real() / h;
  const double s = std::abs(q - std::round(q)) < 0.25 ? 0.5 : 0.0;
  C sum = 0;
  for (int n = -N - 1; n <= N; ++n) {
    const double t = (n + s) * h;
    sum += std::exp(-t * t) / (z - t);
  }
  const C pole = 2.0 * std::exp(-z * z) / (1.0 - std::exp(C(0, -2 * pi / h) * (z - s * h)));
  return C(0, h / pi) * sum + pole;
}

inline std::complex<double> faddeeva_w(std::complex<double> z) {
  if (z.imag() < 0) throw std::domain_error("faddeeva_w: Im z < 0 (only the upper half-plane is implemented)");
  return std::abs(z) >= 8.0 ? faddeeva_w_fraction(z) : faddeeva_w_trapezoid(z);
}

// exp(z^2) erfc(z) for Re z >= 0: w(i z).
inline std::complex<double> erfcx_complex(std::complex<double> z) { return faddeeva_w(std::complex<double>(-z.imag(), z.real())); }

// Eq. (2): the velocity over Stokes's terminal velocity at T = t nu / a^2 of a
// sphere of density ratio r = rho_p / rho started from rest under a constant force.
class StartupReference {
 public:
  explicit StartupReference(double density_ratio) : r_(density_ratio), beta_((2 * density_ratio + 1) / 9.0) {
    if (!(density_ratio > 0)) throw std::invalid_argument("startup reference: density ratio must be > 0");
    const std::complex<double> disc = std::sqrt(std::complex<double>(1 - 4 * beta_, 0));
    if (std::abs(disc) < 1e-6)
      throw std::invalid_argument("startup reference: density ratio 5/8 (a double root) is not supported");
    x1_ = (-1.0 + disc) / (2 * beta_);
    x2_ = (-1.0 - disc) / (2 * beta_);
    c1_ = 1.0 / (x1_ * x1_ * (x1_ - x2_));
    c2_ = 1.0 / (x2_ * x2_ * (x2_ - x1_));
  }
  double beta() const { return beta_; }
  double density_ratio() const { return r_; }
  // u / u_T at T = t nu / a^2.
  double operator()(double T) const {
    if (T <= 0) return 0.0;
    const double s = std::sqrt(T);
    const std::complex<double> v = c1_ * x1_ * erfcx_complex(-x1_ * s) + c2_ * x2_ * erfcx_complex(-x2_ * s);
    return 1.0 + v.real() / beta_;
  }
  // The short- and long-time expansions (see the top of the file).
  double short_time(double T) const { return T / beta_ - 4 * std::pow(T, 1.5) / (3 * std::sqrt(M_PI) * beta_ * beta_); }
  double long_time(double T) const {
    return 1 - 1 / std::sqrt(M_PI * T) - (2 * beta_ - 1) * std::pow(T, -1.5) / (2 * std::sqrt(M_PI));
  }

 private:
  double r_, beta_;
  std::complex<double> x1_, x2_, c1_, c2_;
};

// Direct integration of (1) on a uniform grid T_n = n h: u' is taken constant
// on each interval (value u'_n on (T_{n-1}, T_n]), so the history integral is
// exact for that u': sum_j u'_j * 2 (sqrt(T_n - T_{j-1}) - sqrt(T_n - T_j)),
// the 1/sqrt singularity integrated analytically (product integration). (1) at
// T_n with u_n = u_{n-1} + h u'_n is linear in u'_n:
//   u'_n (beta + h + 2 sqrt(h / pi)) = 1 - u_{n-1} - pi^{-1/2} sum_{j<n} u'_j w_nj.
// First order in h (an implicit Euler step with exact product weights): the
// error halves with h. O(n^2) work. Returns u / u_T at T_0 .. T_n.
inline std::vector<double> startup_brute_force(double density_ratio, double T_end, double h) {
  const double beta = (2 * density_ratio + 1) / 9.0;
  const auto n = static_cast<std::size_t>(std::ceil(T_end / h));
  std::vector<double> u(n + 1, 0.0), du(n + 1, 0.0), sq(n + 1);
  for (std::size_t k = 0; k <= n; ++k) sq[k] = std::sqrt(double(k) * h);
  const double rpi = 1 / std::sqrt(M_PI);
  for (std::size_t m = 1; m <= n; ++m) {
    double hist = 0;
    for (std::size_t j = 1; j < m; ++j) hist += du[j] * 2 * (sq[m - j + 1] - sq[m - j]);
    du[m] = (1 - u[m - 1] - rpi * hist) / (beta + h + 2 * rpi * std::sqrt(h));
    u[m] = u[m - 1] + h * du[m];
  }
  return u;
}

// The same start-up in a periodic cube of edge L = ell a, one sphere per cube,
// with the balancing mean pressure gradient (lbdem's fully periodic coupled
// runs), in the frame that accelerates with the fluid far from the sphere
// (startup_case.hpp: there the sphere is pushed by F_eff and the fluid has no
// body force). Velocities over u_T = F_eff / (6 pi mu a), T = t nu / a^2.
//
// Model: the sphere as a point force for the images (its own flow is the
// unbounded Maxey-Riley sphere's). The fluid receives f(t) = -F_h = F_eff -
// m_p dv/dt per cube. In the periodic cube the unsteady Stokes velocity of
// that force at the sphere's place, less the unbounded part the sphere's own
// equation already holds, is
//   w(t) = (1/rho) int_0^t G(t - s) f(s) ds,
//   G(tau) = 1/(V - V_p) + (2/3) [ (1/V) sum_{k != 0} e^{-nu k^2 tau} - (4 pi nu tau)^{-3/2} ],
// k over the reciprocal lattice 2 pi n / L: the k = 0 mode (the mean flow of
// the fluid, which holds the momentum the cube keeps, over the fluid's volume
// V - V_p: then the frame of zero total momentum accelerates at exactly
// F / (rho V) against this one, as the lab frame does) plus the k != 0 modes less the unbounded
// integral; each mode carries (I - k k / k^2) f, and on a cubic lattice
// sum_k kk/k^2 h(|k|) = (1/3) I sum_k h(|k|), hence the 2/3. By Poisson
// summation the bracket is sum_{R != 0} (4 pi nu tau)^{-3/2} e^{-R^2/(4 nu tau)}
// - 1/V (R over the images): at short times G = 1/(3V) (to O(phi)), the images'
// irrotational (dipole) flows, which carry a third of the impulse given to
// the fluid back to the sphere; at long times the sum over images is
// Hasimoto's: the steady velocity in the lab frame tends to
// u_T (1 - 1.7601 phi^{1/3}) (the Oseen lattice sum, 2.8373 a / L), the
// leading term of Hasimoto's 1/K. Neglected: the images' flow's variation
// over the sphere (Faxen, O((a/L)^3)) and the other O(phi) effects of the
// sphere's volume on the images' flow (Hasimoto's + phi).
// In units of a, t_nu and F_eff (ell = L / a): Gh(T) = a^3 G = 1/(ell^3 - 4 pi/3) +
// (2/3) [ sum_{n != 0} (4 pi T)^{-3/2} e^{-ell^2 |n|^2 / (4 T)} - ell^{-3} ] (real space,
// T <= ell^2 / (4 pi)), or the bracket as
// ell^{-3} sum_{n != 0} e^{-4 pi^2 |n|^2 T / ell^2} - (4 pi T)^{-3/2}
// (reciprocal space, beyond); at the switch both series' terms fall as
// e^{-pi |n|^2}, n in [-4, 4]^3 leaves e^{-16 pi}.
// The sphere in the ambient flow w (Maxey & Riley: drag, added mass and
// Basset on the slip v - w, the fluid's acceleration force m_f dw/dt):
//   beta v' = 1 - (v - w) - pi^{-1/2} int_0^T (v - w)' / sqrt(T - S) dS + (1/3) w',
//   w = 6 pi int_0^T Gh(T - S) (1 - (2 r / 9) v'(S)) dS,
// ((m_f + m_a) / (6 pi mu a t_nu) = 1/3, m_p / (6 pi mu a t_nu) = 2 r / 9),
// integrated like startup_brute_force with w taken explicitly (f at the
// previous step; w is a correction of a few %), first order in h, and
// Richardson-extrapolated from h and h/2.
inline double periodic_kernel(double ell, double T) {
  const double pi = 3.14159265358979323846;
  const double e3 = ell * ell * ell, k0 = 1.0 / (e3 - 4 * pi / 3);
  double sum = 0;
  if (T <= ell * ell / (4 * pi)) {
    if (T <= 0) return k0 - 2.0 / (3 * e3);
    for (int i = -4; i <= 4; ++i)
      for (int j = -4; j <= 4; ++j)
        for (int k = -4; k <= 4; ++k) {
          const int n2 = i * i + j * j + k * k;
          if (n2 > 0) sum += std::exp(-ell * ell * n2 / (4 * T));
        }
    return k0 + (2.0 / 3.0) * (sum * std::pow(4 * pi * T, -1.5) - 1 / e3);
  }
  for (int i = -4; i <= 4; ++i)
    for (int j = -4; j <= 4; ++j)
      for (int k = -4; k <= 4; ++k) {
        const int n2 = i * i + j * j + k * k;
        if (n2 > 0) sum += std::exp(-4 * pi * pi * n2 * T / (ell * ell));
      }
  return k0 + (2.0 / 3.0) * (sum / e3 - std::pow(4 * pi * T, -1.5));
}

// One integration of the periodic model: v / u_T at T_n = n h (accelerated frame).
inline std::vector<double> startup_periodic_once(double density_ratio, double ell, double T_end, double h) {
  const double beta = (2 * density_ratio + 1) / 9.0, bm = 2 * density_ratio / 9.0, bf = 1.0 / 3.0;
  const auto n = static_cast<std::size_t>(std::ceil(T_end / h));
  std::vector<double> v(n + 1, 0.0), dv(n + 1, 0.0), w(n + 1, 0.0), dq(n + 1, 0.0), sq(n + 1), G(n + 1);
  for (std::size_t k = 0; k <= n; ++k) {
    sq[k] = std::sqrt(double(k) * h);
    G[k] = periodic_kernel(ell, (double(k) - 0.5) * h);  // at the interval midpoints (k >= 1)
  }
  const double rpi = 1 / std::sqrt(M_PI), c = 2 * rpi * std::sqrt(h);
  for (std::size_t m = 1; m <= n; ++m) {
    // w at T_m: midpoint rule over the intervals, f on interval m from the previous step.
    double conv = G[1] * (1 - bm * dv[m - 1]);
    for (std::size_t j = 1; j < m; ++j) conv += G[m - j + 1] * (1 - bm * dv[j]);
    w[m] = 6 * M_PI * h * conv;
    const double dw = (w[m] - w[m - 1]) / h;
    double hist = 0;
    for (std::size_t j = 1; j < m; ++j) hist += dq[j] * 2 * (sq[m - j + 1] - sq[m - j]);
    const double q_prev = v[m - 1] - w[m - 1];
    dv[m] = (1 - q_prev + (h + c) * dw - rpi * hist + bf * dw) / (beta + h + c);
    dq[m] = dv[m] - dw;
    v[m] = v[m - 1] + h * dv[m];
  }
  return v;
}

// The periodic model on the grid T_n = n h, Richardson-extrapolated (2 v(h/2) - v(h)).
inline std::vector<double> startup_periodic(double density_ratio, double ell, double T_end, double h) {
  const auto a = startup_periodic_once(density_ratio, ell, T_end, h);
  const auto b = startup_periodic_once(density_ratio, ell, T_end, 0.5 * h);
  std::vector<double> v(a.size());
  for (std::size_t k = 0; k < a.size(); ++k) v[k] = 2 * b[2 * k] - a[k];
  return v;
}

}  // namespace lbdem::bench
