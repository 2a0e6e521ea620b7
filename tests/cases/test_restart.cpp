// Checkpoint/restart of the real `lbdem` binary (core/checkpoint.hpp):
//  - N steps straight equal N1 steps + --restart to N, bit for bit: the final
//    checkpoints (the whole state: populations, particles with tangential
//    histories and ids, Verlet list, rebuild scheduler, step counters) are
//    the same bytes, the time series the same text, the snapshots at the
//    common steps the same values; for the coupled particles scene (friction,
//    walls, neighbour-list rebuilds), the dem scene and a fluid scene (fp32,
//    A-A streaming, restarted at an odd step);
//  - a run killed with SIGKILL at random moments while it writes a
//    checkpoint every step keeps a readable checkpoint, and the restart from
//    it ends in the straight run's state;
//  - refusals: no checkpoint, corrupt, truncated, another grid, lattice,
//    precision or scene; one line, exit 2, nothing of the run changed.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/checkpoint.hpp"
#include "core/exec.hpp"
#include "core/output.hpp"
#include "restart_scenes.hpp"
#include "run_lbdem.hpp"

namespace fs = std::filesystem;
using namespace lbdem;

namespace {

using test::run;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class Restart : public ::testing::Test {
 public:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lbdem_restart_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    setenv("OMP_NUM_THREADS", "2", 1);
  }
  void TearDown() override {
    std::error_code ec;
    if (!HasFailure()) fs::remove_all(dir_, ec);
  }
  std::string write_case(const std::string& text, const std::string& name = "case.yaml") {
    const auto p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  // `lbdem run` on the host backend, quiet; returns the exit code, output to `log`.
  test::Result lbdem(const std::string& args) { return run("run " + args + " --backend " + backend_ + " --quiet"); }
  fs::path dir_;
  std::string backend_ = "cpu";
};

const char* kFluid = R"(scene: periodic_box
lattice: D2Q9
collision: {model: trt, tau: 0.8}
precision: fp32
fluid: {density: 1.0, kinematic_viscosity: 1.0e-5}
domain: {cells: [32, 32], spacing: 1.0e-3}
periodic_box: {initial_velocity: [0.001, 0.0005, 0]}
time: {steps: 20}
output: {interval: 10}
diagnostics: {interval: 5}
checkpoint: {interval: 1000}
)";

// The named datasets of two HDF5 snapshots hold the same values, bit for bit.
void expect_same_datasets(const fs::path& a, const fs::path& b, const std::vector<std::string>& names) {
  for (const auto& n : names) {
    const auto va = io::read_dataset(a.string(), n), vb = io::read_dataset(b.string(), n);
    ASSERT_EQ(va.size(), vb.size()) << a << " " << n;
    ASSERT_FALSE(va.empty()) << a << " " << n;
    EXPECT_EQ(0, std::memcmp(va.data(), vb.data(), va.size() * sizeof(double))) << a << " vs " << b << ": " << n;
  }
}

// Where two checkpoints first differ: the byte offset and the section it lies
// in (the last "u32 n + n-byte name" of a known section before it).
std::string first_difference(const std::string& a, const std::string& b) {
  std::size_t at = 0;
  const std::size_t n = std::min(a.size(), b.size());
  while (at < n && a[at] == b[at]) ++at;
  if (at == n && a.size() == b.size()) return "none";
  std::string section = "header";
  std::size_t best = 0;
  for (const char* name : {"run", "lbm", "dem", "coupling", "particles", "series", "statistics", "scheduler"}) {
    const std::uint32_t len = static_cast<std::uint32_t>(std::strlen(name));
    std::string key(reinterpret_cast<const char*>(&len), 4);
    key += name;
    const auto pos = a.rfind(key, at);
    if (pos != std::string::npos && pos >= best) best = pos, section = name;
  }
  return "byte " + std::to_string(at) + " of " + std::to_string(a.size()) + ", in section '" + section + "'";
}

