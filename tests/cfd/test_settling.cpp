// Single particle settling in an upward gas flow (DEM06 of the second paper,
// Yu et al. 2024 Sec. 3.3; REFERENCES: d = 100 um, rho_s = 2000 kg/m^3, air
// rho = 1.2, mu = 1.8e-5, gas at 0.4 m/s up, C_D of Schiller & Naumann) through
// the whole coupled step: void fraction, drag at the interpolated gas velocity,
// set I forces (the buoyancy comes from the gas's hydrostatic pressure
// gradient), DEM sub-steps. Reference velocities (derived from the ODE):
// v(0.01 s) = -0.01255261, v(0.10 s) = -0.05263133, v(0.35 s) = -0.05739251 m/s.
// Tolerance 0.1 % of each reference velocity: the cell (5 mm) holds 4e-6 of
// solid, so eps^-3.65 - 1 < 2e-5; the force is held over a gas step of
// 5e-5 s against a particle response time of ~0.05 s, a lag that costs
// ~7e-4 at 0.01 s (halving the step halves it) and decays with the transient.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "cfd/coupling.hpp"
#include "common/backends.hpp"
#include "dem/system.hpp"

using namespace lbdem;
using namespace lbdem::cfd;

class Settling : public ::testing::TestWithParam<Backend> {};

TEST_P(Settling, SingleParticleInUpflowMatchesDem06) {
  const Backend be = GetParam();
  const double d = 100e-6, rho_s = 2000, kG = 9.80665, h = 5e-3;
  const int nz = 10;
  dem::HostParticles hp;
  hp.add({0.5 * h, 0.5 * h, 0.04}, 0.5 * d, rho_s);
  dem::DemParams dp;
  dp.lo = {0, 0, 0};
  dp.hi = {h, h, nz * h};
  dp.periodic = {true, true, false};
  dp.material.stiffness = 1e-3;  // no contacts here; soft enough for a large dt
  dp.material.wall_stiffness = 1e-3;
  dp.gravity = {0, 0, -kG};
  dp.external_forcing = true;
  dp.skin = 0.2 * d;
  const double gas_dt = 5e-5;
  const int substeps = 5;
  dp.dt = gas_dt / substeps;
  dem::DemSystem dem(Exec(be), dp, hp);

  GasGridView g;
  g.n[0] = 1; g.n[1] = 1; g.n[2] = nz;
  g.h = h;
  g.periodic[0] = g.periodic[1] = true;
  GasParams gp;
  gp.rho = 1.2;
  gp.mu = 1.8e-5;
  gp.dt = gas_dt;
  gp.gravity = {0, 0, -kG};
  for (int s = 0; s < 4; ++s) gp.faces[static_cast<std::size_t>(s)].kind = FaceKind::Periodic;
  gp.faces[4].kind = FaceKind::Inlet;
  gp.faces[4].inflow = 0.4;
  gp.faces[5].kind = FaceKind::Outlet;
  gp.drag = DragLaw::WenYu;
  gp.deposition = Deposition::Linear;
  GasSolver gas(Exec(be), g, gp);
  gas.set_velocity({0, 0, 0.4});
  GasDemCoupling coupling(gas);
  dem::CoupledLoop loop(dem, coupling, substeps);

  struct Point { double t, v; };
  long done = 0;
  for (const Point& pt : {Point{0.01, -0.01255261}, Point{0.10, -0.05263133}, Point{0.35, -0.05739251}}) {
    const long upto = std::lround(pt.t / gas_dt);
    for (; done < upto; ++done) loop.step();
    const dem::HostParticles now = dem.download();
    EXPECT_NEAR(now.v[0].z, pt.v, 1e-3 * std::fabs(pt.v)) << "t = " << pt.t;
    std::printf("t %.2f s: v %.8f (reference %.8f) m/s\n", pt.t, now.v[0].z, pt.v);
  }
}

INSTANTIATE_TEST_SUITE_P(All, Settling, ::testing::ValuesIn(lbdem::test::backends()), lbdem::test::backend_name);
