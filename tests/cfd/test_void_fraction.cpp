// Void fraction from particles (cfd/void_fraction.hpp): solid volume is
// conserved exactly (in fixed-point quanta; to round-off in metres^3), the
// centroid scheme equals a brute-force count, the sums do not depend on the
// particle order (bitwise), walls reflect and periodic axes wrap, and
// interpolation with the same weights reproduces constant and linear fields.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "cfd/void_fraction.hpp"
#include "common/backends.hpp"

using namespace lbdem;
using namespace lbdem::cfd;

namespace {
constexpr double kPi = 3.14159265358979323846;

GasGridView box_grid() {
  GasGridView g;
  g.n[0] = 6; g.n[1] = 5; g.n[2] = 7;
  g.origin[0] = -0.01; g.origin[1] = 0.02; g.origin[2] = 0.0;
  g.h = 0.004;
  g.periodic[0] = false; g.periodic[1] = true; g.periodic[2] = false;
  return g;
}

std::vector<dem::Real4> random_particles(const GasGridView& g, int n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<dem::Real4> p(static_cast<std::size_t>(n));
  for (auto& q : p) {
    const double r = 0.0004 + 0.0006 * u(rng);
    // Centres anywhere a particle can sit: at least r from a wall, anywhere
    // along the periodic axis (also just outside it: wrapped).
    q.x = g.origin[0] + r + (g.n[0] * g.h - 2 * r) * u(rng);
    q.y = g.origin[1] + (g.n[1] * g.h) * (1.2 * u(rng) - 0.1);
    q.z = g.origin[2] + r + (g.n[2] * g.h - 2 * r) * u(rng);
    q.w = r;
  }
  return p;
}

struct Deposited {
  std::vector<unsigned long long> fixed;
  std::vector<double> solid;
};

Deposited deposit(Backend b, const GasGridView& g, Deposition s, const std::vector<dem::Real4>& host) {
  Buffer<dem::Real4> pos(b, static_cast<Index>(host.size()));
  pos.copy_from_host(host);
  dem::ParticleView v;
  v.pos_r = pos.data();
  v.n = pos.size();
  VoidFraction vf(Exec(b), g, s);
  vf.deposit(v);
  Exec(b).synchronize();
  return {vf.fixed().to_vector(), vf.solid().to_vector()};
}
}  // namespace

class VoidFractionTest : public ::testing::TestWithParam<Backend> {};

TEST_P(VoidFractionTest, ConservesSolidVolumeExactly) {
  const GasGridView g = box_grid();
  const auto p = random_particles(g, 2000, 7);
  long long want = 0;
  double vol = 0;
  for (const auto& q : p) {
    const double vp = 4.0 / 3.0 * kPi * q.w * q.w * q.w;
    want += std::llrint(vp * kFixedScale / g.volume());
    vol += vp;
  }
  for (Deposition s : {Deposition::Centroid, Deposition::Linear, Deposition::Quadratic}) {
    const Deposited d = deposit(GetParam(), g, s, p);
    long long got = 0;
    double got_vol = 0;
    for (Index c = 0; c < g.cells(); ++c) {
      got += static_cast<long long>(d.fixed[static_cast<std::size_t>(c)]);
      got_vol += d.solid[static_cast<std::size_t>(c)] * g.volume();
      EXPECT_GE(d.solid[static_cast<std::size_t>(c)], 0.0);
    }
    EXPECT_EQ(got, want) << to_string(s);
    // Quantisation 2^-40 per particle of V_c: 2000 * 1e-12 relative at most.
    EXPECT_NEAR(got_vol, vol, 1e-11 * vol) << to_string(s);
  }
}

TEST_P(VoidFractionTest, CentroidEqualsBruteForceCount) {
  const GasGridView g = box_grid();
  const auto p = random_particles(g, 1500, 11);
  std::vector<long long> want(static_cast<std::size_t>(g.cells()), 0);
  for (const auto& q : p) {
    int ijk[3];
    const double x[3] = {q.x, q.y, q.z};
    for (int a = 0; a < 3; ++a) {
      int i = static_cast<int>(std::floor((x[a] - g.origin[a]) / g.h));
      if (g.periodic[a]) i = ((i % g.n[a]) + g.n[a]) % g.n[a];
      ijk[a] = i;
    }
    want[static_cast<std::size_t>(g.index(ijk[0], ijk[1], ijk[2]))] +=
        std::llrint(4.0 / 3.0 * kPi * q.w * q.w * q.w * kFixedScale / g.volume());
  }
  const Deposited d = deposit(GetParam(), g, Deposition::Centroid, p);
  for (Index c = 0; c < g.cells(); ++c)
    EXPECT_EQ(static_cast<long long>(d.fixed[static_cast<std::size_t>(c)]), want[static_cast<std::size_t>(c)]) << c;
}

