// Memory of a coupled run and its output path:
//  - the estimates (lbm::lbm_memory, imb::psm_memory) list every buffer the
//    solver and the coupling hold, component by component, to the byte, on a
//    scene allocated on the host backend and stepped;
//  - fields leave the solver slab by slab through the staging buffers reserved
//    at start: the slabs give the whole-grid values bit for bit (macroscopic,
//    and the solid fraction of both pipelines against the slot map's
//    total_eps), and the slabs of a step allocate nothing;
//  - the paper's 3D suspension (first paper, Table 2: 512 x 2016 x 512 cells,
//    129,024 spheres of d/l 10, table fractions, fused pipeline) needs at most
//    100 B/cell in fp32 and 175 B/cell in fp64 by the estimate.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "core/memory_use.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "imb/coupled_memory.hpp"
#include "imb/snapshot_pack.hpp"
#include "imb/fraction_table.hpp"
#include "lbm/solver.hpp"

using namespace lbdem;

namespace {

const imb::FractionTable& table_of(int dim) {
  static const imb::FractionTable t3 = imb::build_fraction_table(3);
  static const imb::FractionTable t2 = imb::build_fraction_table(2);
  return dim == 3 ? t3 : t2;
}

struct Scene {
  lbm::LbmSetup fluid;
  dem::DemParams dem;
  dem::HostParticles particles;
  imb::CoupledParams coupling;
};

// A periodic box of n cells (not a multiple of the tile shape) with `count`
// spheres of radius r at random non-overlapping places, some across the
// periodic faces; moving, so that a step maps and gathers.
Scene scene(std::array<long, 3> n, int count, double r, lbm::Precision prec, imb::FractionMethod method,
            imb::PsmPipeline pipe, unsigned seed = 3) {
  Scene s;
  const int dim = n[2] == 1 ? 2 : 3;
  s.fluid.lattice = dim == 3 ? lbm::LatticeKind::D3Q19 : lbm::LatticeKind::D2Q9;
  s.fluid.precision = prec;
  s.fluid.tau = 0.8;
  s.fluid.domain = Grid::whole(n, {true, true, true});
  s.dem.lo = {0, 0, 0};
  s.dem.hi = {double(n[0]), double(n[1]), double(n[2])};
  s.dem.periodic = {true, true, dim == 3};  // 2D: discs in the plane z = 1/2, no z images
  s.dem.external_forcing = true;
  // Soft contacts (t_c of tens of steps at this mass): two DEM sub-steps suffice.
  s.dem.dt = 0.5;
  s.coupling.dem_substeps = 2;
  s.dem.material.stiffness = 0.5;
  s.coupling.psm.map.method = method;
  if (method == imb::FractionMethod::Table) s.coupling.psm.map.table = &table_of(dim);
  s.coupling.psm.pipeline = pipe;
  s.coupling.psm.map.max_radius = r;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  std::vector<Vec3d> placed;
  for (int tries = 0; static_cast<int>(placed.size()) < count && tries < 100000; ++tries) {
    Vec3d x{U(rng) * double(n[0]), U(rng) * double(n[1]), dim == 3 ? U(rng) * double(n[2]) : 0.5};
    bool ok = true;
    for (const auto& y : placed) {
      double d2 = 0;
      for (int a = 0; a < dim; ++a) {
        double d = x[a] - y[a];
        d -= double(n[static_cast<std::size_t>(a)]) * std::round(d / double(n[static_cast<std::size_t>(a)]));
        d2 += d * d;
      }
      ok = ok && d2 > (2 * r + 0.5) * (2 * r + 0.5);
    }
    if (!ok) continue;
    placed.push_back(x);
    s.particles.add(x, r, 2.0, {0.01 * (U(rng) - 0.5), 0.01 * (U(rng) - 0.5), dim == 3 ? 0.01 * (U(rng) - 0.5) : 0.0},
                    {0, 0, dim == 3 ? 0.0 : 0.001});
  }
  return s;
}

struct Live {
  std::unique_ptr<lbm::LbmSolver> fluid;
  std::unique_ptr<dem::DemSystem> dem;
  std::unique_ptr<imb::CoupledSolver> cs;
};

Live start(Scene& s, long steps) {
  Live r;
  r.fluid = lbm::make_lbm_solver(s.fluid, Backend::Host);
  const auto N = static_cast<std::size_t>(s.fluid.domain.storage_cells());
  r.fluid->initialize(std::vector<std::uint8_t>(N, 0), std::vector<double>(N, 1.0), std::vector<double>(3 * N, 0.0));
  r.dem = std::make_unique<dem::DemSystem>(Exec(Backend::Host), s.dem, s.particles);
  r.cs = std::make_unique<imb::CoupledSolver>(*r.fluid, *r.dem, s.coupling);
  r.cs->advance(steps);
  return r;
}

std::string describe(const MemoryUse& m) {
  std::string t;
  for (const auto& it : m.items) t += "  " + it.name + " " + std::to_string(it.bytes) + "\n";
  return t;
}

void expect_same(const MemoryUse& estimate, const MemoryUse& held, const std::string& what) {
  SCOPED_TRACE(what + "\nestimate:\n" + describe(estimate) + "held:\n" + describe(held));
  EXPECT_EQ(estimate.items.size(), held.items.size());
  for (const auto& it : estimate.items) EXPECT_EQ(it.bytes, held.of(it.name)) << it.name;
  for (const auto& it : held.items) EXPECT_EQ(it.bytes, estimate.of(it.name)) << it.name;
  EXPECT_EQ(estimate.total(), held.total());
}

struct Case {
  const char* name;
  std::array<long, 3> n;
  int count;
  double r;
  lbm::Precision prec;
  imb::FractionMethod method;
  imb::PsmPipeline pipe;
};

const Case kCases[] = {
    {"fused_table_3d_fp32", {45, 38, 21}, 12, 3.5, lbm::Precision::FP32, imb::FractionMethod::Table,
     imb::PsmPipeline::Fused},
    {"fused_linear_3d_fp64", {40, 27, 23}, 10, 4.0, lbm::Precision::FP64, imb::FractionMethod::Linear,
     imb::PsmPipeline::Fused},
    {"mapped_table_3d_fp64", {37, 30, 26}, 10, 3.0, lbm::Precision::FP64, imb::FractionMethod::Table,
     imb::PsmPipeline::Mapped},
    {"mapped_exact_3d_fp32", {30, 29, 22}, 6, 2.7, lbm::Precision::FP32, imb::FractionMethod::Exact,
     imb::PsmPipeline::Mapped},
    {"fused_table_2d_fp64", {150, 77, 1}, 20, 5.0, lbm::Precision::FP64, imb::FractionMethod::Table,
     imb::PsmPipeline::Fused},
    {"mapped_linear_2d_fp64", {90, 61, 1}, 12, 4.5, lbm::Precision::FP64, imb::FractionMethod::Linear,
     imb::PsmPipeline::Mapped},
};

class CoupledMemory : public ::testing::TestWithParam<Case> {};

}  // namespace