// Runs `yaml` straight to its planned steps in A, then to `first` steps and
// --restart to the planned steps in B; the final checkpoints must be the same
// bytes and the series the same text. Returns the first part's summary.json.
std::string straight_vs_restart(Restart& t, const std::string& yaml, long first, const std::string& series,
                                const fs::path& A, const fs::path& B) {
  std::string summary;
  [&] {
  const auto r0 = t.lbdem(yaml + " --output " + A.string());
  ASSERT_EQ(r0.code, 0) << r0.out;
  const auto r1 = t.lbdem(yaml + " --output " + B.string() + " --steps " + std::to_string(first));
  ASSERT_EQ(r1.code, 0) << r1.out;
  summary = slurp(B / "summary.json");
  ASSERT_TRUE(fs::exists(B / ckpt::kFileName)) << "no checkpoint at the end of the first part";
  EXPECT_EQ(ckpt::Reader((B / ckpt::kFileName).string()).step(), first);
  const auto r2 = t.lbdem(yaml + " --restart " + B.string());
  ASSERT_EQ(r2.code, 0) << r2.out;
  const std::string ca = slurp(A / ckpt::kFileName), cb = slurp(B / ckpt::kFileName);
  ASSERT_GT(ca.size(), 100u);
  EXPECT_EQ(ca.size(), cb.size());
  EXPECT_TRUE(ca == cb) << "the final checkpoints differ (" << first_difference(ca, cb)
                        << "): the restarted run is not in the straight run's state";
  EXPECT_EQ(slurp(A / series), slurp(B / series));
  const std::string js = slurp(B / "summary.json");
  EXPECT_NE(js.find("\"interrupted\": false"), std::string::npos) << js;
  }();
  return summary;
}

long json_long(const std::string& js, const std::string& key) {
  const auto at = js.find("\"" + key + "\": ");
  return at == std::string::npos ? -1 : std::stol(js.substr(at + key.size() + 4));
}

}  // namespace

TEST_F(Restart, ParticlesStraightEqualsHalfPlusRestartBitwise) {
  const fs::path A = dir_ / "A", B = dir_ / "B";
  const std::string first = straight_vs_restart(*this, write_case(test::kRestartParticles), 20, "series.csv", A, B);
  if (HasFatalFailure()) return;
  const std::string js = slurp(B / "summary.json");
  EXPECT_NE(js.find("\"steps\": 40"), std::string::npos) << js;
  EXPECT_NE(js.find("\"restarted_from_step\": 20"), std::string::npos) << js;
  expect_same_datasets(A / "particles_00000040.h5", B / "particles_00000040.h5",
                       {"positions", "velocity", "angular_velocity", "id", "hydrodynamic_force"});
  expect_same_datasets(A / "fields_00000040.h5", B / "fields_00000040.h5", {"density", "velocity", "solid_fraction"});
  // The index lists every snapshot once, as in the straight run.
  EXPECT_EQ(slurp(A / "fields.xdmf"), slurp(B / "fields.xdmf"));
  EXPECT_EQ(slurp(A / "particles.xdmf"), slurp(B / "particles.xdmf"));
  // The neighbour list was rebuilt before and after the restart (the count
  // goes on from the checkpoint's).
  EXPECT_GE(json_long(first, "dem_rebuilds"), 1) << first;
  EXPECT_GT(json_long(js, "dem_rebuilds"), json_long(first, "dem_rebuilds")) << js;
}

// The same on the GPU (where one is usable): the device state streamed
// through the host in slabs, the rebuild reports' page-locked ring.
TEST_F(Restart, ParticlesCudaStraightEqualsHalfPlusRestartBitwise) {
  if (!cuda_unavailable_reason().empty()) GTEST_SKIP() << "no usable GPU: " << cuda_unavailable_reason();
  backend_ = "cuda";
  const fs::path A = dir_ / "A", B = dir_ / "B";
  const std::string first = straight_vs_restart(*this, write_case(test::kRestartParticles), 20, "series.csv", A, B);
  if (HasFatalFailure()) return;
  expect_same_datasets(A / "fields_00000040.h5", B / "fields_00000040.h5", {"density", "velocity", "solid_fraction"});
  EXPECT_GE(json_long(first, "dem_rebuilds"), 1) << first;
}

