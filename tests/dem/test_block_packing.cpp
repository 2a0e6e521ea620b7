// The block packing (dem/block_packing.hpp): the pieces of any cut pack to
// exactly the whole set (ids, positions, velocities bitwise), no two
// particles overlap (all pairs), the count and the fraction at the block
// scale are as asked, and a piece generates only its neighbourhood.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <vector>

#include "core/error.hpp"
#include "dem/block_packing.hpp"

using namespace lbdem;
using namespace lbdem::dem;

namespace {

constexpr double kPi = 3.14159265358979323846;

// The paper's suspension at 1/64 of its volume: d = 10 cells, phi = 0.128.
BlockPackingSpec suspension3d(std::array<bool, 3> per = {true, true, true}) {
  BlockPackingSpec s;
  s.dim = 3;
  s.lo = {0, 0, 0};
  s.hi = {128, 504, 128};
  s.periodic = per;
  s.radius = 5;
  s.density = 692.3;
  s.count = std::lround(0.128 * 128.0 * 504 * 128 / (4.0 / 3.0 * kPi * 125));
  s.speed = 5e-3;
  s.velocity = {0, 1e-3, 0};
  s.seed = 7;
  return s;
}

BlockPackingSpec suspension2d() {
  BlockPackingSpec s;
  s.dim = 2;
  s.lo = {0, 0, 0};
  s.hi = {240, 960, 1};
  s.radius = 5;
  s.density = 692.3;
  s.count = std::lround(0.128 * 240.0 * 960 / (kPi * 25));
  s.speed = 1e-2;
  s.seed = 3;
  return s;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void expect_same_particle(const HostParticles& a, Index i, const HostParticles& b, Index j) {
  const auto I = static_cast<std::size_t>(i), J = static_cast<std::size_t>(j);
  ASSERT_EQ(a.id[I], b.id[J]);
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(same_bits(a.x[I][k], b.x[J][k])) << "id " << a.id[I] << " x" << k;
    ASSERT_TRUE(same_bits(a.v[I][k], b.v[J][k])) << "id " << a.id[I] << " v" << k;
    ASSERT_TRUE(same_bits(a.w[I][k], b.w[J][k])) << "id " << a.id[I] << " w" << k;
  }
  ASSERT_TRUE(same_bits(a.r[I], b.r[J]));
  ASSERT_TRUE(same_bits(a.mass[I], b.mass[J]));
}

// Cuts of [lo, hi) into n parts at uneven places (not block-aligned).
std::vector<double> cuts(double lo, double hi, int n) {
  std::vector<double> c{lo};
  for (int i = 1; i < n; ++i) c.push_back(lo + (hi - lo) * (double(i) + 0.37 * (i % 2)) / double(n));
  c.push_back(hi);
  return c;
}

// Every cut of the box into nx x ny x nz pieces packs to the whole set, each
// particle in exactly one piece.
void expect_union_is_whole(const BlockPackingSpec& s, int nx, int ny, int nz) {
  const BlockPacking bp(s);
  const HostParticles all = bp.pack_all();
  ASSERT_EQ(all.size(), s.count);
  std::map<std::int64_t, std::pair<int, Index>> seen;  // id -> (piece, index)
  std::vector<HostParticles> pieces;
  const auto cx = cuts(s.lo[0], s.hi[0], nx), cy = cuts(s.lo[1], s.hi[1], ny), cz = cuts(s.lo[2], s.hi[2], nz);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const std::array<double, 3> lo{cx[i], cy[j], s.dim == 3 ? cz[k] : -1e300},
            hi{cx[i + 1], cy[j + 1], s.dim == 3 ? cz[k + 1] : 1e300};
        pieces.push_back(bp.pack(lo, hi));
        const HostParticles& p = pieces.back();
        for (Index q = 0; q < p.size(); ++q) {
          for (int a = 0; a < s.dim; ++a) {
            ASSERT_GE(p.x[static_cast<std::size_t>(q)][a], lo[static_cast<std::size_t>(a)]);
            ASSERT_LT(p.x[static_cast<std::size_t>(q)][a], hi[static_cast<std::size_t>(a)]);
          }
          ASSERT_TRUE(seen.emplace(p.id[static_cast<std::size_t>(q)], std::make_pair(int(pieces.size()) - 1, q)).second)
              << "id " << p.id[static_cast<std::size_t>(q)] << " in two pieces";
        }
      }
  ASSERT_EQ(static_cast<long>(seen.size()), s.count) << nx << "x" << ny << "x" << nz;
  for (Index i = 0; i < all.size(); ++i) {
    ASSERT_EQ(all.id[static_cast<std::size_t>(i)], i);  // pack_all: id order
    const auto it = seen.find(i);
    ASSERT_NE(it, seen.end());
    expect_same_particle(all, i, pieces[static_cast<std::size_t>(it->second.first)], it->second.second);
  }
}

