// Checkpoints of runs on several ranks (`mpirun -np N lbdem run`, checkpoint
// section; halo/shared_checkpoint.hpp, lbm/checkpoint.hpp): one file, written by rank 0, from
// which a run on any number of ranks, cut any way, goes on.
//  - fluid scenes (A-A and two-lattice, fp32 and fp64, periodic and walled,
//    restarted at odd and even steps): N steps straight equal k steps on Na
//    ranks + --restart on Nb ranks to N, bit for bit: the final fields, and
//    the final checkpoints (canonical: the same bytes whatever the cut);
//  - a stop signal on two ranks writes one checkpoint, and the restart from it
//    ends in the straight run's state;
//  - the dem scene (friction, walls) and the coupled particles scene: the
//    same rank count and cut bit for bit; another rank count to round-off
//    (the neighbour list is rebuilt at the load, tangential histories kept);
//  - refusals: another grid.
// Skipped where the build has no MPI launcher.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/checkpoint.hpp"
#include "core/output.hpp"
#include "restart_scenes.hpp"
#include "run_lbdem.hpp"

namespace lbdem::test {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class MpiRestart : public ::testing::Test {
 public:
  void SetUp() override {
    if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
    dir_ = fs::temp_directory_path() / ("lbdem_mpi_restart_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!HasFailure()) fs::remove_all(dir_, ec);
  }
  // The command line of `lbdem run` of `yaml` (cut as `dims` on `ranks` ranks) into `out`.
  std::string command(const std::string& yaml, int ranks, const std::string& dims, const fs::path& out,
                      const std::string& extra) {
    static int n = 0;
    const fs::path file = dir_ / ("case" + std::to_string(n++) + ".yaml");
    // The dem scene names its cut at the top level, the others in `parallel`.
    const bool dem = yaml.rfind("scene: dem", 0) == 0;
    std::ofstream(file) << yaml
                        << (ranks > 1 && !dims.empty()
                                ? (dem ? "decomposition: " + dims + "\n" : "parallel: {decomposition: " + dims + "}\n")
                                : "");
    std::string args = "run " + file.string() + " --backend cpu --quiet --output " + out.string() + " " + extra;
    return ranks_command(ranks, args);
  }
  Result lbdem(const std::string& yaml, int ranks, const std::string& dims, const fs::path& out,
               const std::string& extra = "") {
    const Result r = run_command(command(yaml, ranks, dims, out, extra) + " 2>&1");
    // Several ranks write pieces (core/piece_output.hpp): joined into whole files here.
    if (r.code != 0 || ranks == 1 || yaml.rfind("scene: dem", 0) == 0) return r;
    const Result j = run("join " + out.string() + " --all");
    return j.code == 0 ? r : Result{j.code, r.out + j.out};
  }
  fs::path dir_;
};

struct Cut {
  int ranks;
  std::string dims;  // "" = chosen
};

// The named datasets of two HDF5 files hold the same values, bit for bit.
void expect_same_fields(const fs::path& a, const fs::path& b) {
  for (const char* n : {"density", "velocity", "pressure"}) {
    const auto va = io::read_dataset(a.string(), n), vb = io::read_dataset(b.string(), n);
    ASSERT_FALSE(va.empty()) << a << " " << n;
    ASSERT_EQ(va.size(), vb.size()) << n;
    EXPECT_EQ(0, std::memcmp(va.data(), vb.data(), va.size() * sizeof(double))) << a << " vs " << b << ": " << n;
  }
}

std::string tag(long step) {
  char t[32];
  std::snprintf(t, sizeof t, "fields_%08ld.h5", step);
  return t;
}

// `yaml` planned to `steps`: straight on `b` ranks into S; `first` steps on
// `a` ranks then --restart on `b` ranks into R. Final fields and checkpoints
// are the same bits.
void chain(MpiRestart& t, const std::string& yaml, long steps, long first, const Cut& a, const Cut& b,
           const std::string& name) {
  const fs::path S = t.dir_ / (name + "_S"), R = t.dir_ / (name + "_R");
  const auto s = t.lbdem(yaml, b.ranks, b.dims, S);
  ASSERT_EQ(s.code, 0) << s.out;
  const auto r1 = t.lbdem(yaml, a.ranks, a.dims, R, "--steps " + std::to_string(first));
  ASSERT_EQ(r1.code, 0) << r1.out;
  ASSERT_TRUE(fs::exists(R / ckpt::kFileName)) << r1.out;
  {
    ckpt::Reader ck((R / ckpt::kFileName).string());
    EXPECT_EQ(ck.step(), first);
    EXPECT_EQ(ck.meta("ranks"), a.ranks > 1 ? std::to_string(a.ranks) : "");
  }
  const auto r2 = t.lbdem(yaml, b.ranks, b.dims, R, "--restart " + R.string());
  ASSERT_EQ(r2.code, 0) << r2.out;
  expect_same_fields(S / tag(steps), R / tag(steps));
  const std::string cs = slurp(S / ckpt::kFileName), cr = slurp(R / ckpt::kFileName);
  ASSERT_GT(cs.size(), 100u);
  EXPECT_TRUE(cs == cr) << name << ": the final checkpoints differ";
  EXPECT_EQ(slurp(S / "diagnostics.csv").substr(0, 40), slurp(R / "diagnostics.csv").substr(0, 40));
  fs::remove_all(S);
  fs::remove_all(R);
}

// D2Q9, fp32, A-A, periodic: restarted at an odd step (populations of a cell
// in its neighbours' slots).
const char* kBoxAa = R"(scene: periodic_box
lattice: D2Q9
collision: {model: trt, tau: 0.8}
precision: fp32
streaming: aa
fluid: {density: 1.0, kinematic_viscosity: 1.0e-5}
domain: {cells: [16, 14], spacing: 1.0e-3}
periodic_box: {initial_velocity: [0.001, 0.0005, 0]}
time: {steps: 12}
output: {interval: 0}
diagnostics: {interval: 4}
checkpoint: {interval: 1000}
)";

// D2Q9, fp64, two-lattice, walls along y, body force.
const char* kChannelTl = R"(scene: channel
lattice: D2Q9
precision: fp64
streaming: two_lattice
collision: {model: trt, tau: 0.8}
fluid: {density: 1.2, kinematic_viscosity: 1.5e-5}
domain: {cells: [8, 18], spacing: 3.125e-5}
channel: {mode: periodic, body_acceleration: 5.0}
time: {steps: 12}
output: {interval: 0}
diagnostics: {interval: 4}
checkpoint: {interval: 1000}
)";

