// DEM sub-steps as CUDA graphs (DemParams::substep_graphs, dem/README.md
// "Sub-step graphs") against the same run with every kernel launched on its
// own: the same particles bit for bit (positions, velocities, angular
// velocities, forces, torques, in storage order), over a run with list
// rebuilds (new buffers: the graphs are captured again) and a coupling input
// rewritten between advance() calls as a fluid step does. The CUDA instances
// run where a GPU is usable (skipped otherwise); on the host the flag changes
// nothing and no graph is made.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "common/backends.hpp"
#include "core/buffer.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"
#include "dem_test_util.hpp"

using namespace lbdem;
using namespace lbdem::dem;

namespace {

// A bed of Mueller's particles (d = 1.2 mm, k = 800 N/m, e = 0.97, mu 0.1
// or none) moving at random in a closed 12 x 6 x 30 mm box under gravity,
// with an upward coupling force of 0.4-0.6 times the weight that changes
// between calls: contacts, wall friction, rebuilds (one per ~70 sub-steps)
// and reports (one per ~3) at the rates of a bubbling bed's fast particles.
struct Bed : lbdem::dem::test::MovingBed {
  Bed(bool friction, bool graphs) : MovingBed(friction, 7, 12345) { p.substep_graphs = graphs; }
};

// Coupling input of call c: an upward force of (0.4 + 0.2 * (c % 2)) times
// each particle's weight, with a small sideways part by id.
void write_coupling(DemSystem& s, int c) {
  const ParticleView v = s.view();
  const HostParticles hp = s.download();
  std::vector<Real4> f(static_cast<std::size_t>(v.n));
  for (Index i = 0; i < v.n; ++i) {
    const double w = hp.mass[i] * 9.80665;
    f[i] = Real4{1e-3 * w * static_cast<double>(hp.id[i] % 3 - 1), 0, (0.4 + 0.2 * (c % 2)) * w, 0};
  }
  backend_copy_from_host(s.backend(), v.ext_force, f.data(), sizeof(Real4) * f.size());
}

void expect_same_bits(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  int differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(Vec3d)) != 0) ++differ;
  EXPECT_EQ(differ, 0) << what << ": particles whose bits differ";
}

struct BedRun {
  HostParticles end;
  DemStats stats;
};

// 24 calls of 101 sub-steps (a gas step of the Mueller bed each), the
// coupling input rewritten before each call.
BedRun run_bed(Backend b, bool friction, bool graphs) {
  const Bed bed(friction, graphs);
  DemSystem s(Exec(b), bed.p, bed.h);
  for (int c = 0; c < 24; ++c) {
    write_coupling(s, c);
    s.advance(101);
  }
  BedRun r;
  r.end = s.download();
  r.stats = s.stats();
  return r;
}

void compare(const BedRun& a, const BedRun& b) {
  ASSERT_EQ(a.end.id, b.end.id) << "storage order differs";
  expect_same_bits(a.end.x, b.end.x, "positions");
  expect_same_bits(a.end.v, b.end.v, "velocities");
  expect_same_bits(a.end.w, b.end.w, "angular velocities");
  expect_same_bits(a.end.f, b.end.f, "forces");
  expect_same_bits(a.end.t, b.end.t, "torques");
  EXPECT_EQ(a.stats.steps, b.stats.steps);
  EXPECT_EQ(a.stats.rebuilds, b.stats.rebuilds);
}

}  // namespace

class DemSubstepGraphs : public ::testing::TestWithParam<bool> {};

TEST_P(DemSubstepGraphs, CudaGraphsGiveTheSameParticlesBitwise) {
  if (!lbdem::test::gpu_available()) GTEST_SKIP() << cuda_unavailable_reason();
  const bool friction = GetParam();
  const BedRun with = run_bed(Backend::Cuda, friction, true);
  const BedRun without = run_bed(Backend::Cuda, friction, false);
  compare(with, without);
  // The graphs ran, over rebuilds (new buffers: captured again), and the
  // plain sub-steps inside them are most of the run.
  EXPECT_GT(with.stats.rebuilds, 5);
  EXPECT_GT(with.stats.graph_launches, 0);
  EXPECT_GT(with.stats.graph_captures, 1);
  EXPECT_LE(with.stats.graph_captures, with.stats.graph_launches);
  EXPECT_GT(with.stats.graph_steps, with.stats.steps / 4);
  EXPECT_EQ(without.stats.graph_launches, 0);
  std::printf("sub-steps %ld, rebuilds %ld, reports read %ld, graphs launched %ld holding %ld sub-steps, "
              "captured %ld\n",
              with.stats.steps, with.stats.rebuilds, with.stats.status_reads, with.stats.graph_launches,
              with.stats.graph_steps, with.stats.graph_captures);
}

// The host ignores the flag: no graph, the same bits either way.
TEST_P(DemSubstepGraphs, HostIgnoresTheFlag) {
  const bool friction = GetParam();
  const BedRun with = run_bed(Backend::Host, friction, true);
  const BedRun without = run_bed(Backend::Host, friction, false);
  compare(with, without);
  EXPECT_EQ(with.stats.graph_launches, 0);
  EXPECT_GT(with.stats.rebuilds, 5);
  std::printf("sub-steps %ld, rebuilds %ld, reports read %ld (the GPU takes the same decisions)\n", with.stats.steps,
              with.stats.rebuilds, with.stats.status_reads);
}

INSTANTIATE_TEST_SUITE_P(Friction, DemSubstepGraphs, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& i) {
                           return std::string(i.param ? "frictional" : "frictionless");
                         });