// Every buffer the fluid and the coupling hold after a few coupled steps is in
// the estimate made from the set-up alone, component by component, to the byte.
TEST_P(CoupledMemory, EstimateMatchesEveryBuffer) {
  const Case& c = GetParam();
  Scene s = scene(c.n, c.count, c.r, c.prec, c.method, c.pipe);
  ASSERT_GT(s.particles.size(), 3);
  Live r = start(s, 3);
  expect_same(lbm::lbm_memory(s.fluid), r.fluid->memory_use(), std::string(c.name) + " fluid");
  expect_same(imb::psm_memory(s.fluid, s.coupling.slots, s.coupling.psm, s.particles.size(), false),
              r.cs->memory_use(), std::string(c.name) + " coupling");
  EXPECT_EQ(r.fluid->memory_bytes(), lbm::lbm_memory_estimate(s.fluid));
  // No grid-sized array beyond the populations and the flags (fluid), none at
  // all in the fused pipeline (coupling), after output of the fields.
  std::vector<double> rho(static_cast<std::size_t>(r.fluid->output_slab_cells())), u(3 * rho.size()), eps(rho.size());
  for (const CellBox& b : slabs_of(s.fluid.domain.owned(), r.fluid->output_slab_cells())) {
    r.fluid->macroscopic_box(b, rho.data(), u.data());
    r.cs->solid_fraction_box(b, eps.data());
  }
  expect_same(lbm::lbm_memory(s.fluid), r.fluid->memory_use(), std::string(c.name) + " fluid after output");
  expect_same(imb::psm_memory(s.fluid, s.coupling.slots, s.coupling.psm, s.particles.size(), false),
              r.cs->memory_use(), std::string(c.name) + " coupling after output");
}

