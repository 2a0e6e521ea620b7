// Neighbour search and force paths: cell + Verlet list against all-pairs
// brute force, reordering invariance, pair- vs particle-parallel forces,
// bitwise reproducibility, CPU vs GPU.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <cstdio>
#include <random>

#include "dem_test_util.hpp"

using namespace lbdem;
using namespace lbdem::dem;
using namespace lbdem::dem::test;

namespace {

using PairSet = std::vector<std::pair<std::int64_t, std::int64_t>>;

PairSet brute_force(const HostParticles& h, const Box& box, double extra) {
  PairSet out;
  for (Index i = 0; i < h.size(); ++i)
    for (Index j = i + 1; j < h.size(); ++j) {
      const Vec3d d = box.min_image(h.x[j] - h.x[i]);
      const double rc = h.r[i] + h.r[j] + extra;
      if (dot(d, d) < rc * rc) out.emplace_back(std::min(h.id[i], h.id[j]), std::max(h.id[i], h.id[j]));
    }
  std::sort(out.begin(), out.end());
  return out;
}

Box box_of(const DemParams& p) {
  Box b;
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = p.lo[k];
    b.len[k] = p.hi[k] - p.lo[k];
    b.periodic[k] = p.periodic[k];
  }
  return b;
}

// Random polydisperse spheres (overlaps allowed: many contacts), plus
// particles placed exactly on cell faces, on the periodic faces (lo and hi,
// hi wraps to lo) and just inside hi.
HostParticles random_cloud(long n, const DemParams& p, double rmin, double rmax, double cell, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> U(0, 1);
  HostParticles h;
  for (long i = 0; i < n; ++i) {
    Vec3d x;
    for (int k = 0; k < 3; ++k) x[k] = p.lo[k] + U(rng) * (p.hi[k] - p.lo[k]);
    const int mode = static_cast<int>(i % 7);
    const int ax = static_cast<int>(i % 3);
    if (mode == 1) x[ax] = p.lo[ax] + std::floor(U(rng) * 5) * cell;  // on a cell face
    if (mode == 2) x[ax] = p.lo[ax];                                     // on the lower periodic face
    if (mode == 3) x[ax] = p.hi[ax];                                     // on the upper face (wraps)
    if (mode == 4) x[ax] = std::nextafter(p.hi[ax], p.lo[ax]);           // just inside hi
    h.add(x, rmin + (rmax - rmin) * U(rng), 1000, {U(rng) - 0.5, U(rng) - 0.5, U(rng) - 0.5});
  }
  return h;
}

DemParams cloud_params(std::array<bool, 3> periodic) {
  DemParams p;
  p.lo = {-3, 0, 1};
  p.hi = {9, 13, 12.5};
  p.periodic = periodic;
  p.material = simple_material(10.0, 0.8);
  p.skin = 0.15;
  return p;
}

}  // namespace

class DemNeighbours : public ::testing::TestWithParam<Backend> {};

// Identical sets (exact equality: same min-image arithmetic, random
// positions never tie with the cutoff), right after the build and after
// steps that move particles and trigger rebuilds, on fully and partly
// periodic boxes (partly periodic: particles also outside the box on the
// closed axis, clamped into edge cells).
TEST_P(DemNeighbours, VerletListMatchesBruteForce) {
  for (auto per : {std::array<bool, 3>{true, true, true}, std::array<bool, 3>{true, false, true}}) {
    DemParams p = cloud_params(per);
    const double rmin = 0.25, rmax = 0.5;
    const double rc = 2 * rmax + p.skin;
    const double cell = (p.hi[0] - p.lo[0]) / std::floor((p.hi[0] - p.lo[0]) / rc);
    HostParticles h = random_cloud(1500, p, rmin, rmax, cell, 7);
    if (!per[1])
      for (int i = 0; i < 20; ++i) h.x[i * 13].y = (i % 2) ? p.hi[1] + 0.3 : p.lo[1] - 0.2;
    p.dt = min_collision_time(p, h) / 50;
    DemSystem sys(Exec(GetParam()), p, h);
    EXPECT_DOUBLE_EQ(sys.cell_size(0), cell);
    const Box box = box_of(p);
    HostParticles now = sys.download();
    EXPECT_EQ(sys.neighbour_pairs(), brute_force(now, box, p.skin));
    EXPECT_EQ(sys.contact_pairs(), brute_force(now, box, 0.0));
    EXPECT_GT(sys.contact_pairs().size(), 100u);
    for (int s = 0; s < 12; ++s) {
      sys.advance(1);
      now = sys.download();
      ASSERT_EQ(sys.contact_pairs(), brute_force(now, box, 0.0)) << "step " << s;
    }
    EXPECT_GT(sys.stats().rebuilds, 0);
  }
}