// All pairs (minimum image on periodic axes): at least 2 r apart; centres
// inside the box, a radius off closed faces.
void expect_apart(const BlockPackingSpec& s, const HostParticles& p) {
  const double d2min = 4 * s.radius * s.radius * (1 - 1e-12);
  for (Index i = 0; i < p.size(); ++i) {
    const Vec3d& xi = p.x[static_cast<std::size_t>(i)];
    for (int a = 0; a < s.dim; ++a) {
      const auto k = static_cast<std::size_t>(a);
      ASSERT_GE(xi[a], s.lo[k] + (s.periodic[k] ? 0 : s.radius));
      if (s.periodic[k]) {
        ASSERT_LT(xi[a], s.hi[k]);
      } else {
        ASSERT_LE(xi[a], s.hi[k] - s.radius);
      }
    }
    if (s.dim == 2) {
      ASSERT_EQ(xi[2], 0.5);
    }
    for (Index j = i + 1; j < p.size(); ++j) {
      Vec3d d = p.x[static_cast<std::size_t>(j)] - xi;
      for (int a = 0; a < s.dim; ++a) {
        const auto k = static_cast<std::size_t>(a);
        const double L = s.hi[k] - s.lo[k];
        if (s.periodic[k]) d[a] -= L * std::rint(d[a] / L);
      }
      ASSERT_GE(dot(d, d), d2min) << "ids " << p.id[static_cast<std::size_t>(i)] << " and " << p.id[static_cast<std::size_t>(j)];
    }
  }
}

TEST(BlockPacking, PiecesOfAnyCutAreTheWholeSetBitwise) {
  for (auto [nx, ny, nz] : {std::array<int, 3>{1, 1, 1}, {1, 2, 1}, {1, 4, 1}, {2, 3, 2}, {3, 7, 1}})
    expect_union_is_whole(suspension3d(), nx, ny, nz);
  expect_union_is_whole(suspension3d({true, false, false}), 2, 3, 2);
  for (auto [nx, ny] : {std::array<int, 2>{1, 4}, {3, 5}}) expect_union_is_whole(suspension2d(), nx, ny, 1);
}

TEST(BlockPacking, NoTwoParticlesOverlap) {
  for (const auto& s : {suspension3d(), suspension3d({true, false, false}), suspension2d()}) {
    const BlockPacking bp(s);
    // The guarantee: sites nn apart, each centre within (nn - 2 r) / 2 of its own.
    EXPECT_NEAR(bp.nearest_neighbour() - 2 * bp.displacement(), 2 * s.radius, 1e-9);
    EXPECT_GT(bp.displacement(), 0.1 * s.radius);  // a random packing, not the lattice
    expect_apart(s, bp.pack_all());
  }
}

