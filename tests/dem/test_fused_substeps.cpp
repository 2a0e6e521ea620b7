// Fused DEM sub-steps (dem/README.md, "Fused sub-steps": each sub-step's
// forces and the next sub-step's kick-drift in one kernel, the positions and
// predicted velocities into the store's twin arrays) against two kernels per
// sub-step (LBDEM_DEM_FUSED_SUBSTEPS=0): the same state bit for bit. The
// state compared is the whole checkpoint section of the system (every
// particle array in storage order, the forces of the last two steps, the
// predicted velocities, the positions at the last build, the wall and
// contact histories, the Verlet list, the report ring on the device and its
// host copies, the decisions read from it) and the counters (sub-steps,
// rebuilds, reports read), over runs of coupled-step-long advance() calls
// with many list rebuilds, with and without friction. The host instances
// run everywhere; the CUDA instances (every lane count of the force kernel,
// with and without sub-step graphs) where a GPU is usable. The device kernels
// round every operation as written (no contraction into fused multiply-adds,
// dem/CMakeLists.txt), so there too the fused and separate kernels must agree
// bit for bit, with friction as without.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "common/backends.hpp"
#include "core/buffer.hpp"
#include "core/checkpoint.hpp"
#include "core/error.hpp"
#include "dem/init.hpp"
#include "dem/system.hpp"
#include "dem_test_util.hpp"

using namespace lbdem;
using namespace lbdem::dem;

namespace {

// The checkpoint bytes of a system, in memory.
struct Bytes final : ckpt::Sink {
  std::vector<unsigned char> b;
  void write(const void* data, std::size_t bytes) override {
    const auto* p = static_cast<const unsigned char*>(data);
    b.insert(b.end(), p, p + bytes);
  }
};

// Sets LBDEM_DEM_FUSED_SUBSTEPS for the scope (read when a DemSystem is
// constructed), restoring what was there.
class FusedEnv {
 public:
  explicit FusedEnv(const char* value) {
    const char* old = std::getenv(kName);
    had_ = old != nullptr;
    if (had_) old_ = old;
    if (value) setenv(kName, value, 1);
    else unsetenv(kName);
  }
  ~FusedEnv() {
    if (had_) setenv(kName, old_.c_str(), 1);
    else unsetenv(kName);
  }
  FusedEnv(const FusedEnv&) = delete;
  FusedEnv& operator=(const FusedEnv&) = delete;

 private:
  static constexpr const char* kName = "LBDEM_DEM_FUSED_SUBSTEPS";
  bool had_ = false;
  std::string old_;
};

// Mueller's particles (d = 1.2 mm, k = 800 N/m, e = 0.97, mu 0.1 or none) at
// random speeds up to 0.3 m/s per axis in a closed 12 x 6 x 30 mm box (each
// side `scale` times that) under gravity, with an upward coupling force that
// changes between calls: wall and particle contacts, a rebuild every ~70
// sub-steps, reports every few. ~560 particles (the host runs them on one
// thread); scale 2: ~4,500 (on the host's threads).
struct Bed : lbdem::dem::test::MovingBed {
  explicit Bed(bool friction, double scale = 1) : MovingBed(friction, 11, 987654321, scale, friction) {}
};

// Coupling input of call c: an upward force of (0.4 + 0.2 (c % 2)) times each
// particle's weight, a small sideways part by id, and a torque with friction.
void write_coupling(DemSystem& s, int c) {
  const ParticleView v = s.view();
  const HostParticles hp = s.download();
  std::vector<Real4> f(static_cast<std::size_t>(v.n)), t(f.size());
  for (Index i = 0; i < v.n; ++i) {
    const double w = hp.mass[i] * 9.80665;
    f[i] = Real4{1e-3 * w * static_cast<double>(hp.id[i] % 3 - 1), 0, (0.4 + 0.2 * (c % 2)) * w, 0};
    t[i] = Real4{0, 1e-9 * static_cast<double>(hp.id[i] % 5 - 2), 0, 0};
  }
  backend_copy_from_host(s.backend(), v.ext_force, f.data(), sizeof(Real4) * f.size());
  backend_copy_from_host(s.backend(), v.ext_torque, t.data(), sizeof(Real4) * t.size());
}

struct BedRun {
  std::vector<unsigned char> state;  // the checkpoint section at the end
  DemStats stats;
  std::vector<DemStats> per_call;
};

// `calls` advance() calls of `steps` sub-steps (101: a gas step of Mueller's
// bed), the coupling input rewritten before each. `fused`: the value of
// LBDEM_DEM_FUSED_SUBSTEPS (null: unset, the default: fused).
BedRun run(Backend b, const Bed& bed, DemParams p, const char* fused, int calls, long steps) {
  const FusedEnv env(fused);
  DemSystem s(Exec(b), p, bed.h);
  BedRun r;
  for (int c = 0; c < calls; ++c) {
    write_coupling(s, c);
    s.advance(steps);
    r.per_call.push_back(s.stats());
  }
  Bytes out;
  s.save_state(out);
  r.state = std::move(out.b);
  r.stats = s.stats();
  return r;
}

// Bit-for-bit comparison of two runs, naming the first differing byte.
void expect_same(const BedRun& a, const BedRun& b, const std::string& what) {
  ASSERT_EQ(a.state.size(), b.state.size()) << what;
  std::size_t first = a.state.size();
  for (std::size_t k = 0; k < a.state.size(); ++k)
    if (a.state[k] != b.state[k]) {
      first = k;
      break;
    }
  EXPECT_EQ(first, a.state.size()) << what << ": the checkpoint sections differ from byte " << first << " of "
                                   << a.state.size();
  EXPECT_EQ(a.stats.steps, b.stats.steps) << what;
  EXPECT_EQ(a.stats.rebuilds, b.stats.rebuilds) << what;
  EXPECT_EQ(a.stats.status_reads, b.stats.status_reads) << what;
  ASSERT_EQ(a.per_call.size(), b.per_call.size());
  for (std::size_t c = 0; c < a.per_call.size(); ++c) {
    EXPECT_EQ(a.per_call[c].rebuilds, b.per_call[c].rebuilds) << what << ", call " << c;
    EXPECT_EQ(a.per_call[c].status_reads, b.per_call[c].status_reads) << what << ", call " << c;
  }
}

std::string param_name(const ::testing::TestParamInfo<std::tuple<Backend, bool>>& i) {
  return std::string(to_string(std::get<0>(i.param))) + (std::get<1>(i.param) ? "_frictional" : "_frictionless");
}

}  // namespace