namespace {

std::map<std::int64_t, std::pair<Vec3d, Vec3d>> by_id(const HostParticles& h) {
  std::map<std::int64_t, std::pair<Vec3d, Vec3d>> m;
  for (Index i = 0; i < h.size(); ++i) m[h.id[i]] = {h.f[i], h.t[i]};
  return m;
}

// Largest force/torque difference relative to the largest force/torque.
double rel_diff(const HostParticles& a, const HostParticles& b) {
  auto ma = by_id(a), mb = by_id(b);
  double df = 0, dt = 0, sf = 0, st = 0;
  for (auto& [id, ft] : ma) {
    const auto& o = mb.at(id);
    df = std::max(df, norm(ft.first - o.first));
    dt = std::max(dt, norm(ft.second - o.second));
    sf = std::max(sf, norm(ft.first));
    st = std::max(st, norm(ft.second));
  }
  return std::max(df / sf, st > 0 ? dt / st : 0.0);
}

HostParticles dense_frictional(DemParams& p, unsigned seed) {
  p = cloud_params({true, true, true});
  p.friction = true;
  p.material = simple_material(1e3, 0.7, 0.4);
  HostParticles h = random_cloud(1200, p, 0.3, 0.5, 1.0, seed);
  for (auto& w : h.w) w = {1, -2, 0.5};
  p.dt = min_collision_time(p, h) / 50;
  return h;
}

HostParticles shuffled(const HostParticles& h, unsigned seed) {
  std::vector<Index> perm(h.size());
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(seed));
  HostParticles o;
  for (Index i : perm) {
    o.x.push_back(h.x[i]); o.v.push_back(h.v[i]); o.w.push_back(h.w[i]); o.r.push_back(h.r[i]);
    o.mass.push_back(h.mass[i]); o.id.push_back(h.id[i]); o.type.push_back(h.type[i]);
  }
  return o;
}

}  // namespace

// Frictional dense cloud, 30 steps (histories built, several rebuilds): a
// shuffled input array, the other force path, and (where present) the other
// backend give the same forces and torques. Only the order of floating-point
// sums differs (~1e-16 relative per contact, a dozen contacts per particle),
// amplified by 30 steps of a stiff contact network: 1e-9 of the largest force
// is far above that and far below any physics error (a lost history would be
// O(1)).
TEST_P(DemNeighbours, ReorderingAndPathsGiveSameForces) {
  DemParams p;
  HostParticles h = dense_frictional(p, 11);
  DemSystem a(Exec(GetParam()), p, h);
  a.advance(30);
  const HostParticles ra = a.download();
  EXPECT_GT(a.stats().rebuilds, 1);

  DemSystem b(Exec(GetParam()), p, shuffled(h, 3));
  b.advance(30);
  EXPECT_LT(rel_diff(ra, b.download()), 1e-9);

  DemParams pp = p;
  pp.path = ForcePath::Pair;
  DemSystem c(Exec(GetParam()), pp, shuffled(h, 5));
  c.advance(30);
  EXPECT_LT(rel_diff(ra, c.download()), 1e-9);
  std::printf("[ paths ] shuffled %.2e, pair+shuffled %.2e\n", rel_diff(ra, b.download()), rel_diff(ra, c.download()));

  // Frictionless too (the other instantiation).
  DemParams q = p, qp;
  q.friction = false;
  qp = q;
  qp.path = ForcePath::Pair;
  DemSystem d(Exec(GetParam()), q, h), e(Exec(GetParam()), qp, shuffled(h, 9));
  d.advance(30);
  e.advance(30);
  EXPECT_LT(rel_diff(d.download(), e.download()), 1e-9);
}

