// The block packing on several ranks (run under `mpiexec -n N`, N = 1..4):
// each rank packs only the particles its piece of a lattice decomposition
// owns (DemDomain::owner), and the union over the ranks is the one-rank set
// bit for bit (rank 0 packs the whole set itself and compares); every
// particle is held by exactly one rank, and no rank generated more than its
// piece and a layer of blocks around it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <vector>

#include "core/grid.hpp"
#include "dem/block_packing.hpp"
#include "dem/domain.hpp"
#include "dem/system.hpp"
#include "halo/comm.hpp"
#include "halo/decomposition.hpp"

namespace lbdem::dem {
namespace {

const halo::Comm& world() { return halo::Comm::world(); }

// One packed particle as bytes: id, position, velocity, radius, mass.
struct Row {
  std::int64_t id;
  double x[3], v[3], r, m;
};

void pack_and_compare(const BlockPackingSpec& s, const std::array<long, 3>& cells, std::array<int, 3> cut) {
  const Grid whole = Grid::whole(cells, s.periodic);
  const halo::Decomposition dec = halo::decompose(whole, world().size(), cut);
  DemParams p;
  p.lo = s.lo;
  p.hi = s.hi;
  p.periodic = s.periodic;
  const DemDomain dom = domain_from_decomposition(world(), dec, p);
  const BlockPacking bp(s);
  Vec3d lo, hi;
  dom.piece(world().rank(), lo, hi);
  const int me = world().rank();
  const HostParticles mine = bp.pack({lo.x, lo.y, lo.z}, {hi.x, hi.y, hi.z},
                                     [&](const Vec3d& x) { return dom.owner(x) == me; });
  // The piece's work: its share of the box plus a block and a displacement
  // each side along every cut axis, each block one particle over its share.
  double share = 1;
  long blocks_near = 1;
  for (int a = 0; a < s.dim; ++a) {
    const auto k = static_cast<std::size_t>(a);
    const double L = s.hi[k] - s.lo[k];
    const double block_len = double(s.dim == 3 ? BlockPacking::kBlockEdge3d : BlockPacking::kBlockEdge2d) * L /
                             double(bp.sites_per_axis()[k]);
    const double span = dec.dims[k] > 1 ? std::min(L, hi[a] - lo[a] + 2 * (block_len + bp.displacement())) : L;
    share *= span / L;
    blocks_near *= std::min(bp.blocks_per_axis()[k], static_cast<long>(std::ceil(span / block_len)) + 1);
  }
  EXPECT_LE(double(bp.generated()), double(s.count) * share + double(blocks_near)) << "rank " << me;
  std::vector<Row> rows;
  for (Index i = 0; i < mine.size(); ++i) {
    const auto I = static_cast<std::size_t>(i);
    Row r{mine.id[I], {mine.x[I].x, mine.x[I].y, mine.x[I].z}, {mine.v[I].x, mine.v[I].y, mine.v[I].z}, mine.r[I], mine.mass[I]};
    rows.push_back(r);
  }
  const auto all = world().gather(std::as_bytes(std::span<const Row>(rows.data(), rows.size())), 0);
  if (me != 0) return;
  const HostParticles ref = bp.pack_all();
  std::map<std::int64_t, Row> got;
  for (const auto& bytes : all) {
    const std::size_t n = bytes.size() / sizeof(Row);
    for (std::size_t i = 0; i < n; ++i) {
      Row r;
      std::memcpy(&r, bytes.data() + i * sizeof(Row), sizeof(Row));
      ASSERT_TRUE(got.emplace(r.id, r).second) << "id " << r.id << " on two ranks";
    }
  }
  ASSERT_EQ(static_cast<long>(got.size()), s.count);
  for (Index i = 0; i < ref.size(); ++i) {
    const auto I = static_cast<std::size_t>(i);
    const auto it = got.find(ref.id[I]);
    ASSERT_NE(it, got.end()) << "id " << ref.id[I] << " on no rank";
    const Row& r = it->second;
    const double want[8] = {ref.x[I].x, ref.x[I].y, ref.x[I].z, ref.v[I].x, ref.v[I].y, ref.v[I].z, ref.r[I], ref.mass[I]};
    const double have[8] = {r.x[0], r.x[1], r.x[2], r.v[0], r.v[1], r.v[2], r.r, r.m};
    ASSERT_EQ(std::memcmp(want, have, sizeof want), 0) << "id " << ref.id[I];
  }
}

// The paper's 3D suspension at 1/64 of its volume (d = 10 cells, phi 0.128),
// cut along its long axis as the scaling runs cut it, and automatically.
TEST(BlockPackingMpi, PiecesUnionIsTheOneRankSet3d) {
  BlockPackingSpec s;
  s.hi = {128, 504, 128};
  s.radius = 5;
  s.density = 692.3;
  s.count = 2019;
  s.speed = 5e-3;
  s.seed = 11;
  pack_and_compare(s, {128, 504, 128}, {1, world().size(), 1});
  pack_and_compare(s, {128, 504, 128}, {0, 0, 0});
  s.periodic = {true, false, true};  // walls along the cut axis
  pack_and_compare(s, {128, 504, 128}, {1, world().size(), 1});
}

TEST(BlockPackingMpi, PiecesUnionIsTheOneRankSet2d) {
  BlockPackingSpec s;
  s.dim = 2;
  s.hi = {240, 960, 1};
  s.radius = 5;
  s.density = 692.3;
  s.count = 375;
  s.speed = 1e-2;
  s.seed = 5;
  pack_and_compare(s, {240, 960, 1}, {1, world().size(), 1});
  pack_and_compare(s, {240, 960, 1}, {world().size(), 1, 1});
}

}  // namespace
}  // namespace lbdem::dem
