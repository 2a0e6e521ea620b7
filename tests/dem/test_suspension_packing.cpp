// The suspension's set-up (dem/packing.hpp): the random disks of the first
// paper's 2D suspension (no overlaps, placed fast, refused when they cannot
// fit) and the random initial velocities (their speed, no net momentum,
// isotropic).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <vector>

#include "core/error.hpp"
#include "dem/packing.hpp"

namespace lbdem::test {
namespace {

// The full 2D suspension of the paper: 1,166,400 disks of d = 10 cells in
// 15360 x 61440 periodic cells, placed in well under 10 s, none overlapping.
TEST(SuspensionSetup, PaperTwoDimensionalPackingIsFastAndValid) {
  const long n = 1166400;
  const double r = 5;
  // CPU time of this (single-threaded) placement: a loaded machine does not fail it.
  const std::clock_t c0 = std::clock();
  const auto p = dem::random_disks({0, 0, 0}, {15360, 61440, 1}, {true, true, true}, n, r, 692.3, 1, "particles.count");
  EXPECT_TRUE(p.apart_by_construction);
  const double secs = double(std::clock() - c0) / CLOCKS_PER_SEC;
  EXPECT_LT(secs, 10.0);
  ASSERT_EQ(p.size(), n);
  // Overlaps through a cell list of 10-cell bins (periodic).
  const long bx = 1536, by = 6144;
  std::vector<std::vector<std::size_t>> bins(static_cast<std::size_t>(bx * by));
  for (std::size_t i = 0; i < p.x.size(); ++i) {
    ASSERT_GE(p.x[i][0], 0.0);
    ASSERT_LT(p.x[i][0], 15360.0);
    ASSERT_GE(p.x[i][1], 0.0);
    ASSERT_LT(p.x[i][1], 61440.0);
    ASSERT_EQ(p.x[i][2], 0.5);
    const long cx = static_cast<long>(p.x[i][0] / 10), cy = static_cast<long>(p.x[i][1] / 10);
    bins[static_cast<std::size_t>(cx + bx * cy)].push_back(i);
  }
  long overlaps = 0;
  double closest = 1e300;
  for (std::size_t i = 0; i < p.x.size(); ++i) {
    const long cx = static_cast<long>(p.x[i][0] / 10), cy = static_cast<long>(p.x[i][1] / 10);
    for (long dy = -1; dy <= 1; ++dy)
      for (long dx = -1; dx <= 1; ++dx)
        for (std::size_t j : bins[static_cast<std::size_t>((cx + dx + bx) % bx + bx * ((cy + dy + by) % by))]) {
          if (j <= i) continue;
          double ddx = p.x[i][0] - p.x[j][0], ddy = p.x[i][1] - p.x[j][1];
          ddx -= 15360 * std::round(ddx / 15360);
          ddy -= 61440 * std::round(ddy / 61440);
          const double dist = std::hypot(ddx, ddy);
          closest = std::min(closest, dist);
          if (dist < 2 * r) ++overlaps;
        }
  }
  EXPECT_EQ(overlaps, 0) << "closest pair " << closest;
  // Not a lattice: the pairs' distances vary (the closest is below the site spacing).
  EXPECT_LT(closest, 20.0);
}

TEST(SuspensionSetup, DisksThatCannotFitAreRefused) {
  EXPECT_THROW(dem::random_disks({0, 0, 0}, {100, 100, 1}, {true, true, true}, 200, 5, 1, 1, "particles.count"),
               ConfigError);
}

TEST(SuspensionSetup, RandomVelocitiesHaveTheSpeedAndNoNetMomentum) {
  for (int dim : {2, 3}) {
    dem::HostParticles p;
    for (int i = 0; i < 5000; ++i) p.add({double(i), 0, 0}, 1, 1);
    dem::add_random_velocities(p, dim, 5e-3, 7);
    Vec3d mean{0, 0, 0};
    double worst = 0, zmax = 0;
    for (const auto& v : p.v) {
      mean = mean + v;
      worst = std::max(worst, std::abs(std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) - 5e-3));
      zmax = std::max(zmax, std::abs(v[2]));
    }
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(mean[k], 0.0, 1e-15) << dim;
    // Removing the mean shifts each speed by about 5e-3 / sqrt(N).
    EXPECT_LT(worst, 5e-3 * 0.05) << dim;
    if (dim == 2) {
      EXPECT_EQ(zmax, 0.0);
    }
    // Isotropic: each direction holds about 1/dim of the energy.
    double ex = 0;
    for (const auto& v : p.v) ex += v[0] * v[0];
    EXPECT_NEAR(ex / (5000 * 25e-6), 1.0 / dim, 0.05) << dim;
  }
}

}  // namespace
}  // namespace lbdem::test
