// Particle → cell slots: Σε over the grid, overflow reports, periodic images,
// and CPU against GPU. Parametrised over the backends present (host always).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "common/backends.hpp"
#include "core/buffer.hpp"
#include "core/error.hpp"
#include "imb/cell_slots.hpp"

using namespace lbdem;
using namespace lbdem::imb;

namespace {

// Particles held on a backend, viewed through SphereView.
struct Particles {
  Buffer<double> x, y, z, r;
  Index n = 0;
  Particles(Backend b, const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<double>& zs,
            const std::vector<double>& rs)
      : x(b, static_cast<Index>(xs.size())), y(b, static_cast<Index>(xs.size())), z(b, static_cast<Index>(xs.size())),
        r(b, static_cast<Index>(xs.size())), n(static_cast<Index>(xs.size())) {
    x.copy_from_host(xs);
    y.copy_from_host(ys);
    z.copy_from_host(zs);
    r.copy_from_host(rs);
  }
  SphereView view() const { return {x.data(), y.data(), z.data(), r.data(), n}; }
};

double sum(const std::vector<double>& v) {
  double s = 0.0;
  for (double e : v) s += e;
  return s;
}

const FractionTable& table3() {
  static const FractionTable t = build_fraction_table(3);
  return t;
}
const FractionTable& table2() {
  static const FractionTable t = build_fraction_table(2);
  return t;
}

}  // namespace

class CellSlotsTest : public ::testing::TestWithParam<Backend> {
 protected:
  Exec ex{GetParam()};
};

TEST_P(CellSlotsTest, SumOfFractionsEqualsParticleVolume3D) {
  Grid g = Grid::whole({48, 40, 44}, {true, true, true});
  std::vector<double> xs{10.3, 30.71, 20.2}, ys{9.9, 25.13, 30.5}, zs{11.4, 30.02, 12.0}, rs{5.0, 7.3, 3.0};
  Particles p(GetParam(), xs, ys, zs, rs);
  double V = 0.0;
  for (double r : rs) V += 4.0 / 3.0 * M_PI * r * r * r;
  const FractionMethod methods[3] = {FractionMethod::Exact, FractionMethod::Table, FractionMethod::Linear};
  const double tol[3] = {1e-10, 5e-4, 0.1 / 9.0};
  for (int m = 0; m < 3; ++m) {
    CellSlots s(GetParam(), g, 2);
    MapOptions o;
    o.method = methods[m];
    o.table = &table3();
    s.map(ex, p.view(), o);
    const auto rep = s.overflow();
    EXPECT_FALSE(rep.overflow) << rep.message;
    EXPECT_NEAR(sum(s.total_eps_host()) / V, 1.0, tol[m]) << to_string(methods[m]);
  }
}

TEST_P(CellSlotsTest, SumOfFractionsEqualsParticleArea2D) {
  Grid g = Grid::whole({64, 50, 1}, {true, false, true});
  std::vector<double> xs{10.3, 40.71}, ys{12.9, 25.13}, zs{0, 0}, rs{8.0, 12.6};
  Particles p(GetParam(), xs, ys, zs, rs);
  const double A = M_PI * (64.0 + 12.6 * 12.6);
  const FractionMethod methods[3] = {FractionMethod::Exact, FractionMethod::Table, FractionMethod::Linear};
  const double tol[3] = {1e-12, 1.5e-4, 0.2 / 64.0};
  for (int m = 0; m < 3; ++m) {
    CellSlots s(GetParam(), g, 1);
    MapOptions o;
    o.method = methods[m];
    o.table = &table2();
    o.max_radius = 12.6;
    s.map(ex, p.view(), o);
    EXPECT_FALSE(s.overflow().overflow);
    EXPECT_NEAR(sum(s.total_eps_host()) / A, 1.0, tol[m]) << to_string(methods[m]);
  }
}

