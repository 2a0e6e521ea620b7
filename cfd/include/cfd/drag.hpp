#pragma once
// Drag closures of the unresolved CFD-DEM mode, one normalised form for all.
//
// Convention (the one every law below is converted to). For a particle of
// diameter d [m] with velocity v in gas of density rho [kg/m^3], viscosity mu
// [Pa s], local gas fraction eps = 1 - phi and interstitial velocity u:
//
//   Re    = eps rho |u - v| d / mu                  (superficial-slip Reynolds number)
//   F     = F_drag / (3 pi mu d eps |u - v|)        (drag over Stokes drag at the superficial slip)
//   f_drag = 3 pi mu d eps F (u - v) = gamma (u - v) [N]
//
// F_drag is the drag of the Anderson-Jackson set I (model A) formulation: the
// particle also feels -V_p grad p (the pressure-gradient / buoyancy force,
// applied separately), and the gas momentum carries -eps grad p. For an
// isolated particle in Stokes flow F -> 1.
//
// Per source:
//  * Gidaspow (Yu et al. 2024, Eq. 15-17; Gidaspow 1994): a momentum-exchange
//    coefficient beta [kg/(m^3 s)] with f_drag = beta V_p / phi (u - v)
//    (Yu et al. 2024, Eq. 14 for one particle). Converted:
//    F = beta d^2 / (18 mu eps phi). Ergun branch (eps <= 0.8) in its standard
//    form beta = 150 phi^2 mu / (eps d^2) + 1.75 phi rho |u - v| / d (Eq. 15 as
//    printed puts the inertial term over eps d^2 too, which is not
//    dimensionally consistent): F = 25 phi / (3 eps^2) + 1.75 Re / (18 eps^2).
//    Wen-Yu branch (eps > 0.8): F = (C_D Re / 24) eps^-3.65 with C_D of Eq. 16.
//  * Wen & Yu (1966): the Gidaspow dilute branch at every eps.
//  * Di Felice (1994): f_drag = 1/2 C_D rho (pi d^2 / 4) eps^2 |u - v| (u - v)
//    eps^-chi, C_D = (0.63 + 4.8 / sqrt(Re))^2 (Dallavalle), chi = 3.7 - 0.65
//    exp(-(1.5 - log10 Re)^2 / 2): F = (C_D Re / 24) eps^-chi
//    = (0.63 sqrt(Re) + 4.8)^2 eps^-chi / 24. Its Stokes limit is 0.96 (the
//    Dallavalle C_D is 23.04/Re there, not 24/Re).
//  * Beetstra, van der Hoef & Kuipers (2007): already in this normalisation
//    (their F is the drag without the mean pressure-gradient part, over
//    3 pi mu d U_superficial, Re on the superficial slip).
//  * Tenneti, Garg & Subramaniam (2011): their F is the total fluid force on a
//    particle (drag plus the mean pressure-gradient part), normalised the same
//    way. In a homogeneous suspension the total force is F_drag / eps, so
//    F = eps F_Tenneti: this is the one factor of eps in which sources differ.
//
// All functions are LBDEM_HD so kernels call them; phi must lie in [0, 1),
// Re >= 0.
#include <cmath>
#include <string>

#include "core/error.hpp"
#include "core/hd.hpp"

