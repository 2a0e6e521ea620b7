// DEM on several ranks against one rank (run under `mpiexec -n N`, N = 1..4):
// particles migrate across every face and edge of the cut (periodic wrap
// included) and none is lost or duplicated; the gathered states (positions,
// velocities, spins, forces) equal the one-rank run's bitwise, both summing
// contacts in global-id order (DemParams::contact_order); a cut thinner than
// the ghost width is refused. Rank 0 runs the one-rank reference itself.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <memory>
#include <cmath>
#include <cstring>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/grid.hpp"
#include "dem/domain.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"
#include "halo/comm.hpp"

namespace lbdem::dem {
namespace {

const halo::Comm& world() { return halo::Comm::world(); }
// Whether a check failed on any rank: every rank stops together (a rank that
// returned alone would leave the others waiting in a collective).
bool any_failure() { return world().any(::testing::Test::HasFailure()); }

Material material(double k, double e, double mu) {
  Material m;
  m.stiffness = k;
  m.restitution = e;
  m.friction = mu;
  m.wall_stiffness = k;
  m.wall_restitution = e;
  m.wall_friction = mu;
  return m;
}

void random_velocities(HostParticles& hp, double vrms, double wrms, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nv(0, vrms / std::sqrt(3.0)), nw(0, wrms / std::sqrt(3.0));
  for (Index i = 0; i < hp.size(); ++i) {
    hp.v[static_cast<std::size_t>(i)] = {nv(rng), nv(rng), nv(rng)};
    hp.w[static_cast<std::size_t>(i)] = {nw(rng), nw(rng), nw(rng)};
  }
}

struct Scene {
  DemParams p;
  HostParticles hp;
};

// A frictional granular gas (~300 spheres at the default solid fraction) in a
// fully periodic box: every particle crosses several cut faces (and the
// periodic boundary) in 10^4 steps.
Scene gas(double solid_fraction = 0.04) {
  Scene s;
  DemParams& p = s.p;
  p.lo = {0, 0, 0};
  p.hi = {1.6, 1.6, 1.6};
  p.periodic = {true, true, true};
  p.friction = true;
  p.material = material(1e5, 0.9, 0.3);
  RandomPackingSpec r;
  r.lo = p.lo;
  r.hi = p.hi;
  r.periodic = p.periodic;
  r.solid_fraction = solid_fraction;
  r.r_min = 0.045;
  r.r_max = 0.055;
  r.density = 2600;
  r.seed = 11;
  s.hp = random_packing(r);
  random_velocities(s.hp, 1.5, 20.0, 5);
  // Probes aimed at the box's edges and corner, which are edges and corners
  // of the pieces whenever two or three periodic axes are cut: each crosses
  // two (three) faces within one list interval. Skipped where it would
  // overlap a particle of the packing.
  const double L = p.hi[0], e = L - 0.03, rp = 0.05;
  const std::vector<std::pair<Vec3d, Vec3d>> probes = {
      {{e, e, 0.3}, {2, 2, 0}},  {{e, e, 1.1}, {2, 2, 0}},  {{e, 0.5, e}, {2, 0, 2}},
      {{e, 1.3, e}, {2, 0, 2}},  {{0.7, e, e}, {0, 2, 2}},  {{1.4, e, e}, {0, 2, 2}},
      {{e, e, e}, {2, 2, 2}},    {{0.03, 0.03, 0.8}, {-2, -2, 0}}};
  for (const auto& [x, v] : probes) {
    bool free = true;
    for (Index i = 0; i < s.hp.size(); ++i) {
      Vec3d d = s.hp.x[static_cast<std::size_t>(i)] - x;
      for (int k = 0; k < 3; ++k) d[k] -= L * std::round(d[k] / L);
      if (norm(d) < s.hp.r[static_cast<std::size_t>(i)] + rp + 0.01) free = false;
    }
    if (free) s.hp.add(x, rp, 2600, v, {0, 0, 30}, 0, static_cast<std::int64_t>(s.hp.size()));
  }
  p.dt = min_collision_time(p, s.hp) / 50;
  // A wide skin: particles move up to skin/2 between builds, so some change
  // two piece coordinates at once (edge crossings) within one interval.
  p.skin = 0.06;
  p.contact_order = ContactOrder::GlobalId;
  return s;
}

// A bed: spheres rain onto a floor wall under gravity in a box periodic in x
// and y, closed by walls in z; friction and rotation.
Scene bed() {
  Scene s;
  DemParams& p = s.p;
  p.lo = {0, 0, 0};
  p.hi = {0.8, 0.8, 1.2};
  p.periodic = {true, true, false};
  p.friction = true;
  p.gravity = {0, 0, -9.81};
  p.material = material(2e4, 0.5, 0.5);
  p.walls = {Wall{{0, 0, 0}, {0, 0, 1}}, Wall{{0, 0, 1.2}, {0, 0, -1}}};
  RandomPackingSpec r;
  r.lo = {0, 0, 0.05};
  r.hi = {0.8, 0.8, 1.15};
  r.periodic = {true, true, false};
  r.solid_fraction = 0.15;
  r.r_min = 0.03;
  r.r_max = 0.04;
  r.density = 2600;
  r.seed = 3;
  s.hp = random_packing(r);
  random_velocities(s.hp, 0.3, 5.0, 9);
  p.dt = min_collision_time(p, s.hp) / 50;
  p.contact_order = ContactOrder::GlobalId;
  return s;
}

// Cuts tried for the gas: on 2 and 3 ranks one axis at a time, on 4 two axes
// at once (edges), on 8 all three (corners).
std::vector<std::array<int, 3>> gas_cuts(int n) {
  switch (n) {
    case 1: return {{1, 1, 1}};
    case 2: return {{2, 1, 1}, {1, 1, 2}};
    case 3: return {{3, 1, 1}, {1, 3, 1}};
    case 4: return {{2, 2, 1}, {1, 2, 2}};
    case 8: return {{2, 2, 2}};
    default: return {{n, 1, 1}};
  }
}
// Cuts for the bed: across gravity, and across gravity and along the floor.
std::array<int, 3> bed_cut(int n) {
  switch (n) {
    case 2: return {1, 1, 2};
    case 4: return {2, 1, 2};
    case 8: return {2, 2, 2};
    default: return {1, n, 1};
  }
}
// One cut of each rank count for the shorter runs.
std::array<int, 3> one_cut(int n) {
  switch (n) {
    case 4: return {2, 2, 1};
    case 8: return {2, 2, 2};
    default: return {n, 1, 1};
  }
}

std::string text(const std::array<int, 3>& d) {
  return std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]);
}

