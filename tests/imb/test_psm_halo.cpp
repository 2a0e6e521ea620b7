// The PSM step on a cut grid: pieces that exchange their halos (each piece a
// rank in this process, through a mailbox) with the step in parts overlapping
// the exchange, spheres moving across the cuts and remapped every step, give
// the whole grid's populations bitwise (fp64 and fp32, mapped and fused, both
// lattices) and its particle forces to round-off once summed over the pieces
// (each piece adds the cells it owns; the grouping of the sum differs). A
// sphere crosses the periodic ends of two cut axes (pieces see its image).
// The fused pipeline's tiles start at the piece's first storage cell, so a
// cell's offset from a sphere is rounded from another tile origin than on the
// whole grid: its populations agree to round-off (a few epsilon of the
// storage precision), not bitwise. On the
// GPU the mapped pipeline fills a cell's slots with atomics (slot order): also
// round-off there.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "../common/backends.hpp"
#include "../common/loopback_transport.hpp"
#include "halo/decomposition.hpp"
#include "imb/fraction_table.hpp"
#include "lbm/halo_exchange.hpp"
#include "psm_scene.hpp"

using namespace lbdem;

namespace {

struct Params {
  Backend backend;
  imb::PsmPipeline pipeline;
  bool d3;
  lbm::Precision precision;
  std::array<int, 3> dims;
};

const imb::FractionTable& table(int dim) {
  static const imb::FractionTable t2 = imb::build_fraction_table(2), t3 = imb::build_fraction_table(3);
  return dim == 2 ? t2 : t3;
}

std::vector<test::PsmSphere> spheres(bool d3, long step) {
  std::vector<test::PsmSphere> s = {
      {15.6, 10.3, 7.2, 4.0, 0.2, 0.0, 0.1, 0.0, 0.0, 1e-3},
      {44.2, 30.1, 12.5, 3.5, -0.15, 0.1, 0.0, 1e-3, 0.0, 0.0},
      {32.4, 24.6, 17.5, 4.5, 0.0, 0.0, 0.15, 0.0, 2e-3, 0.0},
      {56.0, 40.2, 3.9, 3.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0},
      {61.0, 20.0, 12.0, 3.5, 0.3, 0.0, -0.4, 0.0, 0.0, 1e-3},  // across the periodic ends of x and z
  };
  for (auto& q : s) {
    // Positions move far enough over a few steps to cross cuts; velocities are the solid velocities.
    q.x += 2.0 * q.vx * double(step);
    q.y += 2.0 * q.vy * double(step);
    q.z += 2.0 * q.vz * double(step);
    if (!d3) q.z = 0.5;
  }
  return s;
}

class PartsStep final : public lbm::ExternalStep {
 public:
  PartsStep(test::PsmScene& s) : s_(s) {}
  void outer(lbm::Lane lane) override {
    for (const CellBox& b : s_.coupling().parts().outer) s_.coupling().step_part(b, s_.particles(), s_.options(), lane);
  }
  void inner(lbm::Lane lane) override {
    s_.coupling().step_part(s_.coupling().parts().inner, s_.particles(), s_.options(), lane);
  }
  void commit() override { s_.coupling().finish_step(s_.particles(), imb::ForceOut::six(s_.force6())); }

