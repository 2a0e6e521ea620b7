// Torque on a sphere rotating at constant angular velocity in a periodic box
// (PSM, D3Q19), against the Stokes couple corrected for the periodic images.
//
// Reference. An isolated sphere rotating at Omega in Stokes flow feels
// T = -8 pi mu a^3 Omega (Lamb). In a simple cubic array of period L the image
// rotlets add a uniform counter-rotation: with the velocity field written as a
// Fourier series (the k = 0 mode excluded because the mean velocity gradient
// of a periodic field vanishes), the images' vorticity at the sphere is
// -T_s / (3 mu L^3), T_s the couple the sphere exerts on the fluid; Faxen's
// law T_s = 8 pi mu a^3 (Omega - omega_img / 2) then gives
//   T_s = 8 pi mu a^3 Omega / (1 - phi),   phi = (4/3) pi a^3 / L^3,
// with the next correction O(phi^{10/3}) (the O(phi^2) stresslet term is
// killed by cubic symmetry: the lattice sum of a traceless rank-2 tensor
// vanishes), < 1e-4 here. We use this reference (derived, see the comment;
// it is the rotational analogue of Hasimoto's 1959 sum for translation).
//
// Runs: d/l = 8 (a = 4), tau = 0.6, TRT Lambda = 1e-3, Omega = 2.5e-4 about z
// (rotational Reynolds number Omega a^2 / nu = 0.12: inertia enters at
// O(Re^2) for the couple), fluid initially at rest, 3500 steps (the couple
// then changes by < 2e-6 per 500 steps at L = 20, < 1.2e-4 at L = 28).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "psm_scene.hpp"

using namespace lbdem;

namespace {

struct RotationResult {
  double T = 0, T_ref = 0;   // couple on the sphere about z, reference (both signed as on the particle)
  double F = 0;              // |net force|
  double Txy = 0;            // |torque about x and y|
  double phi = 0;
};

RotationResult rotate(long L, double offset) {
  const double a = 4, tau = 0.6, Omega = 2.5e-4;
  const double mu = (tau - 0.5) / 3.0;  // rho = 1
  imb::PsmOptions opt;
  opt.map.method = imb::FractionMethod::Exact;
  const double c = 0.5 * L + offset;
  test::PsmSphere s;
  s.x = c;
  s.y = c + 0.5 * offset;
  s.z = c - 0.3 * offset;
  s.r = a;
  s.wz = Omega;
  test::PsmScene scene(test::psm_box(L, L, L, tau, 1e-3), Backend::Host, 2, {s}, opt);
  scene.map();  // the sphere spins in place: its fractions do not change
  for (int i = 0; i < 3500; ++i) scene.step();
  const auto f = scene.forces();
  RotationResult r;
  r.phi = 4.0 / 3.0 * M_PI * a * a * a / double(L * L * L);
  r.T_ref = -8 * M_PI * mu * a * a * a * Omega / (1 - r.phi);
  r.T = f[5];
  r.F = std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
  r.Txy = std::sqrt(f[3] * f[3] + f[4] * f[4]);
  std::printf("L=%ld (phi %.4f): T/T_ref = %.5f (Stokes alone: %.5f), |F| a/|T| = %.2e, |Txy|/|T| = %.2e\n", L, r.phi,
              r.T / r.T_ref, r.T / r.T_ref / (1 - r.phi), r.F * a / std::abs(r.T), r.Txy / std::abs(r.T));
  return r;
}

}  // namespace

// Two box sizes, chi = d/L = 0.4 and 0.286 (phi = 0.0335, 0.0122), the
// sphere off the lattice's symmetry points (so nothing is zero by symmetry).
// Measured (host, fp64): T/T_ref = 0.98801 (L = 20) and 0.98850 (L = 28);
// against the bare Stokes couple (no periodic correction) 1.0223 and 1.0007.
//  - |T/T_ref - 1| < 2 %: the PSM error at d/l = 8 is an effective-radius
//    offset (the couple goes as a^3: -1.2 % is -0.016 cells), of the same kind
//    and size as the drag error at d/l = 8 (-1.1 %, test_psm_drag.cpp); 2 %
//    leaves ~40 % headroom. It fails if the solid velocity omega x r were
//    taken about the wrong point, or the torque arm or its sign were wrong.
//  - The ratio of the two normalised couples isolates the periodic correction
//    (same sphere, same d/l, so the same PSM offset): measured 1 - 5e-4,
//    asserted within 0.3 %; without the 1/(1 - phi) factor it would be off
//    by 2.2 %.
//  - Net force and the couple about x and y: zero for a rotating sphere in
//    Stokes flow; what remains is the lattice asymmetry of the off-centre
//    sphere's interface cells. Measured |F| a / |T| = 3.8e-4 (L = 20),
//    1.4e-3 (L = 28); |T_xy| / |T| = 3e-4. Asserted < 5e-3 and < 2e-3.
TEST(PsmRotation, CoupleMatchesPeriodicStokes) {
  const auto r20 = rotate(20, 0.23);
  const auto r28 = rotate(28, 0.23);
  for (const auto* r : {&r20, &r28}) {
    EXPECT_LT(r->T / r->T_ref, 1.0 + 0.02);
    EXPECT_GT(r->T / r->T_ref, 1.0 - 0.02);
    EXPECT_LT(r->F * 4.0 / std::abs(r->T), 5e-3);
    EXPECT_LT(r->Txy / std::abs(r->T), 2e-3);
  }
  // Periodic correction: the two normalised couples agree.
  EXPECT_NEAR((r20.T / r20.T_ref) / (r28.T / r28.T_ref), 1.0, 3e-3);
}