// The particle-parallel path has no atomics and a fixed summation order:
// two runs are bitwise identical.
TEST_P(DemNeighbours, ParticlePathIsBitwiseReproducible) {
  DemParams p;
  HostParticles h = dense_frictional(p, 21);
  DemSystem a(Exec(GetParam()), p, h), b(Exec(GetParam()), p, h);
  a.advance(25);
  b.advance(25);
  const HostParticles ra = a.download(), rb = b.download();
  ASSERT_EQ(ra.size(), rb.size());
  for (Index i = 0; i < ra.size(); ++i) {
    ASSERT_EQ(ra.id[i], rb.id[i]);
    ASSERT_EQ(ra.f[i].x, rb.f[i].x);
    ASSERT_EQ(ra.f[i].y, rb.f[i].y);
    ASSERT_EQ(ra.t[i].z, rb.t[i].z);
    ASSERT_EQ(ra.x[i].x, rb.x[i].x);
  }
}

INSTANTIATE_TEST_SUITE_P(All, DemNeighbours, ::testing::ValuesIn(lbdem::test::backends()), lbdem::test::backend_name);

// CPU against GPU on the same frictional cloud (same tolerance argument).
TEST(DemCrossBackend, CpuAndGpuAgree) {
  if (!lbdem::test::gpu_available()) GTEST_SKIP() << "no usable CUDA device: " << cuda_unavailable_reason();
  for (ForcePath path : {ForcePath::Particle, ForcePath::Pair}) {
    DemParams p;
    HostParticles h = dense_frictional(p, 31);
    p.path = path;
    DemSystem a(Exec(Backend::Host), p, h), b(Exec(Backend::Cuda), p, h);
    a.advance(30);
    b.advance(30);
    EXPECT_LT(rel_diff(a.download(), b.download()), 1e-9) << to_string(path);
    // A displacement within round-off of skin/2 could shift one rebuild.
    EXPECT_NEAR(a.stats().rebuilds, b.stats().rebuilds, 1);
  }
}

// The force kernel's lanes per particle (DemParams::force_lanes): a value the
// kernel does not have is refused, naming it.
TEST(DemForceLanes, RefusesOtherCounts) {
  DemParams p;
  HostParticles h = dense_frictional(p, 7);
  for (int lanes : {0, 3, 32}) {
    p.force_lanes = lanes;
    try {
      DemSystem s(Exec(Backend::Host), p, h);
      ADD_FAILURE() << "force_lanes " << lanes << " accepted";
    } catch (const lbdem::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("force_lanes: " + std::to_string(lanes)), std::string::npos) << e.what();
    }
  }
}

// The lane-parallel force kernel against the host's one thread per particle
// on the frictional cloud, periodic and between walls: the same contacts,
// partial sums added in another order (rounding only: the tolerance of
// CpuAndGpuAgree).
TEST(DemCrossBackend, ForceLanesAgreeWithHost) {
  if (!lbdem::test::gpu_available()) GTEST_SKIP() << "no usable CUDA device: " << cuda_unavailable_reason();
  for (bool walls : {false, true}) {
    for (int lanes : {2, 4, 8, 16}) {
      DemParams p;
      HostParticles h = dense_frictional(p, 31);
      if (walls) {
        p.periodic = {true, false, true};
        p.walls.push_back(Wall{{0, 0, 0}, {0, 1, 0}});
        p.walls.push_back(Wall{{0, 13, 0}, {0, -1, 0}});
      }
      p.force_lanes = lanes;
      DemSystem a(Exec(Backend::Host), p, h), b(Exec(Backend::Cuda), p, h);
      a.advance(30);
      b.advance(30);
      EXPECT_LT(rel_diff(a.download(), b.download()), 1e-9) << "lanes " << lanes << (walls ? ", walls" : "");
    }
  }
}