// D3Q19, fp32, A-A, cut along two axes.
const char* kTg3d = R"(scene: taylor_green
lattice: D3Q19
precision: fp32
streaming: aa
collision: {model: trt, tau: 0.8}
fluid: {density: 1.0, kinematic_viscosity: 1.0e-6}
domain: {cells: [8, 8, 8], spacing: 1.5625e-5}
taylor_green: {velocity: 1.0e-3}
time: {steps: 10}
output: {interval: 0}
diagnostics: {interval: 5}
checkpoint: {interval: 1000}
)";

TEST_F(MpiRestart, FluidAaOddStepAnyRankCountBitwise) {
  chain(*this, kBoxAa, 12, 7, {2, ""}, {2, ""}, "2to2");
  chain(*this, kBoxAa, 12, 7, {2, "[2, 1, 1]"}, {3, "[1, 3, 1]"}, "2to3");
  chain(*this, kBoxAa, 12, 5, {3, "[3, 1, 1]"}, {1, ""}, "3to1");
  chain(*this, kBoxAa, 12, 7, {1, ""}, {2, "[2, 1, 1]"}, "1to2");
}

TEST_F(MpiRestart, FluidTwoLatticeWallsAnyRankCountBitwise) {
  chain(*this, kChannelTl, 12, 6, {2, "[1, 2, 1]"}, {2, "[1, 2, 1]"}, "2to2");
  chain(*this, kChannelTl, 12, 5, {2, "[2, 1, 1]"}, {3, "[1, 3, 1]"}, "2to3");
  chain(*this, kChannelTl, 12, 7, {3, "[1, 3, 1]"}, {1, ""}, "3to1");
}

// A-A with walls (a moving lid): the reflections a fluid cell stores in a
// boundary cell across a cut lie in the writer's ghost copy of it.
const char* kCavityAa = R"(scene: lid_driven_cavity
lattice: D2Q9
precision: fp32
collision: {model: trt, tau: 0.6}
fluid: {density: 1.0, kinematic_viscosity: 1.0e-4}
domain: {cells: [20, 22], spacing: 7.8125e-5}
lid_driven_cavity: {lid_velocity: 1.0}
time: {steps: 12}
output: {interval: 0}
diagnostics: {interval: 4}
checkpoint: {interval: 1000}
)";

TEST_F(MpiRestart, Fluid3dAndWalledTwoAxisCutsBitwise) {
  chain(*this, kTg3d, 10, 3, {4, "[1, 2, 2]"}, {2, "[2, 1, 1]"}, "4to2");
  chain(*this, kCavityAa, 12, 5, {4, "[2, 2, 1]"}, {3, "[1, 3, 1]"}, "cavity4to3");
}