TEST_P(VoidFractionTest, IndependentOfParticleOrder) {
  const GasGridView g = box_grid();
  auto p = random_particles(g, 3000, 3);
  for (Deposition s : {Deposition::Centroid, Deposition::Linear, Deposition::Quadratic}) {
    const Deposited a = deposit(GetParam(), g, s, p);
    std::mt19937 rng(5);
    std::shuffle(p.begin(), p.end(), rng);
    const Deposited b = deposit(GetParam(), g, s, p);
    EXPECT_EQ(a.fixed, b.fixed) << to_string(s);
    EXPECT_EQ(a.solid, b.solid) << to_string(s);
  }
}

TEST_P(VoidFractionTest, WallsReflectPeriodicWraps) {
  const GasGridView g = box_grid();
  const double h = g.h;
  // A particle 0.2 h from the x = origin wall, 0.1 h above the periodic
  // y face, at the centre of z cell 3.
  dem::Real4 q{g.origin[0] + 0.2 * h, g.origin[1] + 0.1 * h, g.origin[2] + 3.5 * h, 0.1 * h};
  const double phi = 4.0 / 3.0 * kPi * 1e-3;  // (0.1 h)^3 over h^3
  const double tol = 1e-11;
  {
    // Linear: along x both weights (0.3 mirrored, 0.7) land in cell 0; along
    // y 0.4 goes to the last cell (wrapped) and 0.6 to cell 0; z all in 3.
    const Deposited d = deposit(GetParam(), g, Deposition::Linear, {q});
    EXPECT_NEAR(d.solid[g.index(0, 0, 3)], 0.6 * phi, tol);
    EXPECT_NEAR(d.solid[g.index(0, g.n[1] - 1, 3)], 0.4 * phi, tol);
    double rest = 0;
    for (double v : d.solid) rest += v;
    EXPECT_NEAR(rest, phi, tol);
  }
  {
    // Quadratic: x: f = -0.3 about centre 0, weights 0.32 (cell -1 -> 0),
    // 0.66 (cell 0), 0.02 (cell 1); z: 0.125, 0.75, 0.125.
    const Deposited d = deposit(GetParam(), g, Deposition::Quadratic, {q});
    double x0 = 0, x1 = 0;
    for (int j = 0; j < g.n[1]; ++j)
      for (int k = 0; k < g.n[2]; ++k) {
        x0 += d.solid[g.index(0, j, k)];
        x1 += d.solid[g.index(1, j, k)];
      }
    EXPECT_NEAR(x0, 0.98 * phi, tol);
    EXPECT_NEAR(x1, 0.02 * phi, tol);
    double z3 = 0;
    for (int i = 0; i < g.n[0]; ++i)
      for (int j = 0; j < g.n[1]; ++j) z3 += d.solid[g.index(i, j, 3)];
    EXPECT_NEAR(z3, 0.75 * phi, tol);
  }
}

TEST(VoidFractionInterp, ReproducesConstantAndLinearFields) {
  const GasGridView g = box_grid();
  std::vector<double> one(static_cast<std::size_t>(g.cells()), 2.5), lin(static_cast<std::size_t>(g.cells()));
  for (int k = 0; k < g.n[2]; ++k)
    for (int j = 0; j < g.n[1]; ++j)
      for (int i = 0; i < g.n[0]; ++i)
        lin[static_cast<std::size_t>(g.index(i, j, k))] = 1.0 + 3.0 * (i + 0.5) - 2.0 * (k + 0.5);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  for (Deposition s : {Deposition::Centroid, Deposition::Linear, Deposition::Quadratic}) {
    for (int t = 0; t < 200; ++t) {
      const Vec3d x{g.origin[0] + g.n[0] * g.h * u(rng), g.origin[1] + g.n[1] * g.h * u(rng),
                    g.origin[2] + g.n[2] * g.h * u(rng)};
      EXPECT_NEAR(interpolate(g, s, one.data(), x), 2.5, 1e-14);
    }
    if (s == Deposition::Centroid) continue;
    // Linear reproduction away from the walls (x, z at least 1.5 cells in).
    for (int t = 0; t < 200; ++t) {
      const double xi = 1.5 + (g.n[0] - 3) * u(rng), zi = 1.5 + (g.n[2] - 3) * u(rng);
      const Vec3d x{g.origin[0] + xi * g.h, g.origin[1] + g.n[1] * g.h * u(rng), g.origin[2] + zi * g.h};
      EXPECT_NEAR(interpolate(g, s, lin.data(), x), 1.0 + 3.0 * xi - 2.0 * zi, 1e-12) << to_string(s);
    }
  }
  EXPECT_THROW(parse_deposition("gas.void_fraction", "gaussian"), ConfigError);
  EXPECT_EQ(parse_deposition("gas.void_fraction", "quadratic"), Deposition::Quadratic);
}

INSTANTIATE_TEST_SUITE_P(All, VoidFractionTest, ::testing::ValuesIn(lbdem::test::backends()),
                         lbdem::test::backend_name);