TEST_F(Restart, DemStraightEqualsHalfPlusRestartBitwise) {
  const fs::path A = dir_ / "A", B = dir_ / "B";
  straight_vs_restart(*this, write_case(test::kRestartDem), 300, "series.csv", A, B);
  if (HasFatalFailure()) return;
  expect_same_datasets(A / "particles_00000600.h5", B / "particles_00000600.h5",
                       {"positions", "velocity", "angular_velocity", "id", "force"});
  // Rebuilds happened before and after the restart (the series' last column).
  const std::string s = slurp(A / "series.csv");
  auto rebuilds_at = [&](const std::string& step) {
    const auto at = s.find("\n" + step + ",");
    if (at == std::string::npos) return -1.0;
    const std::string row = s.substr(at + 1, s.find('\n', at + 1) - at - 1);
    return std::stod(row.substr(row.rfind(',') + 1));
  };
  EXPECT_GE(rebuilds_at("300"), 1.0) << s;
  EXPECT_GT(rebuilds_at("600"), rebuilds_at("300")) << s;
}

TEST_F(Restart, FluidFp32AaOddStepStraightEqualsRestartBitwise) {
  const fs::path A = dir_ / "A", B = dir_ / "B";
  straight_vs_restart(*this, write_case(kFluid), 7, "diagnostics.csv", A, B);
  if (HasFatalFailure()) return;
  expect_same_datasets(A / "fields_00000020.h5", B / "fields_00000020.h5", {"density", "velocity", "pressure"});
}

TEST_F(Restart, SecondRestartFromFinishedRunContinuesLonger) {
  // A chain of jobs: 20 steps, then to 40 from its final checkpoint (the
  // case plans 40), again bitwise to the straight run.
  const std::string c = write_case(test::kRestartParticles);
  const fs::path A = dir_ / "A", B = dir_ / "B";
  ASSERT_EQ(lbdem(c + " --output " + A.string()).code, 0);
  ASSERT_EQ(lbdem(c + " --output " + B.string() + " --steps 20").code, 0);
  const auto r = lbdem(c + " --restart " + (B / ckpt::kFileName).string() + " --steps 30");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto r2 = lbdem(c + " --restart " + B.string());
  ASSERT_EQ(r2.code, 0) << r2.out;
  EXPECT_TRUE(slurp(A / ckpt::kFileName) == slurp(B / ckpt::kFileName));
  EXPECT_EQ(slurp(A / "series.csv"), slurp(B / "series.csv"));
}