// Bitwise equality of two gathered sets (ids, then every state component).
void expect_same(const HostParticles& a, const HostParticles& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  long bad = 0;
  for (std::size_t i = 0; i < a.x.size(); ++i) {
    const bool same = a.id[i] == b.id[i] && std::memcmp(&a.x[i], &b.x[i], sizeof(Vec3d)) == 0 &&
                      std::memcmp(&a.v[i], &b.v[i], sizeof(Vec3d)) == 0 &&
                      std::memcmp(&a.w[i], &b.w[i], sizeof(Vec3d)) == 0 &&
                      std::memcmp(&a.f[i], &b.f[i], sizeof(Vec3d)) == 0 &&
                      std::memcmp(&a.t[i], &b.t[i], sizeof(Vec3d)) == 0;
    if (!same && bad++ < 3)
      ADD_FAILURE() << what << ": particle id " << b.id[i] << " differs: x " << a.x[i].x << " vs " << b.x[i].x
                    << ", v " << a.v[i].x << " vs " << b.v[i].x << ", f " << a.f[i].x << " vs " << b.f[i].x;
  }
  EXPECT_EQ(bad, 0) << what << ": particles not bitwise equal to the one-rank run";
}

// Migrations over all ranks (DemStats): across a face, an edge, a corner of
// a piece, and through a periodic face of the box.
struct Crossings {
  long face = 0, edge = 0, corner = 0, periodic = 0;
};