namespace lbdem::cfd {

enum class DragLaw { Gidaspow, WenYu, DiFelice, Beetstra, Tenneti };

// Single-sphere drag of Schiller & Naumann as in Yu et al. 2024, Eq. 16,
// written as C_D Re / 24 (finite at Re = 0).
LBDEM_HD inline double schiller_naumann_cd_re_24(double re) {
  return re < 1000.0 ? 1.0 + 0.15 * std::pow(re, 0.687) : 0.44 * re / 24.0;
}

LBDEM_HD inline double drag_wen_yu(double phi, double re) {
  const double eps = 1.0 - phi;
  return schiller_naumann_cd_re_24(re) * std::pow(eps, -3.65);
}

// Ergun (eps <= 0.8) / Wen-Yu (eps > 0.8), Yu et al. 2024 Eq. 15-17.
LBDEM_HD inline double drag_gidaspow(double phi, double re) {
  const double eps = 1.0 - phi;
  if (eps > 0.8) return drag_wen_yu(phi, re);
  return (25.0 / 3.0) * phi / (eps * eps) + (1.75 / 18.0) * re / (eps * eps);
}

LBDEM_HD inline double drag_di_felice(double phi, double re) {
  const double eps = 1.0 - phi;
  const double chi = re > 0.0 ? 3.7 - 0.65 * std::exp(-0.5 * (1.5 - std::log10(re)) * (1.5 - std::log10(re))) : 3.7;
  const double s = 0.63 * std::sqrt(re) + 4.8;
  return s * s / 24.0 * std::pow(eps, -chi);
}

// Beetstra et al. 2007. The Re-dependent term is multiplied through by
// Re^(0.5 + 2 phi) so that it is finite (zero) at Re = 0.
LBDEM_HD inline double drag_beetstra(double phi, double re) {
  const double eps = 1.0 - phi;
  const double stokes = 10.0 * phi / (eps * eps) + eps * eps * (1.0 + 1.5 * std::sqrt(phi));
  if (re <= 0.0) return stokes;
  const double a = 0.5 + 2.0 * phi;
  const double ra = std::pow(re, a);
  const double num = re * ra * (1.0 / eps + 3.0 * eps * phi) + 8.4 * std::pow(re, 0.657) * ra;
  const double den = ra + std::pow(10.0, 3.0 * phi);
  return stokes + 0.413 / (24.0 * eps * eps) * num / den;
}

// Tenneti et al. 2011, their total-force F times eps (see above).
LBDEM_HD inline double drag_tenneti_total(double phi, double re) {
  const double eps = 1.0 - phi;
  const double e3 = eps * eps * eps;
  const double p3 = phi * phi * phi;
  return (1.0 + 0.15 * std::pow(re, 0.687)) / e3 + 5.81 * phi / e3 + 0.48 * std::cbrt(phi) / (e3 * eps) +
         p3 * re * (0.95 + 0.61 * p3 / (eps * eps));
}
LBDEM_HD inline double drag_tenneti(double phi, double re) { return (1.0 - phi) * drag_tenneti_total(phi, re); }

LBDEM_HD inline double drag_normalised(DragLaw law, double phi, double re) {
  switch (law) {
    case DragLaw::Gidaspow: return drag_gidaspow(phi, re);
    case DragLaw::WenYu: return drag_wen_yu(phi, re);
    case DragLaw::DiFelice: return drag_di_felice(phi, re);
    case DragLaw::Beetstra: return drag_beetstra(phi, re);
    case DragLaw::Tenneti: return drag_tenneti(phi, re);
  }
  return 0.0;
}

// Gas and particle properties the drag needs (SI).
struct DragParams {
  DragLaw law = DragLaw::Gidaspow;
  double rho = 1.2;   // gas density [kg/m^3]
  double mu = 1.8e-5;  // gas dynamic viscosity [Pa s]
};

// gamma [kg/s] with f_drag = gamma (u - v): 3 pi mu d eps F(phi, Re) at the
// slip speed |u - v| [m/s] of a particle of diameter d [m].
LBDEM_HD inline double drag_gamma(const DragParams& p, double phi, double d, double slip) {
  const double eps = 1.0 - phi;
  const double re = eps * p.rho * slip * d / p.mu;
  return 3.0 * 3.14159265358979323846 * p.mu * d * eps * drag_normalised(p.law, phi, re);
}

// Names as a case file writes them.
inline const char* to_string(DragLaw law) {
  switch (law) {
    case DragLaw::Gidaspow: return "gidaspow";
    case DragLaw::WenYu: return "wen_yu";
    case DragLaw::DiFelice: return "di_felice";
    case DragLaw::Beetstra: return "beetstra";
    case DragLaw::Tenneti: return "tenneti";
  }
  return "?";
}

// Parses a drag-law name; `key` is the case-file key (for the message).
inline DragLaw parse_drag_law(const std::string& key, const std::string& value) {
  for (DragLaw l : {DragLaw::Gidaspow, DragLaw::WenYu, DragLaw::DiFelice, DragLaw::Beetstra, DragLaw::Tenneti})
    if (value == to_string(l)) return l;
  throw ConfigError(key + ": unknown drag law '" + value +
                    "' (valid: gidaspow, wen_yu, di_felice, beetstra, tenneti)");
}

}  // namespace lbdem::cfd