// Fields by slabs of an odd size (boxes of whole layers, rows and row pieces)
// equal the whole-grid fields bit for bit: macroscopic(), and the slot map's
// total solid fraction (CoupledSolver::solid_fraction_host, which maps the
// mapped pipeline's slots over the whole grid).
TEST_P(CoupledMemory, SlabsEqualWholeGrid) {
  const Case& c = GetParam();
  Scene s = scene(c.n, c.count, c.r, c.prec, c.method, c.pipe);
  Live r = start(s, 4);
  std::vector<double> rho, u;
  r.fluid->macroscopic(rho, u);
  const std::vector<double> eps = r.cs->solid_fraction_host();
  const GridView g = s.fluid.domain.view();
  double solid = 0;
  for (double e : eps) solid += e;
  EXPECT_GT(solid, 10.0);  // the particles are there
  for (Index cap : {Index{7}, Index{c.n[0] * 3 + 5}, Index{c.n[0] * c.n[1] + 1}, Index{c.n[0] * c.n[1] * 2}}) {
    std::vector<double> br(static_cast<std::size_t>(cap)), bu(3 * br.size()), be(br.size());
    Index seen = 0, bad_rho = 0, bad_u = 0, bad_eps = 0;
    for (const CellBox& b : slabs_of(s.fluid.domain.owned(), std::min(cap, r.fluid->output_slab_cells()))) {
      r.fluid->macroscopic_box(b, br.data(), bu.data());
      r.cs->solid_fraction_box(b, be.data());
      Index t = 0;
      for (int z = b.lo[2]; z < b.lo[2] + b.ext[2]; ++z)
        for (int y = b.lo[1]; y < b.lo[1] + b.ext[1]; ++y)
          for (int x = b.lo[0]; x < b.lo[0] + b.ext[0]; ++x, ++t) {
            const auto cell = static_cast<std::size_t>(g.index(x, y, z));
            const auto k = static_cast<std::size_t>(t);
            bad_rho += br[k] != rho[cell];
            for (int a = 0; a < 3; ++a) bad_u += bu[3 * k + static_cast<std::size_t>(a)] != u[3 * cell + static_cast<std::size_t>(a)];
            bad_eps += be[k] != eps[cell];
          }
      seen += b.size();
    }
    EXPECT_EQ(seen, g.n) << "slab cap " << cap;
    EXPECT_EQ(bad_rho, 0) << "slab cap " << cap;
    EXPECT_EQ(bad_u, 0) << "slab cap " << cap;
    EXPECT_EQ(bad_eps, 0) << "slab cap " << cap;
  }
}

// A background snapshot's pack of the owned box (imb/snapshot_pack.hpp: the
// fields in one buffer, x fastest; in float32 for fp32 files) holds the
// values the slab path gives, bit for bit (float32: each rounded once); on
// the host backend it reserves no device memory, and the estimate of a
// device run counts it at 20 or 40 bytes per owned cell.
TEST_P(CoupledMemory, SnapshotPackEqualsSlabs) {
  const Case& c = GetParam();
  Scene s = scene(c.n, c.count, c.r, c.prec, c.method, c.pipe);
  Live r = start(s, 5);
  const CellBox own = s.fluid.domain.owned();
  const auto M = static_cast<std::size_t>(own.size());
  for (bool fp32 : {true, false}) {
    imb::SnapshotPack pack(Backend::Host, own.size(), fp32);
    EXPECT_TRUE(pack.memory_use().items.empty());
    pack.take(*r.fluid, *r.cs);
    const Index cap = r.fluid->output_slab_cells();
    std::vector<double> br(static_cast<std::size_t>(cap)), bu(3 * br.size()), be(br.size());
    Index bad = 0, seen = 0;
    double solid = 0;
    for (const CellBox& b : slabs_of(own, std::min<Index>(cap, c.n[0] * 2 + 3))) {
      r.fluid->macroscopic_box(b, br.data(), bu.data());
      r.cs->solid_fraction_box(b, be.data());
      Index t = 0;
      for (int z = b.lo[2]; z < b.lo[2] + b.ext[2]; ++z)
        for (int y = b.lo[1]; y < b.lo[1] + b.ext[1]; ++y)
          for (int x = b.lo[0]; x < b.lo[0] + b.ext[0]; ++x, ++t) {
            const auto o = static_cast<std::size_t>((x - own.lo[0]) + Index(own.ext[0]) * ((y - own.lo[1]) + Index(own.ext[1]) * (z - own.lo[2])));
            const auto k = static_cast<std::size_t>(t);
            double want[5] = {br[k], bu[3 * k], bu[3 * k + 1], bu[3 * k + 2], be[k]};
            std::size_t at[5] = {o, M + 3 * o, M + 3 * o + 1, M + 3 * o + 2, 4 * M + o};
            for (int v = 0; v < 5; ++v) {
              const double got = fp32 ? double(pack.host_f()[at[v]]) : pack.host_d()[at[v]];
              const double ref = fp32 ? double(static_cast<float>(want[v])) : want[v];
              bad += std::memcmp(&got, &ref, sizeof got) != 0;
            }
            solid += be[k];
            ++seen;
          }
    }
    EXPECT_EQ(seen, own.size());
    EXPECT_EQ(bad, 0) << (fp32 ? "float32" : "float64");
    EXPECT_GT(solid, 10.0);  // the particles are there
  }
  for (bool fp32 : {true, false}) {
    const imb::SnapshotMemory bg{true, fp32};
    const MemoryUse dev = imb::coupled_memory(s.fluid, s.coupling, double(s.particles.size()), Backend::Cuda, bg);
    EXPECT_EQ(dev.of("snapshot pack (output.background)"), M * (fp32 ? 20u : 40u));
    const MemoryUse without = imb::coupled_memory(s.fluid, s.coupling, double(s.particles.size()), Backend::Cuda);
    EXPECT_EQ(dev.total() - without.total(), M * (fp32 ? 20u : 40u));
    EXPECT_EQ(imb::coupled_memory(s.fluid, s.coupling, double(s.particles.size()), Backend::Host, bg).total(),
              imb::coupled_memory(s.fluid, s.coupling, double(s.particles.size()), Backend::Host).total());
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, CoupledMemory, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& i) { return std::string(i.param.name); });