// SIGKILL while the run writes a checkpoint after every step: the file under
// the final name is always complete (the previous one until the rename), and
// a restart from it reaches the straight run's state.
TEST_F(Restart, KillDuringCheckpointWriteKeepsPreviousAndRestartIsBitwise) {
  std::string yaml = test::kRestartParticles;
  yaml.replace(yaml.find("checkpoint: {interval: 20}"), 26, "checkpoint: {interval: 1}");
  yaml.replace(yaml.find("steps: 40"), 9, "steps: 60");
  const std::string c = write_case(yaml);
  const fs::path A = dir_ / "A", B = dir_ / "B", log = dir_ / "log.txt";
  ASSERT_EQ(lbdem(c + " --output " + A.string()).code, 0);
  std::mt19937 rng(12345);
  int kills = 0, mid_write = 0;
  long before = -1;
  for (int round = 0; round < 6; ++round) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      std::freopen(log.c_str(), "w", stdout);
      dup2(fileno(stdout), 2);
      if (before < 0)
        execl(LBDEM_EXE, "lbdem", "run", c.c_str(), "--backend", "cpu", "--quiet", "--output", B.c_str(),
              static_cast<char*>(nullptr));
      else
        execl(LBDEM_EXE, "lbdem", "run", c.c_str(), "--backend", "cpu", "--quiet", "--restart", B.c_str(),
              static_cast<char*>(nullptr));
      _exit(127);
    }
    // Wait for a checkpoint beyond the last one seen, then kill at a random moment.
    const auto t0 = std::chrono::steady_clock::now();
    int st = 0;
    bool exited = false;
    auto step_now = [&]() -> long {
      try {
        return ckpt::Reader((B / ckpt::kFileName).string()).step();
      } catch (const std::exception&) {
        return -1;
      }
    };
    while (step_now() <= before && std::chrono::steady_clock::now() - t0 < std::chrono::seconds(120)) {
      if (waitpid(pid, &st, WNOHANG) == pid) {
        exited = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (!exited) {
      std::this_thread::sleep_for(std::chrono::microseconds(std::uniform_int_distribution<int>(0, 150000)(rng)));
      kill(pid, SIGKILL);
      waitpid(pid, &st, 0);
      ++kills;
    }
    // Whatever the moment: the checkpoint under the final name reads (checksum and all).
    long s = -1;
    ASSERT_NO_THROW(s = ckpt::Reader((B / ckpt::kFileName).string()).step()) << "round " << round;
    EXPECT_GE(s, before) << "round " << round;
    for (const auto& e : fs::directory_iterator(B))
      if (e.path().filename().string().rfind(std::string(ckpt::kFileName) + ".tmp", 0) == 0) ++mid_write;
    before = s;
    if (exited || s >= 60) break;
  }
  EXPECT_GE(kills, 1);
  // The last restart runs to the end; its state is the straight run's.
  const auto r = lbdem(c + " --restart " + B.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(slurp(A / ckpt::kFileName) == slurp(B / ckpt::kFileName));
  EXPECT_EQ(slurp(A / "series.csv"), slurp(B / "series.csv"));
  // Temporaries of killed writes are the run's files: --overwrite removes them, nothing is left.
  const auto o = lbdem(c + " --output " + B.string() + " --overwrite --steps 1");
  EXPECT_EQ(o.code, 0) << o.out;
  for (const auto& e : fs::directory_iterator(B))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  RecordProperty("kills_mid_write", mid_write);
}

// ------------------------------------------------------------------ refusals
class RestartRefusal : public Restart {
 public:
  // A finished particles run in R (2 steps, checkpoint at 2).
  void make_run() {
    case_ = write_case(test::kRestartParticles);
    R_ = dir_ / "R";
    const auto r = lbdem(case_ + " --output " + R_.string() + " --steps 2");
    ASSERT_EQ(r.code, 0) << r.out;
    series_ = slurp(R_ / "series.csv");
    ckpt_ = slurp(R_ / ckpt::kFileName);
  }
  // A refused restart: exit 2, one line naming `what`, the run's files unchanged.
  void expect_refused(const std::string& args, const std::string& what) {
    const auto r = lbdem(args);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find(what), std::string::npos) << r.out;
    // One line besides log lines ("[hh:mm:ss] ..."; the start of a particle
    // scene may warn about its expected drag error before the refusal).
    long lines = 0;
    std::istringstream in(r.out);
    for (std::string l; std::getline(in, l);)
      if (!l.empty() && l[0] != '[') ++lines;
    EXPECT_EQ(lines, 1) << r.out;
    EXPECT_EQ(slurp(R_ / "series.csv"), series_);
    EXPECT_TRUE(fs::exists(R_ / "particles_00000002.h5"));
  }
  std::string case_, series_, ckpt_;
  fs::path R_;
};

TEST_F(RestartRefusal, FolderWithoutCheckpoint) {
  make_run();
  fs::create_directories(dir_ / "empty");
  const auto r = lbdem(case_ + " --restart " + (dir_ / "empty").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("holds no checkpoint"), std::string::npos) << r.out;
  expect_refused(case_ + " --restart " + (dir_ / "nowhere").string(), "no such run folder");
}

TEST_F(RestartRefusal, CorruptAndTruncated) {
  make_run();
  std::string bad = ckpt_;
  bad[bad.size() / 2] ^= 0x10;
  std::ofstream(R_ / ckpt::kFileName, std::ios::binary) << bad;
  expect_refused(case_ + " --restart " + R_.string(), "corrupt");
  std::ofstream(R_ / ckpt::kFileName, std::ios::binary) << ckpt_.substr(0, ckpt_.size() / 3);
  expect_refused(case_ + " --restart " + R_.string(), "truncated");
  std::ofstream(R_ / ckpt::kFileName, std::ios::binary) << "not a checkpoint at all\n";
  expect_refused(case_ + " --restart " + R_.string(), "not an lbdem checkpoint");
}