// A stop signal on two ranks: the ranks agree on the step, rank 0 writes one
// checkpoint, exit 130/143 (kExitInterrupted); the restart reaches the
// straight run's state.
TEST_F(MpiRestart, StopSignalOnTwoRanksWritesOneCheckpoint) {
  std::string yaml = kBoxAa;
  yaml.replace(yaml.find("steps: 12"), 9, "steps: 1000000");
  const fs::path R = dir_ / "signal", S = dir_ / "straight";
  const std::string cmd = command(yaml, 2, "[2, 1, 1]", R, "") + " >" + (dir_ / "log").string() + " 2>&1";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::setpgid(0, 0);
    ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Wait until the run is under way (its diagnostics have rows), then signal every process of its group.
  for (int i = 0; i < 600; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (slurp(R / "diagnostics.csv").size() > 200) break;
  }
  // SIGTERM to each rank (the lbdem processes of this case file), as a batch system sends it.
  int signalled = 0;
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::string cl = slurp(e.path() / "cmdline");
    std::replace(cl.begin(), cl.end(), '\0', ' ');
    if (cl.rfind(std::string(LBDEM_EXE) + " run ", 0) == 0 && cl.find(R.string()) != std::string::npos) {
      ::kill(std::stoi(name), SIGTERM);
      ++signalled;
    }
  }
  EXPECT_EQ(signalled, 2);
  int st = 0;
  ::waitpid(pid, &st, 0);
  const std::string log = slurp(dir_ / "log");
  ASSERT_TRUE(WIFEXITED(st)) << log;
  ASSERT_NE(WEXITSTATUS(st), 0) << log;
  ASSERT_TRUE(fs::exists(R / ckpt::kFileName)) << log;
  long at = 0;
  {
    ckpt::Reader ck((R / ckpt::kFileName).string());
    at = ck.step();
    EXPECT_EQ(ck.meta("ranks"), "2");
  }
  ASSERT_GT(at, 0);
  ASSERT_LT(at, 1000000) << "the run ended before the signal";
  // Only the final checkpoint: no temporaries.
  for (const auto& e : fs::directory_iterator(R)) EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos);
  const long to = at + 6;
  const auto r2 = lbdem(yaml, 3, "", R, "--restart " + R.string() + " --steps " + std::to_string(to));
  ASSERT_EQ(r2.code, 0) << r2.out;
  const auto s = lbdem(yaml, 1, "", S, "--steps " + std::to_string(to));
  ASSERT_EQ(s.code, 0) << s.out;
  expect_same_fields(S / tag(to), R / tag(to));
}

// Checkpoints by wall time: the ranks agree on when (their clocks differ),
// and the restart from the last one is bit for bit.
TEST_F(MpiRestart, WallClockCheckpointsOnTwoRanks) {
  std::string yaml = kBoxAa;
  yaml.replace(yaml.find("checkpoint: {interval: 1000}"), 28, "checkpoint: {minutes: 1.0e-7}");
  const fs::path R = dir_ / "minutes", S = dir_ / "straight";
  const auto r1 = lbdem(yaml, 2, "[1, 2, 1]", R, "--steps 9");
  ASSERT_EQ(r1.code, 0) << r1.out;
  EXPECT_EQ(ckpt::Reader((R / ckpt::kFileName).string()).step(), 9);
  const auto r2 = lbdem(yaml, 2, "[2, 1, 1]", R, "--restart " + R.string());
  ASSERT_EQ(r2.code, 0) << r2.out;
  ASSERT_EQ(lbdem(yaml, 1, "", S).code, 0);
  expect_same_fields(S / tag(12), R / tag(12));
}

TEST_F(MpiRestart, RefusesCheckpointOfAnotherGrid) {
  const fs::path R = dir_ / "grid";
  ASSERT_EQ(lbdem(kBoxAa, 2, "", R, "--steps 4").code, 0);
  const std::string before = slurp(R / ckpt::kFileName);
  std::string other = kBoxAa;
  other.replace(other.find("[16, 14]"), 8, "[16, 16]");
  const auto r = lbdem(other, 2, "", R, "--restart " + R.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("grid '16x14x1'"), std::string::npos) << r.out;
  EXPECT_EQ(slurp(R / ckpt::kFileName), before);
}

// ---------------------------------------------------------------------------
// Particles: the dem scene (friction, walls) and the coupled particles scene.
// ---------------------------------------------------------------------------

