// Drag closures (cfd/drag.hpp) in the one normalisation
// F = F_drag / (3 pi mu d eps |u - v|), Re = eps rho |u - v| d / mu.
//
// References:
//  * each law's published formula, evaluated independently in its own
//    normalisation (beta for Gidaspow / Wen-Yu, the force for Di Felice, F for
//    Beetstra 2007 and Tenneti 2011; formulas as in the second paper, Yu et al.
//    2024 Eq. 14-17, and the cited sources) and converted by hand: relative
//    tolerance 1e-12 (the same arithmetic in another order);
//  * Stokes limit F -> 1 (phi -> 0, Re -> 0) for laws built on 24/Re;
//  * the single particle settling case DEM06 (terminal slip 0.457402 m/s for
//    d = 100 um, rho_s = 2000, air): drag balances the buoyant weight to the
//    6 significant digits the slip is given with (tolerance 1e-5);
//  * Ergun's pressure drop from the Gidaspow dense branch (set I balance
//    eps grad p = -beta u), to round-off;
//  * Tenneti's total-force F converted by eps against Beetstra in the Stokes
//    and moderate-Re range where both fit the same random-array simulations:
//    within 10 %; unconverted they differ by more than 15 %.
#include <gtest/gtest.h>

#include <cmath>

#include "cfd/drag.hpp"

using namespace lbdem;
using namespace lbdem::cfd;

namespace {
constexpr double kPi = 3.14159265358979323846;
void expect_rel(double got, double want, double tol) { EXPECT_NEAR(got, want, tol * std::fabs(want)) << got; }
}  // namespace

TEST(Drag, PublishedFormsConverted) {
  // Evaluated from beta (Gidaspow 1994) / the force (Di Felice 1994) / F
  // (Beetstra 2007, Tenneti 2011) at unit rho, d, mu and converted.
  expect_rel(drag_wen_yu(0.1, 10), 2.540757587079204, 1e-12);
  expect_rel(drag_wen_yu(0.15, 2000), 66.35785690316537, 1e-12);  // C_D = 0.44 branch
  expect_rel(drag_gidaspow(0.1, 10), 2.540757587079204, 1e-12);   // eps > 0.8: Wen-Yu
  expect_rel(drag_gidaspow(0.4, 10), 11.95987654320988, 1e-12);   // eps <= 0.8: Ergun
  expect_rel(drag_gidaspow(0.3, 100), 24.943310657596374, 1e-12);
  expect_rel(drag_di_felice(0.2, 10), 3.8618143550577297, 1e-12);
  expect_rel(drag_di_felice(0.4, 100), 25.352310610977955, 1e-12);
  expect_rel(drag_beetstra(0.3, 10), 8.27936128272357, 1e-12);
  expect_rel(drag_beetstra(0.5, 100), 50.413427784678476, 1e-12);
  expect_rel(drag_tenneti(0.3, 10), 8.20967933823754, 1e-12);
  expect_rel(drag_tenneti(0.5, 100), 40.707078204693495, 1e-12);
  // The dispatcher picks the same functions.
  EXPECT_EQ(drag_normalised(DragLaw::Beetstra, 0.3, 10), drag_beetstra(0.3, 10));
  EXPECT_EQ(drag_normalised(DragLaw::Tenneti, 0.3, 10), drag_tenneti(0.3, 10));
  EXPECT_EQ(drag_normalised(DragLaw::DiFelice, 0.3, 10), drag_di_felice(0.3, 10));
  EXPECT_EQ(drag_normalised(DragLaw::WenYu, 0.3, 10), drag_wen_yu(0.3, 10));
  EXPECT_EQ(drag_normalised(DragLaw::Gidaspow, 0.3, 10), drag_gidaspow(0.3, 10));
}