// A box larger than the staging buffer is refused, not written past its end.
TEST(CoupledMemoryRefusal, BoxBeyondStagingRefused) {
  Scene s = scene({24, 20, 18}, 4, 3.0, lbm::Precision::FP64, imb::FractionMethod::Table, imb::PsmPipeline::Fused);
  Live r = start(s, 1);
  ASSERT_EQ(r.fluid->output_slab_cells(), 24 * 20 * 18);  // a small grid: one slab
  lbm::LbmSetup big = s.fluid;
  big.domain = Grid::whole({512, 512, 512});
  EXPECT_EQ(lbm::lbm_stage_cells(big), kOutputSlabCells);
  CellBox b = s.fluid.domain.owned();
  std::vector<double> rho(static_cast<std::size_t>(b.size())), u(3 * rho.size());
  EXPECT_NO_THROW(r.fluid->macroscopic_box(b, rho.data(), u.data()));
  b.ext[2] += 1;
  EXPECT_THROW(r.fluid->macroscopic_box(b, rho.data(), u.data()), Error);
}

// The paper's 3D suspension (first paper, Table 2) by the estimate: at most
// 100 B/cell (fp32) and 175 B/cell (fp64) on the device, fused pipeline,
// table fractions, K = 4.
TEST(CoupledMemoryPaper, Suspension3dFitsTheGoals) {
  for (lbm::Precision prec : {lbm::Precision::FP32, lbm::Precision::FP64}) {
    lbm::LbmSetup s;
    s.lattice = lbm::LatticeKind::D3Q19;
    s.precision = prec;
    s.domain = Grid::whole({512, 2016, 512});
    imb::PsmOptions o;
    o.map.method = imb::FractionMethod::Table;
    o.map.max_radius = 5.0;
    const MemoryUse m = lbm::lbm_memory(s);
    MemoryUse all = m;
    all.add(imb::psm_memory(s, 4, o, 129024, true));
    const double cells = 512.0 * 2016 * 512;
    const double per_cell = double(all.total()) / cells;
    std::printf("%s: %.2f B/cell, %.2f GB\n", lbm::to_string(prec), per_cell, double(all.total()) / 1e9);
    for (const auto& it : all.items) std::printf("  %-22s %8.3f B/cell\n", it.name.c_str(), double(it.bytes) / cells);
    EXPECT_LE(per_cell, prec == lbm::Precision::FP32 ? 100.0 : 175.0);
    EXPECT_GE(per_cell, prec == lbm::Precision::FP32 ? 77.0 : 153.0);  // populations and flags at least
    EXPECT_EQ(all.of("fraction table"), 32u * 11 * 11 * 2 * sizeof(float));
  }
}
