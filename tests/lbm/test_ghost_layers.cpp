// Ghost layers: a grid split along x into one piece with a ghost layer on each
// side (its own periodic neighbour), whose ghosts are refreshed from their
// periodic images as a halo exchange would, evolves bitwise like the whole
// grid — with walls (boundary cells inside the ghost layers reflect, ghost
// cells never do), a body force, both streaming schemes, both precisions, and
// with the step split into the outer slabs and the inner box.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "lbm/lattice.hpp"
#include "lbm_test_util.hpp"

namespace lbdem::lbm {
namespace {

struct Params {
  LatticeKind lattice;
  Precision precision;
  StreamKind streaming;
  bool split_step;  // outer slabs, then the inner box
};

// x of storage cell of the split grid <-> whole grid: split = whole + 1.
// Only ghost-flagged cells take part: a boundary cell in a ghost layer holds
// the reflections its own fluid neighbours wrote into it, which no other rank
// has (each reflected slot has one writer, the fluid cell that reads it back).
template <class T>
void exchange_before(LbmSolver& s, int Q) {
  // Every ghost cell takes all populations of its periodic image (the owned
  // cell one period away): what the neighbour rank would send.
  const LbmRaw r = s.raw();
  T* f = static_cast<T*>(r.src);
  const GridView g = r.grid;
  for (int z = 0; z < g.nz; ++z)
    for (int y = 0; y < g.ny; ++y)
      for (int q = 0; q < Q; ++q) {
        if (r.flags[g.index(0, y, z)] == kGhostFlag)
          f[q * r.stride + g.index(0, y, z)] = f[q * r.stride + g.index(g.nx - 2, y, z)];
        if (r.flags[g.index(g.nx - 1, y, z)] == kGhostFlag)
          f[q * r.stride + g.index(g.nx - 1, y, z)] = f[q * r.stride + g.index(1, y, z)];
      }
}

// A-A odd steps write the populations that leave the owned box into the ghost
// cells: they belong to the image cell (what the neighbour rank would
// receive). Only slots some owned fluid cell wrote (its source ghost - c_q is
// fluid) are sent: the others of the image cell have their own writer there.
template <class L, class T>
void exchange_after_odd(LbmSolver& s) {
  const LbmRaw r = s.raw();
  T* f = static_cast<T*>(r.src);
  const GridView g = r.grid;
  auto written = [&](int gx, int y, int z, int q) {
    const int sy = (y - L::c(q, 1) + g.ny) % g.ny, sz = (z - L::c(q, 2) + g.nz) % g.nz;
    return r.flags[g.index(gx - L::c(q, 0), sy, sz)] == 0;
  };
  for (int z = 0; z < g.nz; ++z)
    for (int y = 0; y < g.ny; ++y)
      for (int q = 0; q < L::Q; ++q) {
        if (L::c(q, 0) < 0 && written(0, y, z, q))
          f[q * r.stride + g.index(g.nx - 2, y, z)] = f[q * r.stride + g.index(0, y, z)];
        if (L::c(q, 0) > 0 && written(g.nx - 1, y, z, q))
          f[q * r.stride + g.index(1, y, z)] = f[q * r.stride + g.index(g.nx - 1, y, z)];
      }
}

template <class L, class T>
void run_case(const Params& p) {
  const bool d3 = p.lattice == LatticeKind::D3Q19;
  const long nx = 12, ny = 10, nz = d3 ? 6 : 1;
  test::Scene whole = test::make_scene(p.lattice, nx, ny, nz);
  whole.setup.precision = p.precision;
  whole.setup.streaming = p.streaming;
  whole.setup.tau = 0.7;
  whole.setup.body_force = {2e-5, 0, 0};
  const int wall = test::add_boundary(whole, BoundaryKind::Wall);
  const int lid = test::add_boundary(whole, BoundaryKind::Velocity, {0.02, 0, 0});
  test::add_y_walls(whole, wall, lid);
  test::randomize(whole, 0.01, 0.02, 7);

  // The same grid as one piece split along x with one ghost layer per side.
  test::Scene piece = whole;
  Grid& gp = piece.setup.domain;
  gp.split = {true, false, false};
  gp.ghost = 1;
  const GridView gv = gp.view();
  ASSERT_EQ(gv.nx, nx + 2);
  const auto n = static_cast<std::size_t>(gv.n);
  piece.flags.assign(n, 0);
  piece.rho.assign(n, 1.0);
  piece.u.assign(3 * n, 0.0);
  for (long z = 0; z < nz; ++z)
    for (long y = 0; y < ny; ++y)
      for (long x = -1; x <= nx; ++x) {
        const long xw = (x + nx) % nx;  // periodic image in the whole grid
        const auto wi = test::cell_index(whole, xw, y, z);
        const auto pi = static_cast<std::size_t>(gv.index(static_cast<int>(x + 1), static_cast<int>(y), static_cast<int>(z)));
        const bool ghost = x < 0 || x >= nx;
        // A ghost copies its image's boundary flag; a copy of a fluid cell is a ghost.
        piece.flags[pi] = ghost && whole.flags[wi] == 0 ? kGhostFlag : whole.flags[wi];
        piece.rho[pi] = whole.rho[wi];
        for (int a = 0; a < 3; ++a) piece.u[3 * pi + a] = whole.u[3 * wi + a];
      }

  auto a = make_lbm_solver(whole.setup, Backend::Host);
  auto b = make_lbm_solver(piece.setup, Backend::Host);
  a->initialize(whole.flags, whole.rho, whole.u);
  b->initialize(piece.flags, piece.rho, piece.u);
  const int steps = 13;
  for (int t = 0; t < steps; ++t) {
    a->step(1);
    const bool odd = (b->steps_done() & 1) == 1;
    if (p.streaming == StreamKind::TwoLattice || odd) exchange_before<T>(*b, L::Q);
    if (p.split_step) {
      for (const CellBox& box : gp.outer(1)) b->step_box(box);
      b->step_box(gp.inner(1));
    } else {
      b->step_box(gp.owned());
    }
    b->end_step();
    if (p.streaming == StreamKind::AA && odd) exchange_after_odd<L, T>(*b);
  }
  // Reading the incoming populations of the edge cells needs the ghosts too
  // (two-lattice pull; A-A after an even step).
  if (p.streaming == StreamKind::TwoLattice || (b->steps_done() & 1) == 1) exchange_before<T>(*b, L::Q);
  const std::vector<double> fa = a->populations(), fb = b->populations();
  const GridView ga = whole.setup.domain.view();
  long compared = 0;
  for (int q = 0; q < L::Q; ++q)
    for (int z = 0; z < nz; ++z)
      for (int y = 0; y < ny; ++y)
        for (int x = 0; x < nx; ++x) {
          if (whole.flags[test::cell_index(whole, x, y, z)] != 0) continue;
          const double va = fa[static_cast<std::size_t>(q * ga.n + ga.index(x, y, z))];
          const double vb = fb[static_cast<std::size_t>(q * gv.n + gv.index(x + 1, y, z))];
          ASSERT_EQ(std::memcmp(&va, &vb, sizeof va), 0) << "q " << q << " cell " << x << "," << y << "," << z
                                                        << ": " << va << " vs " << vb;
          ++compared;
        }
  EXPECT_GT(compared, 0);
  const LbmDiagnostics da = a->diagnostics(), db = b->diagnostics();
  EXPECT_EQ(da.fluid_cells, db.fluid_cells);  // ghosts are not counted
  EXPECT_EQ(da.mass, db.mass);
}

class GhostLayers : public ::testing::TestWithParam<Params> {};

TEST_P(GhostLayers, SplitPieceEqualsWholeGridBitwise) {
  const Params p = GetParam();
  if (p.lattice == LatticeKind::D2Q9) {
    if (p.precision == Precision::FP32) run_case<D2Q9, float>(p);
    else run_case<D2Q9, double>(p);
  } else {
    if (p.precision == Precision::FP32) run_case<D3Q19, float>(p);
    else run_case<D3Q19, double>(p);
  }
}

std::vector<Params> all_params() {
  std::vector<Params> v;
  for (auto l : {LatticeKind::D2Q9, LatticeKind::D3Q19})
    for (auto pr : {Precision::FP64, Precision::FP32})
      for (auto s : {StreamKind::AA, StreamKind::TwoLattice})
        for (bool split : {false, true}) v.push_back({l, pr, s, split});
  return v;
}

std::string name(const ::testing::TestParamInfo<Params>& i) {
  const Params& p = i.param;
  return std::string(to_string(p.lattice)) + "_" + to_string(p.precision) + "_" + to_string(p.streaming) +
         (p.split_step ? "_outer_inner" : "_owned");
}

INSTANTIATE_TEST_SUITE_P(Lbm, GhostLayers, ::testing::ValuesIn(all_params()), name);

}  // namespace
}  // namespace lbdem::lbm