TEST(Drag, StokesLimit) {
  // F -> 1 for an isolated sphere in creeping flow; Di Felice's Dallavalle
  // C_D gives 4.8^2 / 24 = 0.96 there.
  for (DragLaw l : {DragLaw::Gidaspow, DragLaw::WenYu, DragLaw::Beetstra, DragLaw::Tenneti})
    EXPECT_NEAR(drag_normalised(l, 0.0, 0.0), 1.0, 1e-14) << to_string(l);
  EXPECT_NEAR(drag_di_felice(0.0, 0.0), 0.96, 1e-14);
  // Approaching the limit at phi = 1e-6, Re = 1e-6: the slowest terms are
  // Beetstra's 1.5 sqrt(phi) = 1.5e-3 and Tenneti's 0.48 phi^(1/3) = 4.8e-3.
  EXPECT_NEAR(drag_beetstra(1e-6, 1e-6), 1.0, 2e-3);
  EXPECT_NEAR(drag_tenneti(1e-6, 1e-6), 1.0, 6e-3);
  EXPECT_NEAR(drag_wen_yu(1e-6, 1e-6), 1.0, 1e-4);
  // Finite at Re = 0 for every phi (no 0 * inf).
  for (DragLaw l : {DragLaw::Gidaspow, DragLaw::WenYu, DragLaw::DiFelice, DragLaw::Beetstra, DragLaw::Tenneti})
    EXPECT_TRUE(std::isfinite(drag_normalised(l, 0.4, 0.0))) << to_string(l);
}

TEST(Drag, SingleParticleTerminalSlip) {
  // DEM06 (REFERENCES: terminal slip 0.457402 m/s, Re_p = 3.0493).
  const double d = 100e-6, rho_s = 2000, g = 9.80665;
  DragParams p;
  p.law = DragLaw::WenYu;
  p.rho = 1.2;
  p.mu = 1.8e-5;
  const double slip = 0.457402;
  const double weight = (rho_s - p.rho) * kPi * d * d * d / 6 * g;
  for (DragLaw l : {DragLaw::Gidaspow, DragLaw::WenYu, DragLaw::Tenneti}) {
    p.law = l;
    expect_rel(drag_gamma(p, 0.0, d, slip) * slip, weight, 1e-5);
  }
  EXPECT_NEAR(p.rho * slip * d / p.mu, 3.0493, 1e-4);
}

TEST(Drag, GidaspowDenseBranchIsErgun) {
  // A fixed bed at superficial velocity U: set I momentum balance
  // eps dp/dz = -beta u with u = U / eps and beta V_p / phi = gamma per
  // particle, phi / V_p particles per volume. Ergun:
  // -dp/dz = 150 phi^2 mu U / (eps^3 d^2) + 1.75 phi rho U^2 / (eps^3 d).
  DragParams p;
  p.law = DragLaw::Gidaspow;
  p.rho = 1.225;
  p.mu = 1.8e-5;
  const double d = 1.2e-3, vp = kPi * d * d * d / 6;
  for (double phi : {0.2, 0.4, 0.6}) {
    for (double U : {0.01, 0.3, 1.5}) {
      const double eps = 1 - phi, u = U / eps;
      const double beta = drag_gamma(p, phi, d, u) * phi / vp;
      const double dpdz = -beta * u / eps;
      const double ergun = 150 * phi * phi * p.mu * U / (eps * eps * eps * d * d) +
                           1.75 * phi * p.rho * U * U / (eps * eps * eps * d);
      expect_rel(-dpdz, ergun, 1e-12);
    }
  }
}

TEST(Drag, TennetiNormalisationAgainstBeetstra) {
  for (double phi : {0.2, 0.3, 0.4, 0.5}) {
    for (double re : {0.0, 1.0, 10.0}) {
      const double b = drag_beetstra(phi, re);
      EXPECT_NEAR(drag_tenneti(phi, re) / b, 1.0, 0.10) << phi << " " << re;
      EXPECT_GT(std::fabs(drag_tenneti_total(phi, re) / b - 1.0), 0.15) << phi << " " << re;
    }
  }
}

TEST(Drag, LawNamesAndBadInput) {
  for (DragLaw l : {DragLaw::Gidaspow, DragLaw::WenYu, DragLaw::DiFelice, DragLaw::Beetstra, DragLaw::Tenneti})
    EXPECT_EQ(parse_drag_law("gas.drag", to_string(l)), l);
  try {
    parse_drag_law("gas.drag", "ergun");
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("gas.drag"), std::string::npos);
    EXPECT_NE(m.find("ergun"), std::string::npos);
    EXPECT_NE(m.find("beetstra"), std::string::npos);
  }
}
