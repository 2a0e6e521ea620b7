// The narrow particle view the coupling modules use, and external forcing:
// a force written into ext_force (held over sub-steps) and a body force on
// every particle accelerate a free particle at (F_ext + F_body)/m exactly
// (constant force: velocity Verlet is exact; tolerance 1e-12 relative).
#include <gtest/gtest.h>

#include <vector>

#include "core/buffer.hpp"
#include "dem/particle_view.hpp"
#include "dem_test_util.hpp"

using namespace lbdem;
using namespace lbdem::dem;
using namespace lbdem::dem::test;

class DemView : public ::testing::TestWithParam<Backend> {};

TEST_P(DemView, ExternalForceThroughView) {
  HostParticles h;
  h.add({0, 0, 0}, 0.01, 1000);
  h.add({0.5, 0, 0}, 0.02, 1000);
  DemParams p = open_box(1.0);
  p.material = simple_material(1e3, 0.9);
  p.external_forcing = true;
  p.body_force = {0, 0, 1e-3};
  p.dt = min_collision_time(p, h) / 50;
  DemSystem sys(Exec(GetParam()), p, h);
  ParticleView v = sys.view();
  ASSERT_EQ(v.n, 2);
  ASSERT_NE(v.ext_force, nullptr);
  // The coupling writes per-particle forces through the view (here copied in
  // from the host; storage order is whatever the last rebuild left).
  const HostParticles now = sys.download();
  std::vector<Real4> f(2);
  for (int i = 0; i < 2; ++i) f[i] = Real4{now.id[i] == 0 ? 2e-3 : -1e-3, 0, 0, 0};
  backend_copy_from_host(sys.backend(), v.ext_force, f.data(), sizeof(Real4) * 2);
  const long steps = 100;
  sys.advance(steps);
  const HostParticles out = sys.download();
  const double t = steps * p.dt;
  for (int i = 0; i < 2; ++i) {
    const double m = out.mass[i];
    const double fx = out.id[i] == 0 ? 2e-3 : -1e-3;
    EXPECT_NEAR(out.v[i].x, fx / m * t, 1e-12 * std::fabs(fx / m * t));
    EXPECT_NEAR(out.v[i].z, 1e-3 / m * t, 1e-12 * (1e-3 / m * t));
  }
}
INSTANTIATE_TEST_SUITE_P(All, DemView, ::testing::ValuesIn(lbdem::test::backends()), lbdem::test::backend_name);