// The exact method's deferred (two-pass) fill gives the same slots as the direct one.
TEST_P(CellSlotsTest, DeferredExactMatchesDirect) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  Grid g = Grid::whole({40, 40, 40}, {true, true, true});
  std::vector<double> xs, ys, zs, rs;
  for (int i = 0; i < 30; ++i) {
    xs.push_back(40 * U(rng));
    ys.push_back(40 * U(rng));
    zs.push_back(40 * U(rng));
    rs.push_back(2.0 + 4.0 * U(rng));
  }
  Particles p(GetParam(), xs, ys, zs, rs);
  CellSlots a(GetParam(), g, 8), b(GetParam(), g, 8);
  MapOptions o;
  o.defer_exact = true;
  a.map(ex, p.view(), o);
  o.defer_exact = false;
  b.map(ex, p.view(), o);
  ASSERT_FALSE(a.overflow().overflow);
  const auto ca = a.counts_host();
  EXPECT_EQ(ca, b.counts_host());
  const auto pa = a.particles_host(), pb = b.particles_host();
  const auto ea = a.eps_host(), eb = b.eps_host();
  const Index n = g.cells();
  for (Index c = 0; c < n; ++c)  // slots beyond the count hold stale values: compare used ones
    for (int k = 0; k < std::min(ca[c], 8); ++k) {
      ASSERT_EQ(pa[k * n + c], pb[k * n + c]);
      ASSERT_EQ(ea[k * n + c], eb[k * n + c]);
    }
}

TEST_P(CellSlotsTest, ReportsOverflowWithCellAndParticles) {
  // Three small balls inside cell (5, 6, 7) only, K = 2; a fourth elsewhere.
  Grid g = Grid::whole({16, 16, 16}, {true, true, true});
  std::vector<double> xs{5.45, 5.55, 5.5, 12.0}, ys{6.5, 6.45, 6.55, 12.0}, zs{7.5, 7.5, 7.45, 12.0},
      rs{0.4, 0.4, 0.4, 2.0};
  Particles p(GetParam(), xs, ys, zs, rs);
  CellSlots s(GetParam(), g, 2);
  MapOptions o;
  s.map(ex, p.view(), o);
  const auto rep = s.overflow();
  ASSERT_TRUE(rep.overflow);
  EXPECT_FALSE(rep.radius_too_large);
  EXPECT_EQ(rep.events, 1);
  EXPECT_EQ(rep.ijk, (std::array<Index, 3>{5, 6, 7}));
  EXPECT_EQ(rep.cell, 5 + 16 * (6 + 16 * 7));
  EXPECT_EQ(rep.count, 3);
  EXPECT_EQ(rep.particles, (std::vector<int>{0, 1, 2}));
  EXPECT_NE(rep.message.find("(5, 6, 7)"), std::string::npos) << rep.message;
  EXPECT_NE(rep.message.find("K = 2"), std::string::npos) << rep.message;
  EXPECT_THROW(s.throw_if_overflow(), ResourceError);
  // K = 3 holds them: no overflow, and the slots are sorted by particle index.
  CellSlots s3(GetParam(), g, 3);
  s3.map(ex, p.view(), o);
  EXPECT_FALSE(s3.overflow().overflow);
  const auto parts = s3.particles_host();
  const Index c = rep.cell, n = g.cells();
  EXPECT_EQ(parts[c], 0);
  EXPECT_EQ(parts[n + c], 1);
  EXPECT_EQ(parts[2 * n + c], 2);
}

TEST_P(CellSlotsTest, ReportsRadiusAboveMaxRadius) {
  Grid g = Grid::whole({32, 32, 32}, {true, true, true});
  Particles p(GetParam(), {10.0, 20.0}, {10.0, 20.0}, {10.0, 20.0}, {3.0, 6.0});
  CellSlots s(GetParam(), g, 2);
  MapOptions o;
  o.max_radius = 3.0;
  s.map(ex, p.view(), o);
  const auto rep = s.overflow();
  EXPECT_TRUE(rep.radius_too_large);
  EXPECT_EQ(rep.bad_particle, 1);
  EXPECT_THROW(s.throw_if_overflow(), ResourceError);
}