TEST_F(RestartRefusal, OtherGridPrecisionLatticeScene) {
  make_run();
  auto variant = [&](const std::string& from, const std::string& to, const std::string& name) {
    std::string y = test::kRestartParticles;
    y.replace(y.find(from), from.size(), to);
    return write_case(y, name);
  };
  expect_refused(variant("cells: [20, 20, 20]", "cells: [20, 24, 20]", "grid.yaml") + " --restart " + R_.string(),
                 "grid '20x22x20' (this run: '20x26x20')");
  expect_refused(variant("fluid: {tau: 0.55}", "fluid: {tau: 0.55, precision: fp32}", "fp32.yaml") + " --restart " +
                     R_.string(),
                 "precision 'fp64' (this run: 'fp32')");
  // A 2D lattice: another lattice (and grid).
  const std::string d2 = write_case(R"(scene: particles
units: lattice
domain: {cells: [20, 20], periodic: [1, 0]}
fluid: {tau: 0.8}
physics: {gravity: [0, -2.0e-5, 0]}
particles: {init: list, diameter: 4, density_ratio: 2, list: [{position: [10, 10]}]}
dem: {stiffness: 2, restitution: 0.5, substeps: 5}
time: {steps: 40}
output: {directory: unused, interval: 20, series_interval: 10}
)",
                                    "d2.yaml");
  expect_refused(d2 + " --restart " + R_.string(), "lattice 'D3Q19' (this run: 'D2Q9')");
  expect_refused(write_case(test::kRestartDem, "dem.yaml") + " --restart " + R_.string(), "scene 'particles' (this run: 'dem')");
  // A scene that writes no checkpoints.
  const std::string fs_case = write_case(R"(scene: fixed_sphere
units: lattice
geometry: {dim: 3, diameter: 4, chi: 0.25}
fluid: {tau: 0.52}
steady: {tolerance: 1.0e-14, max_steps: 10}
output: {directory: unused}
)",
                                         "fs.yaml");
  expect_refused(fs_case + " --restart " + R_.string(), "does not write checkpoints");
}

// When checkpoints are due (ckpt::Run::due): the interval, the wall-clock
// minutes, a stop signal, the end of the run; never twice at one step.
TEST(CheckpointPolicy, DueByIntervalMinutesSignalAndEnd) {
  const fs::path dir = fs::temp_directory_path() / ("lbdem_ckpt_policy_" + std::to_string(::getpid()));
  ckpt::Policy p;
  p.interval = 10;
  ckpt::Run by_steps(dir.string(), p, {}, std::nullopt);
  EXPECT_FALSE(by_steps.due(5, false));
  EXPECT_TRUE(by_steps.due(10, false));
  EXPECT_TRUE(by_steps.due(7, true));    // stop signal
  EXPECT_TRUE(by_steps.due(13, false, true));  // end of the run
  p.on_signal = false;
  ckpt::Run quiet(dir.string(), p, {}, std::nullopt);
  EXPECT_FALSE(quiet.due(7, true));
  ckpt::Policy t;
  t.minutes = 1e-6;  // due as soon as the clock has moved
  ckpt::Run by_time(dir.string(), t, {}, std::nullopt);
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  EXPECT_TRUE(by_time.due(3, false));
  ckpt::Run none(dir.string(), ckpt::Policy{0, 0, true}, {}, std::nullopt);
  EXPECT_FALSE(none.due(100, false));
  EXPECT_FALSE(none.due(100, false, true));  // nothing asked for: no checkpoint at the end
  fs::create_directories(dir);
  none.write(100, 1.0, [](ckpt::Writer& w) {
    w.section("x");
    w.put<int>(1);
  });
  EXPECT_FALSE(none.due(100, true));  // already written at this step
  EXPECT_EQ(ckpt::Reader(none.path()).step(), 100);
  std::error_code ec;
  fs::remove_all(dir, ec);
}
