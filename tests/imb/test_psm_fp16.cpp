// The PSM step with 16-bit population storage (fp16s, fp16c; arithmetic in
// fp32): mapped and fused pipelines, both lattices, A-A and two-lattice. Moving
// spheres in a periodic box with a body force: the particle forces and the
// velocity field stay within a few 16-bit unit roundoffs of the fp64 run.
//
// Tolerance: the flow changes quickly here (spheres moving at 0.01-0.02 cells
// per step, 60 steps from a uniform start), so the rounding of each store is
// damped as in a decaying flow (tests/lbm/test_fp16_storage.cpp) rather than
// accumulated into a stall; the force on a sphere is a sum of momentum
// exchanges of populations each rounded with relative error u16 = 2^-11
// (fp16s) or 2^-12 (fp16c), so it carries a few u16 of the largest force.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "../common/backends.hpp"
#include "imb/fraction_table.hpp"
#include "lbm/storage_checks.hpp"
#include "psm_scene.hpp"

using namespace lbdem;

namespace {

struct Params {
  Backend backend;
  imb::PsmPipeline pipeline;
  bool d3;
  lbm::Precision precision;
  lbm::StreamKind streaming;
};

const imb::FractionTable& table(int dim) {
  static const imb::FractionTable t2 = imb::build_fraction_table(2), t3 = imb::build_fraction_table(3);
  return dim == 2 ? t2 : t3;
}

std::vector<test::PsmSphere> spheres(bool d3) {
  std::vector<test::PsmSphere> s = {
      {10.3, 12.1, 8.2, 4.0, 0.02, 0.0, 0.0, 0.0, 0.0, 2e-3},
      {24.6, 20.4, 15.5, 3.5, -0.01, 0.01, 0.0, 1e-3, 0.0, 0.0},
  };
  if (!d3)
    for (auto& q : s) q.z = 0.5;
  return s;
}

struct Outcome {
  std::vector<double> forces, u;
};

Outcome run_scene(const Params& p, lbm::Precision pr) {
  lbm::LbmSetup s = test::psm_box(32, 32, p.d3 ? 24 : 1, 0.8, 3.0 / 16.0, {2e-5, -1e-5, 0.0});
  s.precision = pr;
  s.streaming = p.streaming;
  imb::PsmOptions opt;
  opt.map.method = imb::FractionMethod::Table;
  opt.map.table = &table(p.d3 ? 3 : 2);
  opt.pipeline = p.pipeline;
  auto ps = spheres(p.d3);
  test::PsmScene sc(s, p.backend, 2, ps, opt, {0.01, 0.0, 0.0});
  for (int step = 0; step < 60; ++step) {
    for (auto& q : ps) {
      q.x += q.vx;
      q.y += q.vy;
    }
    sc.set_particles(ps);
    sc.map();
    sc.step();
  }
  Outcome r;
  r.forces = sc.forces();
  std::vector<double> rho;
  sc.solver().macroscopic(rho, r.u);
  return r;
}

class PsmFp16 : public ::testing::TestWithParam<Params> {};

TEST_P(PsmFp16, CloseToFp64) {
  const Params p = GetParam();
  const Outcome a = run_scene(p, lbm::Precision::FP64), b = run_scene(p, p.precision);
  ASSERT_EQ(a.forces.size(), b.forces.size());
  double fmax = 0, tmax = 0, df = 0, dt = 0;
  for (std::size_t i = 0; i < a.forces.size(); ++i) {
    const bool torque = i % 6 >= 3;
    (torque ? tmax : fmax) = std::max(torque ? tmax : fmax, std::abs(a.forces[i]));
    (torque ? dt : df) = std::max(torque ? dt : df, std::abs(a.forces[i] - b.forces[i]));
  }
  const double umax = test::max_abs(a.u), du = test::max_diff(a.u, b.u);
  const double u16 = lbm::storage_unit_roundoff(p.precision);
  std::printf("%s %s %s %s: force %.3e torque %.3e velocity %.3e (relative; u16 %.2e)\n", to_string(p.backend),
              imb::to_string(p.pipeline), p.d3 ? "D3Q19" : "D2Q9", to_string(p.precision), df / fmax,
              tmax > 0 ? dt / tmax : 0.0, du / umax, u16);
  ASSERT_GT(fmax, 0.0);
  EXPECT_LT(df / fmax, 8 * u16);
  if (tmax > 0) {
    EXPECT_LT(dt / tmax, 8 * u16);
  }
  EXPECT_LT(du / umax, 8 * u16);
}

std::vector<Params> all_params() {
  std::vector<Params> v;
  for (Backend b : test::backends())
    for (auto pl : {imb::PsmPipeline::Mapped, imb::PsmPipeline::Fused})
      for (bool d3 : {false, true})
        for (auto pr : {lbm::Precision::FP16S, lbm::Precision::FP16C})
          v.push_back({b, pl, d3, pr, d3 ? lbm::StreamKind::AA : lbm::StreamKind::TwoLattice});
  return v;
}

INSTANTIATE_TEST_SUITE_P(Imb, PsmFp16, ::testing::ValuesIn(all_params()), [](const auto& i) {
  const Params& p = i.param;
  return std::string(to_string(p.backend)) + "_" + imb::to_string(p.pipeline) + (p.d3 ? "_D3Q19_" : "_D2Q9_") +
         to_string(p.precision);
});

}  // namespace