// Runs the scene on all ranks cut `dims` for `steps` steps in chunks of
// `chunk`, comparing with the one-rank reference (rank 0) after each chunk.
// The one-rank run of a scene, sampled every `chunk` steps (rank 0 computes
// it once per scene and reuses it for every cut).
struct Reference {
  std::vector<HostParticles> states;
  std::vector<long> rebuilds;
};

void run_against_reference(const Scene& sc, std::array<int, 3> dims, long steps, long chunk, Crossings* cross,
                           Reference& refs) {
  const halo::Comm& comm = world();
  const DemDomain dom = decompose_box(comm, sc.p, sc.hp, dims);
  DemSystem many(Exec(Backend::Host), sc.p, sc.hp, dom);
  if (comm.root() && refs.states.empty()) {
    DemSystem one(Exec(Backend::Host), sc.p, sc.hp);
    for (long done = 0; done < steps; done += chunk) {
      one.advance(chunk);
      refs.states.push_back(one.gather());
      refs.rebuilds.push_back(one.stats().rebuilds);
    }
  }
  const Index total = sc.hp.size();
  EXPECT_EQ(many.global_size(), total);
  // Rank 0: the reference advanced alike, then every check.
  auto compare = [&](long step, const HostParticles& got, const std::vector<std::vector<std::byte>>& parts,
                     long n_global) {
    const std::string at = text(dims) + " after " + std::to_string(step) + " steps";
    const auto k = static_cast<std::size_t>(step / chunk - 1);
    const HostParticles& ref = refs.states.at(k);
    EXPECT_EQ(n_global, total) << at;
    // None lost, none duplicated: the gathered ids are exactly 0..total-1.
    ASSERT_EQ(got.size(), total) << at;
    for (Index i = 0; i < total; ++i) ASSERT_EQ(got.id[static_cast<std::size_t>(i)], i) << at;
    expect_same(got, ref, at);
    // The global rebuild decisions are the one-rank decisions.
    EXPECT_EQ(many.stats().rebuilds, refs.rebuilds.at(k)) << at;
    if (::testing::Test::HasFailure()) return;
    std::vector<int> owner(static_cast<std::size_t>(total), -1);
    for (int r = 0; r < comm.size(); ++r) {
      const auto& b = parts[static_cast<std::size_t>(r)];
      for (std::size_t k = 0; k < b.size() / sizeof(std::int64_t); ++k) {
        std::int64_t id;
        std::memcpy(&id, b.data() + k * sizeof(id), sizeof(id));
        ASSERT_EQ(owner[static_cast<std::size_t>(id)], -1) << at << ": particle " << id << " owned twice";
        owner[static_cast<std::size_t>(id)] = r;
      }
    }
  };
  for (long done = 0; done < steps; done += chunk) {
    many.advance(chunk);
    const HostParticles got = many.gather();
    // The owner of every particle: each rank's ids, gathered on rank 0.
    const HostParticles mine = many.download();
    std::vector<std::byte> ids(static_cast<std::size_t>(mine.size()) * sizeof(std::int64_t));
    if (!ids.empty()) std::memcpy(ids.data(), mine.id.data(), ids.size());
    const auto parts = comm.gather(ids);
    const long n_global = static_cast<long>(many.global_size());
    if (comm.root()) compare(done + chunk, got, parts, n_global);
    if (any_failure()) return;
  }
  if (cross) {
    const DemStats st = many.stats();
    cross->face = comm.sum(st.migrations[0]);
    cross->edge = comm.sum(st.migrations[1]);
    cross->corner = comm.sum(st.migrations[2]);
    cross->periodic = comm.sum(st.migrations_periodic);
  }
}