 private:
  test::PsmScene& s_;
};

class PsmHalo : public ::testing::TestWithParam<Params> {};

TEST_P(PsmHalo, PiecesEqualWholeGrid) {
  const Params p = GetParam();
  lbm::LbmSetup whole = test::psm_box(64, 48, p.d3 ? 24 : 1, 0.6, 3.0 / 16.0, {2e-6, -1e-6, p.d3 ? 5e-7 : 0.0});
  whole.precision = p.precision;
  imb::PsmOptions opt;
  // Table fractions in the mapped pipeline; the fused one with linear
  // fractions (its tiles sit differently on a piece, so its table lookups
  // start from positions rounded differently: the table's bins would show).
  opt.map.method = p.pipeline == imb::PsmPipeline::Fused ? imb::FractionMethod::Linear : imb::FractionMethod::Table;
  opt.map.table = &table(p.d3 ? 3 : 2);
  opt.pipeline = p.pipeline;
  const std::array<double, 3> u0{0.002, 0.001, p.d3 ? -0.001 : 0.0};
  test::PsmScene ref(whole, p.backend, 2, spheres(p.d3, 0), opt, u0);
  const halo::Decomposition dec = halo::decompose(whole.domain, p.dims[0] * p.dims[1] * p.dims[2], p.dims);
  const int n = dec.ranks();
  test::Mailbox mail;
  std::vector<std::unique_ptr<test::PsmScene>> pieces;
  std::vector<std::unique_ptr<test::LoopbackTransport>> tr;
  std::vector<std::unique_ptr<lbm::FluidHalo>> halos;
  std::vector<std::unique_ptr<PartsStep>> ext;
  for (int r = 0; r < n; ++r) {
    lbm::LbmSetup s = whole;
    s.domain = dec.piece(whole.domain, r);
    pieces.push_back(std::make_unique<test::PsmScene>(s, p.backend, 2, spheres(p.d3, 0), opt, u0));
    tr.push_back(std::make_unique<test::LoopbackTransport>(mail, r, p.backend));
    halos.push_back(std::make_unique<lbm::FluidHalo>(pieces.back()->solver(), dec, r, *tr.back()));
    ext.push_back(std::make_unique<PartsStep>(*pieces.back()));
  }
  const int steps = 7;
  for (int t = 0; t < steps; ++t) {
    ref.set_particles(spheres(p.d3, t));
    ref.map();
    ref.step();
    for (int r = 0; r < n; ++r) {
      pieces[static_cast<std::size_t>(r)]->set_particles(spheres(p.d3, t));
      pieces[static_cast<std::size_t>(r)]->map();
    }
    for (int r = 0; r < n; ++r) halos[static_cast<std::size_t>(r)]->begin_step(ext[static_cast<std::size_t>(r)].get());
    for (int r = 0; r < n; ++r) halos[static_cast<std::size_t>(r)]->finish_step();
  }
  // Forces: the pieces' shares summed in rank order.
  const auto fr = ref.forces();
  std::vector<double> fs(fr.size(), 0.0);
  for (auto& pc : pieces) {
    const auto f = pc->forces();
    for (std::size_t i = 0; i < f.size(); ++i) fs[i] += f[i];
  }
  double fmax = 0;
  for (double v : fr) fmax = std::max(fmax, std::abs(v));
  ASSERT_GT(fmax, 0.0);
  // The fused fp32 kernel sums a tile's cells in float per warp: a tile cut
  // by the piece boundary is summed in two parts there (float round-off).
  // So does the mapped fp32 pipeline on the GPU, whose slot order comes from atomics.
  const bool float_sums = p.precision == lbm::Precision::FP32 &&
                          (p.pipeline == imb::PsmPipeline::Fused || p.backend == Backend::Cuda);
  const double ftol = float_sums ? 1e-6 : 1e-12;
  for (std::size_t i = 0; i < fr.size(); ++i)
    EXPECT_NEAR(fs[i], fr[i], ftol * fmax) << "particle " << i / 6 << " component " << i % 6;
  // Populations of every owned cell.
  const bool bitwise = p.pipeline == imb::PsmPipeline::Mapped && p.backend == Backend::Host;
  // Round-off of the storage precision: a few units of its epsilon.
  const double tol = p.precision == lbm::Precision::FP64 ? 1e-13 : 2e-6;
  const auto fa = ref.solver().populations();
  const GridView ga = whole.domain.view();
  const int Q = lbm::lattice_q(whole.lattice);
  long compared = 0;
  for (int r = 0; r < n; ++r) {
    const Grid& pg = pieces[static_cast<std::size_t>(r)]->solver().setup().domain;
    const GridView gv = pg.view();
    const CellBox o = pg.owned();
    const auto fb = pieces[static_cast<std::size_t>(r)]->solver().populations();
    for (int q = 0; q < Q; ++q)
      for (Index t = 0; t < o.size(); ++t) {
        int x, y, z;
        o.coords(t, x, y, z);
        const int wx = static_cast<int>(x - o.lo[0] + pg.offset[0]), wy = static_cast<int>(y - o.lo[1] + pg.offset[1]),
                  wz = static_cast<int>(z - o.lo[2] + pg.offset[2]);
        const double va = fa[static_cast<std::size_t>(q * ga.n + ga.index(wx, wy, wz))];
        const double vb = fb[static_cast<std::size_t>(q * gv.n + gv.index(x, y, z))];
        if (bitwise)
          ASSERT_EQ(std::memcmp(&va, &vb, sizeof va), 0) << "rank " << r << " q " << q << " cell " << wx << "," << wy << "," << wz << ": " << va << " vs " << vb;
        else
          ASSERT_NEAR(va, vb, tol) << "rank " << r << " q " << q;
        ++compared;
      }
  }
  EXPECT_EQ(compared, ga.n * Q);
}

std::vector<Params> all_params() {
  std::vector<Params> v;
  for (Backend b : test::backends())
    for (auto pl : {imb::PsmPipeline::Mapped, imb::PsmPipeline::Fused})
      for (auto pr : {lbm::Precision::FP64, lbm::Precision::FP32}) {
        v.push_back({b, pl, false, pr, {2, 2, 1}});
        v.push_back({b, pl, true, pr, {2, 1, 1}});
        v.push_back({b, pl, true, pr, {1, 2, 2}});
        if (pr == lbm::Precision::FP64) v.push_back({b, pl, true, pr, {3, 1, 1}});
      }
  return v;
}

INSTANTIATE_TEST_SUITE_P(Imb, PsmHalo, ::testing::ValuesIn(all_params()), [](const auto& i) {
  const Params& p = i.param;
  return std::string(to_string(p.backend)) + "_" + imb::to_string(p.pipeline) + (p.d3 ? "_D3Q19_" : "_D2Q9_") +
         lbm::to_string(p.precision) + "_" + std::to_string(p.dims[0]) + "x" + std::to_string(p.dims[1]) + "x" +
         std::to_string(p.dims[2]);
});

}  // namespace
