#pragma once
// Linear spring-dashpot contact with optional tangential spring, history and
// Coulomb limit: the one evaluator every force path and the walls call.
//
// Normal (Yu et al. 2024, Eq. 7): F_n,i = -(k_n delta + eta_n d(delta)/dt) n,
// n the unit vector from i to its partner, delta > 0 the overlap [m].
// Damping from restitution e (the paper's Eqs. 9-11 carry typos; the correct
// pair, checked numerically in tests/dem/test_contact_law.cpp, is
//   eta_n = 2 beta sqrt(k_n m_eff),  beta = |ln e| / sqrt(pi^2 + ln^2 e),
//   t_c   = pi / (omega_0 sqrt(1 - beta^2)),  omega_0 = sqrt(k_n / m_eff),
// and then exp(-eta_n t_c / (2 m_eff)) = e exactly).
// Tangential (Eqs. 8, 12, 13): history xi integrates the tangential relative
// velocity at the contact point; it is rotated into the current tangent plane
// each step (keeping its length); F_t = -k_t xi - eta_t v_t, capped at
// mu |F_n| (then xi is reset to the value that gives the capped force).
#include <cmath>

#include "core/hd.hpp"
#include "core/vec.hpp"

namespace lbdem::dem {

inline constexpr double kPi = 3.14159265358979323846;

struct ContactLaw {
  double kn = 0;        // normal stiffness [N/m]
  double eta_coef = 0;  // eta_n = eta_coef * sqrt(m_eff), eta_coef = 2 beta sqrt(kn) [sqrt(N/m)]
  double kt = 0;        // tangential stiffness [N/m]
  double eta_t_ratio = 0;  // eta_t = eta_t_ratio * eta_n
  double mu = 0;        // Coulomb friction coefficient
};

// beta(e) of the linear spring-dashpot; e in (0, 1].
inline double damping_ratio_from_restitution(double e) {
  const double l = std::log(e);
  return -l / std::sqrt(kPi * kPi + l * l);
}
// Duration of a binary contact [s] for stiffness k, effective mass m_eff, restitution e.
inline double collision_time(double k, double m_eff, double e) {
  const double b = damping_ratio_from_restitution(e);
  return kPi / (std::sqrt(k / m_eff) * std::sqrt(1.0 - b * b));
}
inline ContactLaw make_contact_law(double kn, double e, double kt_ratio, double eta_t_ratio, double mu) {
  ContactLaw c;
  c.kn = kn;
  c.eta_coef = 2.0 * damping_ratio_from_restitution(e) * std::sqrt(kn);
  c.kt = kt_ratio * kn;
  c.eta_t_ratio = eta_t_ratio;
  c.mu = mu;
  return c;
}

// Force on particle i [N] from one contact.
//   n     unit vector from i towards the partner
//   delta overlap > 0 [m]
//   meff  effective mass [kg]
//   vrel  velocity of i's surface relative to the partner's at the contact point [m/s]
//   xi    tangential history [m] (read and updated; unused when !Friction)
//   ft    tangential part of the returned force (output; unused when !Friction)
template <bool Friction>
LBDEM_HD LBDEM_FORCEINLINE Vec3d contact_force(const ContactLaw& law, const Vec3d& n, double delta, double meff,
                                              const Vec3d& vrel, Vec3d& xi, double dt, Vec3d& ft) {
  const double vn = dot(vrel, n);  // approach speed d(delta)/dt
  double eta_n = law.eta_coef * sqrt(meff);
  // Onset / release step. In velocity Verlet the force of step n+1 stands
  // for the impulse over the window [t_{n+1/2}, t_{n+3/2}] (midpoint rule),
  // but the contact starts (ends) inside it, at t_{n+1} -/+ tau with
  // tau = delta/|vn| (overlap linear in time over one step). Integrating the
  // spring and the dashpot exactly over the part of the window in contact
  // (plus the part of the previous window that step missed when
  // 1/2 < s = tau/dt < 1) removes the O(dt) impulse error of switching the
  // force on and off between steps (derived here; it is symmetric in time, so
  // release is treated the same way).
  const double avn = fabs(vn) * dt;
  double fn;  // magnitude along -n
  if (delta < avn) {
    const double sf = delta / avn;
    eta_n *= 0.5 + sf;
    const double deff = sf < 0.5 ? 0.5 * (sf + 0.5) * (sf + 0.5) * avn : delta + 0.5 * (sf - 0.5) * (sf - 0.5) * avn;
    fn = law.kn * deff + eta_n * vn;
  } else {
    fn = law.kn * delta + eta_n * vn;
  }
  Vec3d f = n * (-fn);
  if constexpr (Friction) {
    const Vec3d vt = vrel - n * vn;
    const double xi2 = dot(xi, xi);
    if (xi2 == 0.0) {
      // Eq. 12: a new contact has slid only since the surfaces met, a fraction
      // delta/vn of the step.
      const double tau = (vn > 0.0) ? fmin(delta / vn, dt) : dt;
      xi = vt * tau;
    } else {
      // Rotate the old history into the current tangent plane, keep its length (Eq. 13).
      Vec3d p = xi - n * dot(xi, n);
      const double p2 = dot(p, p);
      if (p2 > 0.0) p *= sqrt(xi2 / p2);
      xi = p + vt * dt;
    }
    const double eta_t = law.eta_t_ratio * eta_n;
    Vec3d t = xi * (-law.kt) - vt * eta_t;
    const double t2 = dot(t, t);
    const double lim = law.mu * fabs(fn);
    if (t2 > lim * lim) {
      t *= lim / sqrt(t2);
      // Sliding: history consistent with the capped force.
      xi = (t + vt * eta_t) * (-1.0 / law.kt);
    }
    ft = t;
    f += t;
  } else {
    (void)xi;
    (void)dt;
    (void)ft;
  }
  return f;
}

}  // namespace lbdem::dem
