// The fluid halo exchange: a grid cut into 2-8 pieces (1D, 2D and 3D cuts,
// uneven, periodic and walled axes), each piece a rank in this process
// exchanging through a mailbox, evolves bitwise like the whole grid on one
// rank — both lattices, all four precisions, both streaming schemes, the
// overlapped step and the serial one. Also: the slot counts per face and
// edge, and the links of a 2-rank periodic cut.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "common/backends.hpp"
#include "common/loopback_transport.hpp"
#include "halo/decomposition.hpp"
#include "lbm/halo_exchange.hpp"
#include "lbm_test_util.hpp"

namespace lbdem::lbm {
namespace {

struct Params {
  LatticeKind lattice;
  Precision precision;
  StreamKind streaming;
  std::array<int, 3> dims;
  bool walls;        // y walls with a moving lid (else fully periodic)
  bool overlap;
  Backend backend;
};

test::Scene make_whole(const Params& p) {
  const bool d3 = p.lattice == LatticeKind::D3Q19;
  test::Scene s = test::make_scene(p.lattice, 11, 10, d3 ? 7 : 1);
  s.setup.precision = p.precision;
  s.setup.streaming = p.streaming;
  s.setup.tau = 0.7;
  s.setup.body_force = {2e-5, 1e-5, 0};
  if (p.walls) {
    const int wall = test::add_boundary(s, BoundaryKind::Wall);
    const int lid = test::add_boundary(s, BoundaryKind::Velocity, {0.02, 0, 0});
    test::add_y_walls(s, wall, lid);
    s.setup.domain.periodic = {true, false, true};
  }
  test::randomize(s, 0.01, 0.02, 11);
  return s;
}

template <class T>
void run_case(const Params& p) {
  test::Scene whole = make_whole(p);
  const Grid wg = whole.setup.domain;
  const halo::Decomposition dec = halo::decompose(wg, p.dims[0] * p.dims[1] * p.dims[2], p.dims);
  const int n = dec.ranks();

  auto ref = make_lbm_solver(whole.setup, p.backend);
  ref->initialize(whole.flags, whole.rho, whole.u);

  test::Mailbox mail;
  std::vector<std::unique_ptr<LbmSolver>> solvers;
  std::vector<std::unique_ptr<test::LoopbackTransport>> transports;
  std::vector<std::unique_ptr<FluidHalo>> halos;
  for (int r = 0; r < n; ++r) {
    LbmSetup s = whole.setup;
    s.domain = dec.piece(wg, r);
    std::vector<std::uint8_t> f;
    std::vector<double> rho, u;
    piece_fields(wg, s.domain, whole.flags, whole.rho, whole.u, f, rho, u);
    solvers.push_back(make_lbm_solver(s, p.backend));
    solvers.back()->initialize(f, rho, u);
    transports.push_back(std::make_unique<test::LoopbackTransport>(mail, r, p.backend));
    halos.push_back(std::make_unique<FluidHalo>(*solvers.back(), dec, r, *transports.back()));
    if (!p.overlap) halos.back()->set_mode(FluidHalo::Mode::Serial);
  }
  for (auto& h : halos) h->begin_fill();
  for (auto& h : halos) h->finish_fill();
  const int steps = 13;
  for (int t = 0; t < steps; ++t) {
    ref->step(1);
    for (auto& h : halos) h->begin_step();
    for (auto& h : halos) h->finish_step();
  }
  const std::vector<double> fa = ref->populations();
  const GridView ga = wg.view();
  const int Q = lattice_q(p.lattice);
  long compared = 0;
  double mass = 0;
  for (int r = 0; r < n; ++r) {
    const Grid& pg = solvers[static_cast<std::size_t>(r)]->setup().domain;
    const GridView gv = pg.view();
    const std::vector<double> fb = solvers[static_cast<std::size_t>(r)]->populations();
    const CellBox o = pg.owned();
    for (int q = 0; q < Q; ++q)
      for (int z = 0; z < o.ext[2]; ++z)
        for (int y = 0; y < o.ext[1]; ++y)
          for (int x = 0; x < o.ext[0]; ++x) {
            const int wx = static_cast<int>(x + pg.offset[0]), wy = static_cast<int>(y + pg.offset[1]),
                      wz = static_cast<int>(z + pg.offset[2]);
            if (whole.flags[test::cell_index(whole, wx, wy, wz)] != 0) continue;
            const double va = fa[static_cast<std::size_t>(q * ga.n + ga.index(wx, wy, wz))];
            const double vb = fb[static_cast<std::size_t>(q * gv.n + gv.index(x + o.lo[0], y + o.lo[1], z + o.lo[2]))];
            ASSERT_EQ(std::memcmp(&va, &vb, sizeof va), 0)
                << "rank " << r << " q " << q << " global cell " << wx << "," << wy << "," << wz << ": " << va
                << " vs " << vb;
            ++compared;
          }
    mass += solvers[static_cast<std::size_t>(r)]->diagnostics().mass;
  }
  long fluid = 0;
  for (auto f : whole.flags) fluid += f == 0;
  EXPECT_EQ(compared, fluid * Q);
  EXPECT_NEAR(mass, ref->diagnostics().mass, 1e-12 * mass);
}

class FluidHaloExchange : public ::testing::TestWithParam<Params> {};

TEST_P(FluidHaloExchange, PiecesEqualWholeGridBitwise) {
  const Params p = GetParam();
  if (p.precision == Precision::FP32) run_case<float>(p);
  else run_case<double>(p);
}

std::vector<Params> all_params() {
  std::vector<Params> v;
  const std::vector<std::array<int, 3>> cuts2 = {{2, 1, 1}, {1, 2, 1}, {2, 2, 1}, {3, 1, 1}, {3, 2, 1}};
  const std::vector<std::array<int, 3>> cuts3 = {{2, 1, 1}, {1, 1, 2}, {2, 2, 1}, {1, 3, 2}, {2, 2, 2}, {3, 1, 1}};
  for (Backend b : test::backends())
    for (auto l : {LatticeKind::D2Q9, LatticeKind::D3Q19})
      for (auto pr : {Precision::FP64, Precision::FP32})
        for (auto s : {StreamKind::AA, StreamKind::TwoLattice})
          for (const auto& d : l == LatticeKind::D2Q9 ? cuts2 : cuts3)
            for (bool walls : {false, true}) {
              // The serial step once per lattice and scheme; the overlapped one everywhere.
              v.push_back({l, pr, s, d, walls, true, b});
              if (pr == Precision::FP64 && walls && d == std::array<int, 3>{2, 2, 1}) v.push_back({l, pr, s, d, walls, false, b});
            }
  // 16-bit storage: the halo carries the stored 16-bit values; one 2D and one 3D cut.
  for (Backend b : test::backends())
    for (auto l : {LatticeKind::D2Q9, LatticeKind::D3Q19})
      for (auto pr : {Precision::FP16S, Precision::FP16C})
        for (auto s : {StreamKind::AA, StreamKind::TwoLattice})
          for (bool walls : {false, true})
            v.push_back({l, pr, s, l == LatticeKind::D2Q9 ? std::array<int, 3>{2, 2, 1} : std::array<int, 3>{2, 2, 2},
                         walls, true, b});
  return v;
}

std::string name(const ::testing::TestParamInfo<Params>& i) {
  const Params& p = i.param;
  return std::string(to_string(p.backend)) + "_" + to_string(p.lattice) + "_" + to_string(p.precision) + "_" +
         to_string(p.streaming) + "_" + std::to_string(p.dims[0]) + "x" + std::to_string(p.dims[1]) + "x" +
         std::to_string(p.dims[2]) + (p.walls ? "_walls" : "_periodic") + (p.overlap ? "" : "_serial");
}

INSTANTIATE_TEST_SUITE_P(Lbm, FluidHaloExchange, ::testing::ValuesIn(all_params()), name);

TEST(FluidHaloLinks, SlotsPerFaceAndEdge) {
  // D3Q19 cut along x and y: 4 faces with 5 slots, 4 x-y edges with 1, no corners.
  const Grid whole = Grid::whole({8, 8, 4});
  const halo::Decomposition dec = halo::decompose(whole, 9, {3, 3, 1});
  const auto links = halo_links(dec, 4, dec.piece(whole, 4), LatticeKind::D3Q19);
  int faces = 0, edges = 0;
  for (const HaloLink& k : links) {
    const int nz = (k.dir[0] != 0) + (k.dir[1] != 0) + (k.dir[2] != 0);
    const int want = nz == 1 ? 5 : 1;
    for (const HaloBlock* b : {&k.send_fill_tl, &k.send_fill_aa, &k.send_back, &k.recv_fill_tl, &k.recv_fill_aa, &k.recv_back})
      EXPECT_EQ(b->slots, want);
    (nz == 1 ? faces : edges)++;
  }
  EXPECT_EQ(faces, 4);
  EXPECT_EQ(edges, 4);
  // D2Q9 cut 2 x 2, periodic: 4 faces of 3 slots, 4 corners of 1.
  const Grid w2 = Grid::whole({8, 8, 1});
  const halo::Decomposition d2 = halo::decompose(w2, 4, {2, 2, 1});
  const auto l2 = halo_links(d2, 0, d2.piece(w2, 0), LatticeKind::D2Q9);
  ASSERT_EQ(l2.size(), 8u);
  for (const HaloLink& k : l2) EXPECT_EQ(k.send_fill_tl.slots, (k.dir[0] != 0 && k.dir[1] != 0) ? 1 : 3);
}

TEST(FluidHaloLinks, TwoRankPeriodicPairUsesDistinctTags) {
  const Grid whole = Grid::whole({8, 6, 4});
  const halo::Decomposition dec = halo::decompose(whole, 2, {2, 1, 1});
  const auto links = halo_links(dec, 0, dec.piece(whole, 0), LatticeKind::D3Q19);
  ASSERT_EQ(links.size(), 2u);
  EXPECT_EQ(links[0].peer, 1);
  EXPECT_EQ(links[1].peer, 1);
  EXPECT_NE(links[0].tag, links[1].tag);
  EXPECT_EQ(links[0].tag, links[1].recv_tag);  // what goes out one face comes in the other
  // A walled axis cut in two: one link each, none across the wall.
  Grid walled = whole;
  walled.periodic = {false, true, true};
  const halo::Decomposition dw = halo::decompose(walled, 2, {2, 1, 1});
  EXPECT_EQ(halo_links(dw, 0, dw.piece(walled, 0), LatticeKind::D3Q19).size(), 1u);
}

}  // namespace
}  // namespace lbdem::lbm