class DemFusedSubsteps : public ::testing::TestWithParam<std::tuple<Backend, bool>> {};

// Fused (LBDEM_DEM_FUSED_SUBSTEPS=1) against two kernels
// per sub-step, with look-ahead and every-step rebuild decisions; on the
// device with 1, 2, 4, 8 and 16 lanes per particle and with and without
// sub-step graphs (the reference: every kernel launched on its own).
TEST_P(DemFusedSubsteps, SameStateBitwiseAsTwoKernelsPerSubstep) {
  const auto [backend, friction] = GetParam();
  if (backend == Backend::Cuda && !lbdem::test::gpu_available()) GTEST_SKIP() << cuda_unavailable_reason();
  const Bed bed(friction);
  const int calls = 8;
  const long steps = 101;
  for (RebuildCheck check : {RebuildCheck::Lookahead, RebuildCheck::EveryStep}) {
    const std::vector<int> lanes = backend == Backend::Cuda ? std::vector<int>{1, 2, 4, 8, 16} : std::vector<int>{1};
    for (int l : lanes) {
      DemParams p = bed.p;
      p.rebuild_check = check;
      p.force_lanes = l;
      p.substep_graphs = false;
      const std::string what = std::string(to_string(check)) + ", lanes " + std::to_string(l);
      const BedRun ref = run(backend, bed, p, "0", calls, steps);
      // Lists rebuilt several times, reports read: the decisions are exercised.
      EXPECT_GE(ref.stats.rebuilds, 4) << what;
      EXPECT_GE(ref.stats.status_reads, calls) << what;
      EXPECT_EQ(ref.stats.fused_steps, 0) << what;
      const BedRun fused = run(backend, bed, p, "1", calls, steps);
      expect_same(fused, ref, what + ", fused");
      // Every sub-step but the first of each call runs fused.
      EXPECT_EQ(fused.stats.fused_steps, calls * (steps - 1)) << what;
      // Unset: the default, fused.
      const BedRun unset = run(backend, bed, p, nullptr, calls, steps);
      expect_same(unset, ref, what + ", the default");
      EXPECT_EQ(unset.stats.fused_steps, calls * (steps - 1)) << what;
      std::printf("%s: %ld sub-steps (%ld fused), %ld rebuilds, %ld reports read\n", what.c_str(),
                  fused.stats.steps, fused.stats.fused_steps, fused.stats.rebuilds, fused.stats.status_reads);
      if (backend == Backend::Cuda && check == RebuildCheck::Lookahead) {
        p.substep_graphs = true;
        const BedRun graphs = run(backend, bed, p, "1", calls, steps);
        expect_same(graphs, ref, what + ", fused in sub-step graphs");
        EXPECT_GT(graphs.stats.graph_steps, graphs.stats.steps / 4) << what;
        std::printf("%s, graphs: %ld launched holding %ld sub-steps, %ld captured\n", what.c_str(),
                    graphs.stats.graph_launches, graphs.stats.graph_steps, graphs.stats.graph_captures);
        const BedRun graphs2 = run(backend, bed, p, "0", calls, steps);
        expect_same(graphs2, ref, what + ", two kernels per sub-step in sub-step graphs");
      }
    }
  }
}