// The named datasets of two particle snapshots (ascending id): bitwise when
// `rel` is 0, else within rel of the largest magnitude of each dataset.
void expect_close(const fs::path& a, const fs::path& b, const std::vector<std::string>& names, double rel) {
  for (const auto& n : names) {
    const auto va = io::read_dataset(a.string(), n), vb = io::read_dataset(b.string(), n);
    ASSERT_FALSE(va.empty()) << a << " " << n;
    ASSERT_EQ(va.size(), vb.size()) << n;
    if (rel == 0) {
      EXPECT_EQ(0, std::memcmp(va.data(), vb.data(), va.size() * sizeof(double))) << a << " vs " << b << ": " << n;
      continue;
    }
    double scale = 0, worst = 0;
    for (std::size_t i = 0; i < va.size(); ++i) {
      scale = std::max(scale, std::abs(va[i]));
      worst = std::max(worst, std::abs(va[i] - vb[i]));
    }
    EXPECT_LE(worst, rel * scale) << a << " vs " << b << ": " << n;
  }
}

std::string snap(const std::string& prefix, long step) {
  char t[64];
  std::snprintf(t, sizeof t, "%s_%08ld.h5", prefix.c_str(), step);
  return t;
}

// Straight on `b` ranks into S; to `first` on `a` ranks, --restart on `b` into R.
void particle_chain(MpiRestart& t, const std::string& yaml, long steps, long first, const Cut& a, const Cut& b,
                    const std::string& name, const std::vector<std::string>& particle_sets, double rel,
                    bool fields) {
  const fs::path S = t.dir_ / (name + "_S"), R = t.dir_ / (name + "_R");
  const auto s = t.lbdem(yaml, b.ranks, b.dims, S);
  ASSERT_EQ(s.code, 0) << s.out;
  const auto r1 = t.lbdem(yaml, a.ranks, a.dims, R, "--steps " + std::to_string(first));
  ASSERT_EQ(r1.code, 0) << r1.out;
  {
    ckpt::Reader ck((R / ckpt::kFileName).string());
    EXPECT_EQ(ck.step(), first);
    EXPECT_EQ(ck.meta("ranks"), a.ranks > 1 ? std::to_string(a.ranks) : "");
  }
  const auto r2 = t.lbdem(yaml, b.ranks, b.dims, R, "--restart " + R.string());
  ASSERT_EQ(r2.code, 0) << r2.out;
  expect_close(S / snap("particles", steps), R / snap("particles", steps), particle_sets, rel);
  if (fields) expect_close(S / snap("fields", steps), R / snap("fields", steps), {"density", "velocity", "solid_fraction"}, rel);
  if (rel == 0) {
    EXPECT_EQ(slurp(S / "series.csv"), slurp(R / "series.csv")) << name;
  }
  fs::remove_all(S);
  fs::remove_all(R);
}

TEST_F(MpiRestart, DemSameCutBitwise) {
  particle_chain(*this, test::kRestartDem, 600, 300, {2, "[1, 1, 2]"}, {2, "[1, 1, 2]"}, "2to2",
                 {"positions", "velocity", "angular_velocity", "id", "force"}, 0, false);
}

// Another rank count: the particles are handed to the ranks whose pieces
// hold them and the neighbour list is rebuilt at the load (tangential
// histories carried by partner id). Sums in global-id order (as on several
// ranks): the straight run's state to round-off.
TEST_F(MpiRestart, DemOtherRankCountsWithinRoundOff) {
  std::string yaml = test::kRestartDem;
  yaml += "neighbours: {contact_order: global_id}\n";
  const std::vector<std::string> sets{"positions", "velocity", "angular_velocity", "id", "force"};
  particle_chain(*this, yaml, 600, 300, {2, "[1, 1, 2]"}, {1, ""}, "2to1", sets, 1e-12, false);
  particle_chain(*this, yaml, 600, 300, {1, ""}, {2, "[2, 1, 1]"}, "1to2", sets, 1e-12, false);
}

// The small suspension of the one-rank restart tests, cut so that particles cross the cut.
TEST_F(MpiRestart, ParticlesSameCutBitwiseAndOtherCutWithinRoundOff) {
  const std::vector<std::string> sets{"positions", "velocity", "angular_velocity", "id", "hydrodynamic_force"};
  particle_chain(*this, test::kRestartParticles, 40, 20, {2, "[2, 1, 1]"}, {2, "[2, 1, 1]"}, "2to2", sets, 0, true);
  particle_chain(*this, test::kRestartParticles, 40, 20, {2, "[2, 1, 1]"}, {3, "[1, 1, 3]"}, "2to3", sets, 1e-12, true);
}

}  // namespace
}  // namespace lbdem::test