TEST(BlockPacking, CountAndSolidFractionAtTheBlockScale) {
  const auto s = suspension3d();
  const BlockPacking bp(s);
  const HostParticles p = bp.pack_all();
  // The count is exact, so the solid fraction is count V_p / V, the asked
  // 0.128 to within half a particle's volume (the rounding of the count).
  ASSERT_EQ(p.size(), s.count);
  const double vbox = 128.0 * 504 * 128, vp = 4.0 / 3.0 * kPi * 125;
  EXPECT_NEAR(double(p.size()) * vp / vbox, 0.128, 0.5 * vp / vbox);
  // Each block holds count x sites_b / sites rounded (the largest remainder):
  // within one particle of its share.
  long total = 0;
  for (long b = 0; b < bp.blocks(); ++b) total += bp.block_count(b);
  EXPECT_EQ(total, s.count);
  // Each slab of 4 along y holds a quarter: a uniform random subset of the
  // sites would give a count of standard deviation below sqrt(n); the blocks'
  // fixed shares only narrow it. Five of those.
  for (int q = 0; q < 4; ++q) {
    long n = 0;
    for (const Vec3d& x : p.x) n += x.y >= 126.0 * q && x.y < 126.0 * (q + 1);
    EXPECT_NEAR(double(n), double(s.count) / 4, 5 * std::sqrt(double(s.count) / 4)) << "slab " << q;
  }
  // The blocks fill alike: each within one particle of count x sites_b / sites.
  for (long b = 0; b < bp.blocks(); ++b)
    EXPECT_LT(std::abs(double(bp.block_count(b)) - double(s.count) * double(bp.block_sites(b)) / double(bp.sites())), 1.0)
        << "block " << b;
  // The added velocities have no net momentum (block means removed), their size ~ speed.
  Vec3d sum{0, 0, 0};
  double speed = 0;
  for (const Vec3d& v : p.v) {
    const Vec3d d = v - s.velocity;
    sum = sum + d;
    speed += std::sqrt(dot(d, d));
  }
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(sum[k], 0.0, 1e-12 * double(p.size()) * s.speed);
  EXPECT_NEAR(speed / double(p.size()), s.speed, 0.05 * s.speed);
}

TEST(BlockPacking, APieceGeneratesOnlyItsNeighbourhood) {
  auto s = suspension3d();
  s.hi[1] = 2016;  // the paper's long axis, cut into 8 pieces of 252 cells
  s.count *= 4;
  const BlockPacking bp(s);
  const double block_len = double(BlockPacking::kBlockEdge3d) * 2016.0 / double(bp.sites_per_axis()[1]);
  for (int r = 0; r < 8; ++r) {
    const HostParticles p = bp.pack({0, 252.0 * r, 0}, {128, 252.0 * (r + 1), 128});
    // The blocks within the displacement of the piece: at most the piece plus
    // a block and a displacement each side; each block one over its share.
    const double span = 252 + 2 * (block_len + bp.displacement());
    const double bound = double(s.count) * span / 2016 + double(bp.blocks_per_axis()[0] * bp.blocks_per_axis()[2]) *
                                                              std::ceil(span / block_len + 1);
    EXPECT_LE(double(bp.generated()), bound) << "piece " << r;
    EXPECT_LT(bp.generated(), s.count / 3) << "piece " << r;
    EXPECT_GT(p.size(), 0);
  }
}

TEST(BlockPacking, DeterministicAndSeeded) {
  auto s = suspension2d();
  const HostParticles a = BlockPacking(s).pack_all(), b = BlockPacking(s).pack_all();
  ASSERT_EQ(a.size(), b.size());
  for (Index i = 0; i < a.size(); ++i) expect_same_particle(a, i, b, i);
  s.seed = 4;
  const HostParticles c = BlockPacking(s).pack_all();
  long moved = 0;
  for (Index i = 0; i < a.size(); ++i) moved += !same_bits(a.x[static_cast<std::size_t>(i)].x, c.x[static_cast<std::size_t>(i)].x);
  EXPECT_GT(moved, a.size() / 2);
}

TEST(BlockPacking, WithoutDisplacementEveryCentreIsOnItsSite) {
  auto s = suspension3d();
  s.displace = false;
  const BlockPacking bp(s);
  const HostParticles p = bp.pack_all();
  ASSERT_EQ(p.size(), s.count);
  const auto m = bp.sites_per_axis();
  for (const Vec3d& x : p.x)
    for (int a = 0; a < 3; ++a) {
      const double q = x[a] / ((s.hi[static_cast<std::size_t>(a)] - s.lo[static_cast<std::size_t>(a)]) / double(m[static_cast<std::size_t>(a)])) - 0.5;
      ASSERT_NEAR(q, std::rint(q), 1e-9);
    }
}

TEST(BlockPacking, TooManyParticlesNameTheKey) {
  auto s = suspension3d();
  s.count = std::lround(0.8 * 128.0 * 504 * 128 / (4.0 / 3.0 * kPi * 125));  // beyond close packing (0.74)
  try {
    BlockPacking bp(s);
    FAIL() << "accepted " << s.count << " particles";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("particles.count"), std::string::npos) << e.what();
  }
}

}  // namespace