// advance() calls of one and two sub-steps (a first step alone; a fused step
// that is also the call's last, report and closing kick after it), and a
// call that ends on a rebuild, against two kernels per sub-step.
TEST_P(DemFusedSubsteps, ShortCallsSameStateBitwise) {
  const auto [backend, friction] = GetParam();
  if (backend == Backend::Cuda && !lbdem::test::gpu_available()) GTEST_SKIP() << cuda_unavailable_reason();
  const Bed bed(friction);
  for (long steps : {1L, 2L, 3L, 17L}) {
    const int calls = static_cast<int>(300 / steps) + 1;
    const std::string what = std::to_string(calls) + " calls of " + std::to_string(steps);
    const BedRun ref = run(backend, bed, bed.p, "0", calls, steps);
    const BedRun fused = run(backend, bed, bed.p, "1", calls, steps);
    expect_same(fused, ref, what);
    EXPECT_EQ(fused.stats.fused_steps, calls * (steps - 1)) << what;
    EXPECT_GE(ref.stats.rebuilds, 2) << what;
  }
}

// A bed of more than 4,096 particles, which the host backend runs on all its
// threads (smaller ones run serially): the fused kernel's reads of other
// particles' positions and predictors race with no write.
TEST_P(DemFusedSubsteps, LargeBedSameStateBitwise) {
  const auto [backend, friction] = GetParam();
  if (backend == Backend::Cuda && !lbdem::test::gpu_available()) GTEST_SKIP() << cuda_unavailable_reason();
  const Bed bed(friction, 2);
  ASSERT_GT(bed.h.size(), 4096);
  const BedRun ref = run(backend, bed, bed.p, "0", 2, 101);
  const BedRun fused = run(backend, bed, bed.p, "1", 2, 101);
  expect_same(fused, ref, "large bed");
  EXPECT_EQ(fused.stats.fused_steps, 2 * 100);
  EXPECT_GE(ref.stats.rebuilds, 1);
}

namespace {

// The state after one advance() call of k sub-steps (sub-steps 2..k fused
// with LBDEM_DEM_FUSED_SUBSTEPS=1), its particles and its checkpoint bytes.
struct CallState {
  std::vector<unsigned char> bytes;
  HostParticles h;
  DemStats stats;
};
CallState one_call(Backend b, const Bed& bed, const DemParams& p, const char* fused, long k) {
  const FusedEnv env(fused);
  DemSystem s(Exec(b), p, bed.h);
  write_coupling(s, 0);
  s.advance(k);
  CallState c;
  Bytes out;
  s.save_state(out);
  c.bytes = std::move(out.b);
  c.h = s.download();
  c.stats = s.stats();
  return c;
}

// Largest differences of a's particles from b's (matched by id): position
// over the diameter, velocity over b's largest speed, angular velocity over
// b's largest.
struct Diff {
  double x = 0, v = 0, w = 0;
  double max() const { return std::max(x, std::max(v, w)); }
};
Diff largest_difference(const HostParticles& a, const HostParticles& b) {
  std::map<std::int64_t, std::size_t> at;
  for (std::size_t k = 0; k < b.id.size(); ++k) at[b.id[k]] = k;
  double vmax = 0, wmax = 0;
  for (std::size_t k = 0; k < b.id.size(); ++k) {
    vmax = std::max(vmax, norm(b.v[k]));
    wmax = std::max(wmax, norm(b.w[k]));
  }
  Diff d;
  for (std::size_t k = 0; k < a.id.size(); ++k) {
    const std::size_t j = at.at(a.id[k]);
    d.x = std::max(d.x, norm(a.x[k] - b.x[j]) / (2 * b.r[j]));
    if (vmax > 0) d.v = std::max(d.v, norm(a.v[k] - b.v[j]) / vmax);
    if (wmax > 0) d.w = std::max(d.w, norm(a.w[k] - b.w[j]) / wmax);
  }
  return d;
}

}  // namespace

