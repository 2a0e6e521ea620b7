// The PSM step in parts (PsmCoupling::parts / step_part / finish_step), which
// a halo exchange overlaps: on a piece of a grid cut along x and z, the outer
// parts then the inner part give bitwise the populations and the particle
// forces of one launch over the whole piece — mapped (cell boxes) and fused
// (tile boxes: each tile's partial forces are written once) pipelines, both
// lattices, fp64 and fp32, spheres across the cut faces. One exception: the
// mapped pipeline on the GPU fills a cell's slots with atomics, so two maps of
// the same spheres may list a shared cell's particles in another order and
// the solid terms add in another order: there the two runs agree to
// round-off (a few epsilon of the precision) instead of bitwise.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "../common/backends.hpp"
#include "imb/fraction_table.hpp"
#include "psm_scene.hpp"

using namespace lbdem;

namespace {

struct Params {
  Backend backend;
  imb::PsmPipeline pipeline;
  bool d3;
  lbm::Precision precision;
};

const imb::FractionTable& table(int dim) {
  static const imb::FractionTable t2 = imb::build_fraction_table(2), t3 = imb::build_fraction_table(3);
  return dim == 2 ? t2 : t3;
}

lbm::LbmSetup piece_setup(const Params& p) {
  lbm::LbmSetup s = test::psm_box(1, 1, 1, 0.6, 3.0 / 16.0, {2e-6, -1e-6, p.d3 ? 5e-7 : 0.0});
  s.lattice = p.d3 ? lbm::LatticeKind::D3Q19 : lbm::LatticeKind::D2Q9;
  s.precision = p.precision;
  Grid& g = s.domain;
  g.global = {140, 48, p.d3 ? 24L : 1L};
  g.local = {70, 48, p.d3 ? 12L : 1L};
  g.offset = {35, 0, p.d3 ? 6L : 0L};
  g.split = {true, false, p.d3};
  g.ghost = 1;
  return s;
}

std::vector<test::PsmSphere> spheres(bool d3) {
  // Global lattice frame; the piece owns x in [35, 105), z in [6, 18).
  std::vector<test::PsmSphere> s = {
      {36.0, 10.3, 7.2, 4.0, 0.01, 0.0, 0.0, 0.0, 0.0, 1e-3},     // across the low x cut and the low z cut
      {104.2, 30.1, 12.5, 3.5, -0.01, 0.005, 0.0, 1e-3, 0.0, 0.0},  // across the high x cut
      {70.4, 24.6, 17.5, 4.5, 0.0, 0.0, 0.004, 0.0, 2e-3, 0.0},   // across the high z cut
      {66.0, 40.2, 11.9, 3.0, 0.002, 0.0, 0.0, 0.0, 0.0, 0.0},    // inside
  };
  if (!d3)
    for (auto& q : s) q.z = 0.5;
  return s;
}

class PsmParts : public ::testing::TestWithParam<Params> {};

TEST_P(PsmParts, OuterThenInnerEqualsOneLaunchBitwise) {
  const Params p = GetParam();
  const lbm::LbmSetup setup = piece_setup(p);
  imb::PsmOptions opt;
  opt.map.method = imb::FractionMethod::Table;
  opt.map.table = &table(p.d3 ? 3 : 2);
  opt.pipeline = p.pipeline;
  test::PsmScene a(setup, p.backend, 2, spheres(p.d3), opt, {0.002, 0.001, p.d3 ? -0.001 : 0.0});
  test::PsmScene b(setup, p.backend, 2, spheres(p.d3), opt, {0.002, 0.001, p.d3 ? -0.001 : 0.0});
  for (int step = 0; step < 4; ++step) {
    a.map();
    b.map();
    const auto parts = a.coupling().parts();
    ASSERT_FALSE(parts.outer.empty());
    ASSERT_FALSE(parts.inner.empty());
    a.step();  // in parts
    // One box holding every part.
    CellBox all = parts.inner;
    for (const CellBox& o : parts.outer)
      for (int ax = 0; ax < 3; ++ax) {
        const int lo = std::min(all.lo[ax], o.lo[ax]), hi = std::max(all.lo[ax] + all.ext[ax], o.lo[ax] + o.ext[ax]);
        all.lo[ax] = lo;
        all.ext[ax] = hi - lo;
      }
    b.coupling().step_part(all, b.particles(), b.options());
    b.coupling().finish_step(b.particles(), imb::ForceOut::six(b.force6()));
  }
  const bool bitwise = !(p.backend == Backend::Cuda && p.pipeline == imb::PsmPipeline::Mapped);
  auto same = [&](double x, double y, double scale) {
    const double tol = p.precision == lbm::Precision::FP64 ? 1e-13 : 1e-6;  // a few epsilon of the precision
    return bitwise ? std::memcmp(&x, &y, sizeof(double)) == 0 : std::abs(x - y) <= tol * scale;
  };
  const auto fa = a.forces(), fb = b.forces();
  ASSERT_EQ(fa.size(), fb.size());
  double fmax = 0;
  for (double v : fa) fmax = std::max(fmax, std::abs(v));
  EXPECT_GT(fmax, 0.0);
  for (std::size_t i = 0; i < fa.size(); ++i)
    ASSERT_TRUE(same(fa[i], fb[i], fmax)) << "force/torque " << i << ": " << fa[i] << " vs " << fb[i];
  // Populations of the owned cells (populations() leaves the others unset).
  const auto pa = a.solver().populations(), pb = b.solver().populations();
  ASSERT_EQ(pa.size(), pb.size());
  const GridView g = setup.domain.view();
  const CellBox o = setup.domain.owned();
  const int Q = lbm::lattice_q(setup.lattice);
  for (int q = 0; q < Q; ++q)
    for (Index t = 0; t < o.size(); ++t) {
      int x, y, z;
      o.coords(t, x, y, z);
      const auto i = static_cast<std::size_t>(q * g.n + g.index(x, y, z));
      ASSERT_TRUE(same(pa[i], pb[i], 1.0)) << "q " << q << " cell " << x << "," << y << "," << z;
    }
}

std::vector<Params> all_params() {
  std::vector<Params> v;
  for (Backend b : test::backends())
    for (auto pl : {imb::PsmPipeline::Mapped, imb::PsmPipeline::Fused})
      for (bool d3 : {false, true})
        for (auto pr : {lbm::Precision::FP64, lbm::Precision::FP32}) {
          v.push_back({b, pl, d3, pr});
        }
  return v;
}

INSTANTIATE_TEST_SUITE_P(Imb, PsmParts, ::testing::ValuesIn(all_params()), [](const auto& i) {
  const Params& p = i.param;
  return std::string(to_string(p.backend)) + "_" + imb::to_string(p.pipeline) + (p.d3 ? "_D3Q19_" : "_D2Q9_") +
         lbm::to_string(p.precision);
});

}  // namespace