TEST(DemMpi, GasCrossesEveryFaceAndEdgeLikeOneRank) {
  const Scene sc = gas();
  ASSERT_GT(sc.hp.size(), 200);
  Reference refs;
  for (const auto& dims : gas_cuts(world().size())) {
    Crossings c;
    run_against_reference(sc, dims, 10000, 500, &c, refs);
    if (any_failure()) return;
    if (!world().root()) continue;
    int split = 0;
    for (int d : dims) split += d > 1;
    // Each split axis gives face crossings; two split axes give edges, three
    // corners; a periodic axis cut in parts gives wraps through the box boundary.
    if (split >= 1) {
      EXPECT_GT(c.face, 100) << text(dims);
      EXPECT_GT(c.periodic, 20) << text(dims);
    }
    if (split >= 2) {
      EXPECT_GT(c.edge, 0) << text(dims);
    }
    if (split == 3) {
      EXPECT_GT(c.corner, 0) << text(dims);
    }
    std::printf("[ dem_mpi ] cut %s: %ld face, %ld edge, %ld corner crossings (%ld through a periodic face)\n",
                text(dims).c_str(), c.face, c.edge, c.corner, c.periodic);
  }
}

TEST(DemMpi, BedWithWallsGravityFrictionLikeOneRank) {
  const Scene sc = bed();
  ASSERT_GT(sc.hp.size(), 150);
  if (world().size() == 1) GTEST_SKIP() << "needs at least two ranks";
  Reference refs;
  run_against_reference(sc, bed_cut(world().size()), 2000, 500, nullptr, refs);
}

// A small cluster drifting through the box: most ranks own no particle for
// many steps, yet take part in every decision, and the result is unchanged.
TEST(DemMpi, RanksWithoutParticlesLikeOneRank) {
  Scene sc;
  DemParams& p = sc.p;
  p.lo = {0, 0, 0};
  p.hi = {1.6, 1.6, 1.6};
  p.periodic = {true, true, true};
  p.friction = true;
  p.material = material(1e5, 0.8, 0.3);
  sc.hp = lattice_particles({0.15, 0.15, 0.15}, {3, 3, 2}, {0.11, 0.11, 0.11}, 0.05, 2600);
  random_velocities(sc.hp, 0.8, 5.0, 21);
  // A common drift carries the cluster from piece to piece (and through the
  // periodic face): ranks that held particles are left with none.
  for (auto& v : sc.hp.v) v.x += 3.0;
  p.dt = min_collision_time(p, sc.hp) / 50;
  p.contact_order = ContactOrder::GlobalId;
  Reference refs;
  run_against_reference(sc, one_cut(world().size()), 4000, 500, nullptr, refs);
}

// The exact every-step rebuild test (the reference of the look-ahead) is
// global too: any rank's excess rebuilds all.
TEST(DemMpi, EveryStepRebuildCheckLikeOneRank) {
  Scene sc = gas();
  sc.p.rebuild_check = RebuildCheck::EveryStep;
  Reference refs;
  run_against_reference(sc, one_cut(world().size()), 2000, 1000, nullptr, refs);
}

// With the default storage order the sums run in an order that depends on
// the cut: the states then agree with one rank to rounding only.
TEST(DemMpi, StorageOrderAgreesToRounding) {
  const halo::Comm& comm = world();
  Scene sc = gas(0.35);  // dense: particles with several contacts at once
  sc.p.contact_order = ContactOrder::Storage;
  DemSystem many(Exec(Backend::Host), sc.p, sc.hp, decompose_box(comm, sc.p, sc.hp));
  many.advance(300);
  const HostParticles got = many.gather();
  if (comm.root()) {
    DemSystem one(Exec(Backend::Host), sc.p, sc.hp);
    one.advance(300);
    const HostParticles ref = one.gather();
    ASSERT_EQ(got.size(), ref.size());
    double fmax = 0, df = 0, dx = 0;
    for (std::size_t i = 0; i < ref.x.size(); ++i) {
      ASSERT_EQ(got.id[i], ref.id[i]);
      fmax = std::max(fmax, norm(ref.f[i]));
      df = std::max(df, norm(got.f[i] - ref.f[i]));
      dx = std::max(dx, norm(got.x[i] - ref.x[i]));
    }
    ASSERT_GT(fmax, 0);
    EXPECT_LE(df, 1e-12 * fmax);
    EXPECT_LE(dx, 1e-12 * (sc.p.hi[0] - sc.p.lo[0]));
    std::printf("[ dem_mpi ] storage order, %d ranks: largest force difference %.3g of the largest force\n",
                comm.size(), df / fmax);
  }
}