// Where the fused sub-steps first leave the two kernels' bits, and by how
// much: one advance() call of k sub-steps each way for k = 2..24 (every
// sub-step) and then every 8th up to 120, with a skin of 1 % of the diameter
// so that the list is rebuilt (particles reordered, histories handed over)
// every few sub-steps from the start. Prints the first k whose state differs
// (or none) and the largest relative difference of positions, velocities and
// angular velocities. The states must be the same bits (the kernels round
// every operation as written); should they not be, the second assertion says
// which kind of difference it is: up to k = 24 (less than a collision time,
// dt = t_c / 50, before contacts amplify differences chaotically) a rounding
// difference of fp64 (unit roundoff 1.1e-16, a few hundred operations per
// sub-step) stays many orders below 1e-12 relative, while an operation on the
// wrong half step or twin array (a torque, a predictor, a history) is of the
// order of dt times a rate, 1e-4 or more.
TEST_P(DemFusedSubsteps, FirstDifferingSubstep) {
  const auto [backend, friction] = GetParam();
  if (backend == Backend::Cuda && !lbdem::test::gpu_available()) GTEST_SKIP() << cuda_unavailable_reason();
  const Bed bed(friction);
  const std::vector<int> lanes = backend == Backend::Cuda ? std::vector<int>{1, 4} : std::vector<int>{1};
  std::vector<long> ks;
  for (long k = 2; k <= 24; ++k) ks.push_back(k);
  for (long k = 32; k <= 120; k += 8) ks.push_back(k);
  for (int l : lanes) {
    DemParams p = bed.p;
    p.skin = 0.01 * 1.2e-3;
    p.force_lanes = l;
    long first = 0;
    Diff early, all;
    long rebuilds = 0;
    for (long k : ks) {
      const CallState ref = one_call(backend, bed, p, "0", k);
      const CallState fused = one_call(backend, bed, p, "1", k);
      ASSERT_EQ(fused.stats.fused_steps, k - 1);
      rebuilds = ref.stats.rebuilds;
      const Diff d = largest_difference(fused.h, ref.h);
      if (k <= 24) {
        early.x = std::max(early.x, d.x);
        early.v = std::max(early.v, d.v);
        early.w = std::max(early.w, d.w);
      }
      all.x = std::max(all.x, d.x);
      all.v = std::max(all.v, d.v);
      all.w = std::max(all.w, d.w);
      if (first == 0 && fused.bytes != ref.bytes) first = k;
    }
    const std::string what = std::string(to_string(backend)) + (friction ? ", friction" : ", no friction") +
                             ", lanes " + std::to_string(l);
    std::printf("%s: first sub-step whose fused state differs: %s; largest relative difference up to 24 sub-steps: "
                "x %.3g, v %.3g, w %.3g; up to 120: x %.3g, v %.3g, w %.3g (%ld rebuilds in 120)\n",
                what.c_str(), first ? std::to_string(first).c_str() : "none", early.x, early.v, early.w, all.x, all.v,
                all.w, rebuilds);
    EXPECT_GE(rebuilds, 10) << what;
    EXPECT_EQ(first, 0) << what << ": the fused state first differs after " << first << " sub-steps";
    EXPECT_LE(early.max(), 1e-12) << what << ": more than a rounding difference (an ordering error)";
  }
}

// The pair path (several kernels per force evaluation) is never fused, and
// gives the same bits whatever the switch says.
TEST_P(DemFusedSubsteps, PairPathUnfused) {
  const auto [backend, friction] = GetParam();
  if (backend == Backend::Cuda) GTEST_SKIP() << "the pair path's atomic sums are not reproducible on the device";
  const Bed bed(friction);
  DemParams p = bed.p;
  p.path = ForcePath::Pair;
  const BedRun on = run(backend, bed, p, "1", 3, 101);
  const BedRun off = run(backend, bed, p, "0", 3, 101);
  expect_same(on, off, "pair path");
  EXPECT_EQ(on.stats.fused_steps, 0);
}

INSTANTIATE_TEST_SUITE_P(All, DemFusedSubsteps,
                         ::testing::Combine(::testing::Values(Backend::Host, Backend::Cuda),
                                            ::testing::Values(false, true)),
                         param_name);

// A value of the switch other than 0 or 1 is refused, naming the variable
// and the value.
TEST(DemFusedSubstepsSwitch, RefusesOtherValues) {
  const Bed bed(false);
  for (const char* bad : {"2", "yes", ""}) {
    const FusedEnv env(bad);
    try {
      DemSystem s(Exec(Backend::Host), bed.p, bed.h);
      ADD_FAILURE() << "LBDEM_DEM_FUSED_SUBSTEPS='" << bad << "' accepted";
    } catch (const ConfigError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("LBDEM_DEM_FUSED_SUBSTEPS: '" + std::string(bad) + "'"), std::string::npos) << msg;
      EXPECT_NE(msg.find("not 0 or 1"), std::string::npos) << msg;
    }
  }
}
