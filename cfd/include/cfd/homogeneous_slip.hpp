#pragma once
// The slip of a homogeneous suspension under the Wen-Yu drag (cfd/drag.hpp).

namespace lbdem::cfd {

// The slip speed w = |u_f - v_p| (interstitial fluid velocity minus particle
// velocity) at which the Wen & Yu (1966) drag on one particle of a homogeneous
// suspension at solid fraction phi balances its net weight W = (m_p - rho_f
// V_p) |g|: the steady state of a weight-balanced periodic suspension, where
// the fluid body force, not a pressure gradient, holds the weight (the
// particles feel no mean pressure gradient beyond their buoyancy). The drag is
// that of cfd/drag.hpp (Yu et al. 2024, Eq. 16-17, the Wen-Yu branch):
//   F(w) = 3 pi mu d w (1 - phi)^-2.65 (1 + 0.15 Re^0.687),
//   Re = (1 - phi) rho_f d w / mu,
// so in the Stokes limit w = W (1 - phi)^2.65 / (3 pi mu d). Any consistent
// units (lattice: rho_f = 1, mu = nu). Returns 0 for W <= 0. For a 2D
// suspension the particles scene evaluates it for spheres of the disks'
// diameter and density at the areal fraction, as the first paper compares its
// 2D suspension with Wen & Yu (its Table 2 gives one terminal velocity for both).
double wen_yu_slip(double phi, double d, double rho_f, double mu, double net_weight);
double wen_yu_drag(double phi, double d, double rho_f, double mu, double w);

}  // namespace lbdem::cfd