// A coupled scene cuts its particles where it cuts its lattice: cut positions
// at the pieces' first cells, owners by position (uneven split, clamping at
// closed faces).
TEST(DemMpi, CutsFollowTheLatticeDecomposition) {
  DemParams p;
  p.lo = {-1, 0, 2};
  p.hi = {9, 7, 7};
  p.periodic = {true, false, false};
  const Grid whole = Grid::whole({10, 7, 5}, {true, false, false});
  const halo::Decomposition dec = halo::decompose(whole, 6, {3, 2, 1});
  const DemDomain d = domain_from_decomposition(world(), dec, p);
  // 10 cells in 3 parts: 4, 3, 3 (offsets 0, 4, 7); 7 in 2: 4, 3 (offsets 0, 4).
  ASSERT_EQ(d.cuts[0].size(), 4u);
  EXPECT_EQ(d.cuts[0][0], -1.0);
  EXPECT_EQ(d.cuts[0][1], -1.0 + 10.0 * 4 / 10);
  EXPECT_EQ(d.cuts[0][2], -1.0 + 10.0 * 7 / 10);
  EXPECT_EQ(d.cuts[0][3], 9.0);
  ASSERT_EQ(d.cuts[1].size(), 3u);
  EXPECT_EQ(d.cuts[1][1], 7.0 * 4 / 7);
  ASSERT_EQ(d.cuts[2].size(), 2u);
  EXPECT_EQ(d.owner({-1.0, 0.0, 2.0}), dec.rank_at({0, 0, 0}));
  EXPECT_EQ(d.owner({3.0, 3.99, 4.0}), dec.rank_at({1, 0, 0}));
  EXPECT_EQ(d.owner({6.0, 4.0, 4.0}), dec.rank_at({2, 1, 0}));
  EXPECT_EQ(d.owner({8.5, -0.5, 9.0}), dec.rank_at({2, 0, 0}));  // beyond closed faces: the edge pieces
  Vec3d lo, hi;
  d.piece(dec.rank_at({1, 1, 0}), lo, hi);
  EXPECT_EQ(lo.x, 3.0);
  EXPECT_EQ(hi.x, 6.0);
  EXPECT_EQ(lo.y, 4.0);
  EXPECT_EQ(hi.y, 7.0);
}

TEST(DemMpi, RefusesPiecesThinnerThanTheGhostWidth) {
  const halo::Comm& comm = world();
  if (comm.size() < 2) GTEST_SKIP() << "needs at least two ranks";
  const Scene sc = gas();
  const double w = ghost_width(sc.p, sc.hp.r);
  DemDomain dom;
  dom.comm = &comm;
  dom.dec.dims = {comm.size(), 1, 1};
  dom.dec.periodic = sc.p.periodic;
  // Pieces along x: the first one half the ghost width thick.
  dom.cuts[0].push_back(sc.p.lo[0]);
  dom.cuts[0].push_back(sc.p.lo[0] + 0.5 * w);
  for (int i = 2; i < comm.size(); ++i)
    dom.cuts[0].push_back(sc.p.lo[0] + 0.5 * w + (sc.p.hi[0] - sc.p.lo[0] - 0.5 * w) * (i - 1) / (comm.size() - 1));
  dom.cuts[0].push_back(sc.p.hi[0]);
  for (std::size_t a = 1; a < 3; ++a) dom.cuts[a] = {sc.p.lo[a], sc.p.hi[a]};
  try {
    DemSystem sys(Exec(Backend::Host), sc.p, sc.hp, dom);
    ADD_FAILURE() << "a piece thinner than the ghost width was accepted";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("ghost width"), std::string::npos) << msg;
    EXPECT_NE(msg.find("piece 0"), std::string::npos) << msg;
  }
  // The pair path cannot run on several ranks either.
  DemParams pair = sc.p;
  pair.path = ForcePath::Pair;
  EXPECT_THROW(DemSystem(Exec(Backend::Host), pair, sc.hp, decompose_box(comm, sc.p, sc.hp)), ConfigError);
}

}  // namespace
}  // namespace lbdem::dem