TEST_P(CellSlotsTest, PeriodicWrapGivesSameFractions) {
  // The same ball inside the box and straddling every periodic face (corner):
  // the solid-fraction fields are equal up to the integer shift.
  const Index n = 24;
  Grid g = Grid::whole({n, n, n}, {true, true, true});
  const double R = 5.3, fx = 0.37, fy = 0.81, fz = 0.12;
  Particles inside(GetParam(), {12 + fx}, {12 + fy}, {12 + fz}, {R});
  Particles corner(GetParam(), {0 + fx}, {n - 1 + fy}, {-2 + fz}, {R});  // shifts (−12, +11, −14)
  for (FractionMethod m : {FractionMethod::Exact, FractionMethod::Table, FractionMethod::Linear}) {
    MapOptions o;
    o.method = m;
    o.table = &table3();
    CellSlots a(GetParam(), g, 1), b(GetParam(), g, 1);
    a.map(ex, inside.view(), o);
    b.map(ex, corner.view(), o);
    const auto ea = a.total_eps_host(), eb = b.total_eps_host();
    EXPECT_NEAR(sum(ea), sum(eb), 1e-11);
    if (m == FractionMethod::Exact) {
      EXPECT_NEAR(sum(eb) / (4.0 / 3.0 * M_PI * R * R * R), 1.0, 1e-10);
    }
    double worst = 0.0;
    for (Index k = 0; k < n; ++k)
      for (Index j = 0; j < n; ++j)
        for (Index i = 0; i < n; ++i) {
          const Index i2 = (i - 12 + n) % n, j2 = (j + 11) % n, k2 = (k - 14 + n) % n;
          worst = std::max(worst, std::fabs(ea[i + n * (j + n * k)] - eb[i2 + n * (j2 + n * k2)]));
        }
    EXPECT_LT(worst, 1e-12) << to_string(m);
  }
}

TEST_P(CellSlotsTest, NonPeriodicAxisClips) {
  Grid g = Grid::whole({20, 20, 20}, {true, true, false});
  Particles p(GetParam(), {10.0}, {10.0}, {0.0}, {4.0});  // half below z = 0
  CellSlots s(GetParam(), g, 1);
  s.map(ex, p.view(), MapOptions{});
  EXPECT_NEAR(sum(s.total_eps_host()), 0.5 * 4.0 / 3.0 * M_PI * 64.0, 1e-9);
}

TEST_P(CellSlotsTest, RefusesParticleLargerThanPeriodicBox) {
  Grid g = Grid::whole({8, 8, 8}, {true, true, true});
  Particles p(GetParam(), {4.0}, {4.0}, {4.0}, {4.0});
  CellSlots s(GetParam(), g, 1);
  EXPECT_THROW(s.map(ex, p.view(), MapOptions{}), ConfigError);
}

INSTANTIATE_TEST_SUITE_P(Backends, CellSlotsTest, ::testing::ValuesIn(lbdem::test::backends()),
                         lbdem::test::backend_name);

// CPU against GPU: the same particles give the same slots and fractions.
TEST(CellSlotsCrossBackend, HostMatchesCuda) {
  if (!lbdem::test::gpu_available()) GTEST_SKIP() << "no usable GPU: " << cuda_unavailable_reason();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const Index n = 64;
  Grid g = Grid::whole({n, n, n}, {true, true, true});
  std::vector<double> xs, ys, zs, rs;
  for (int i = 0; i < 60; ++i) {
    xs.push_back(n * U(rng));
    ys.push_back(n * U(rng));
    zs.push_back(n * U(rng));
    rs.push_back(3.0 + 3.0 * U(rng));
  }
  for (int mi = 0; mi < 4; ++mi) {
    const FractionMethod m = mi == 3 ? FractionMethod::Table : static_cast<FractionMethod>(mi);
    MapOptions o;
    o.method = m;
    o.table = &table3();
    o.table_in_constant = mi != 3;  // mi == 3: the global-memory table path
    CellSlots h(Backend::Host, g, 8), d(Backend::Cuda, g, 8);
    Particles ph(Backend::Host, xs, ys, zs, rs), pd(Backend::Cuda, xs, ys, zs, rs);
    h.map(Exec(Backend::Host), ph.view(), o);
    d.map(Exec(Backend::Cuda), pd.view(), o);
    ASSERT_FALSE(h.overflow().overflow);
    ASSERT_FALSE(d.overflow().overflow);
    EXPECT_EQ(h.counts_host(), d.counts_host());
    const auto ch = h.counts_host();
    const auto ph_ = h.particles_host(), pd_ = d.particles_host();
    const auto eh = h.eps_host(), ed = d.eps_host();
    double worst = 0.0;
    for (Index c = 0; c < g.cells(); ++c)
      for (int k = 0; k < std::min(ch[c], 8); ++k) {
        ASSERT_EQ(ph_[k * g.cells() + c], pd_[k * g.cells() + c]);
        worst = std::max(worst, std::fabs(eh[k * g.cells() + c] - ed[k * g.cells() + c]));
      }
    EXPECT_LT(worst, 1e-12) << to_string(m);
  }
}
