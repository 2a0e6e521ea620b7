// Checkpoint/restart of the fluidized_bed scene (cases/src/cfd_case.cpp), on
// the real `lbdem` binary, host backend:
//  - N gas steps straight equal N/2 + --restart to N, bit for bit: the final
//    checkpoints (gas fields, particles with their contact histories and
//    neighbour list, the statistics accumulators) are the same bytes, the
//    series and the profiles the same text, the gas and particle snapshots
//    of the last step the same values;
//  - SIGTERM in the middle of a long run: the scene stops at once with a
//    checkpoint of the step it reached, and a restart from it to a given step
//    ends where a straight run to that step ends, bit for bit;
//  - refusals: a corrupt checkpoint, another scene's, another gas grid.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "core/checkpoint.hpp"
#include "core/output.hpp"
#include "core/signals.hpp"
#include "restart_scenes.hpp"
#include "run_lbdem.hpp"

namespace fs = std::filesystem;
using namespace lbdem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A small bubbling column: 3 x 1 x 12 gas cells of 4 mm, walls on x,
// periodic on y, 300 particles of 1.2 mm settling from a loose packing onto
// the distributor while the gas blows at 0.5 m/s (they move by far more
// than the neighbour-list skin in each half), statistics from the first
// step (both profile kinds), a tracked particle.
constexpr const char* kBed = R"(scene: fluidized_bed
domain: {lo: [0, 0, 0], hi: [0.012, 0.004, 0.048]}
gas:
  density: 1.225
  viscosity: 1.8e-5
  cell_size: 4.0e-3
  dt: 2.0e-4
  drag: gidaspow
  void_fraction: linear
  pressure_solver: {type: multigrid}
  boundaries:
    x_lo: {type: no_slip}
    x_hi: {type: no_slip}
    y_lo: {type: periodic}
    y_hi: {type: periodic}
    z_lo: {type: inlet, velocity: 0.5}
    z_hi: {type: outlet, pressure: 0}
physics: {gravity: [0, 0, -9.80665]}
particles: {init: random, density: 1000, radius: [0.6e-3], count: 300, region_hi: [0.012, 0.004, 0.03], seed: 5}
material: {stiffness: 100, restitution: 0.9, friction: 0.1}
dem: {steps_per_collision: 20}
time: {steps: 300}
statistics:
  start: 0
  interval: 3
  profiles:
    - {quantity: void_fraction, height: 0.01}
    - {quantity: particle_velocity_z, height: 0.008}
diagnostics: {check_interval: 20}
output: {directory: unused, interval: 150, series_interval: 10, track: [7]}
checkpoint: {interval: 1000000}
)";

class BedRestart : public ::testing::Test {
 public:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lbdem_bed_restart_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    setenv("OMP_NUM_THREADS", "1", 1);  // small loops: OpenMP barriers cost more than they save
  }
  void TearDown() override {
    std::error_code ec;
    if (!HasFailure()) fs::remove_all(dir_, ec);
  }
  std::string write_case(const std::string& text, const std::string& name = "bed.yaml") {
    const auto p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  test::Result lbdem(const std::string& args) { return test::run("run " + args + " --backend cpu --quiet"); }
  fs::path dir_;
};

// The named datasets of two HDF5 snapshots hold the same values, bit for bit.
void expect_same_datasets(const fs::path& a, const fs::path& b, const std::vector<std::string>& names) {
  for (const auto& n : names) {
    const auto va = io::read_dataset(a.string(), n), vb = io::read_dataset(b.string(), n);
    ASSERT_EQ(va.size(), vb.size()) << a << " " << n;
    ASSERT_FALSE(va.empty()) << a << " " << n;
    EXPECT_EQ(0, std::memcmp(va.data(), vb.data(), va.size() * sizeof(double))) << a << " vs " << b << ": " << n;
  }
}

// The final states of two runs of the bed are the same: checkpoint bytes,
// series and profiles text, the snapshots of step `last`.
void expect_same_end(const fs::path& A, const fs::path& B, long last) {
  const std::string ca = slurp(A / ckpt::kFileName), cb = slurp(B / ckpt::kFileName);
  ASSERT_GT(ca.size(), 1000u);
  EXPECT_EQ(ckpt::Reader((A / ckpt::kFileName).string()).step(), last);
  EXPECT_TRUE(ca == cb) << "the final checkpoints differ: the restarted run is not in the straight run's state";
  EXPECT_EQ(slurp(A / "series.csv"), slurp(B / "series.csv"));
  EXPECT_EQ(slurp(A / "profiles.csv"), slurp(B / "profiles.csv"));
  EXPECT_EQ(slurp(A / "profiles_blocks.csv"), slurp(B / "profiles_blocks.csv"));
  char name[64];
  std::snprintf(name, sizeof name, "%08ld.h5", last);
  expect_same_datasets(A / ("gas_" + std::string(name)), B / ("gas_" + std::string(name)),
                       {"gas_fraction", "pressure", "velocity"});
  expect_same_datasets(A / ("particles_" + std::string(name)), B / ("particles_" + std::string(name)),
                       {"positions", "velocity", "angular_velocity", "id"});
}

// The rows of a CSV file below its header, split at commas.
std::vector<std::vector<std::string>> csv_rows(const fs::path& p, const std::string& header) {
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, header) << p;
  std::vector<std::vector<std::string>> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    rows.push_back(f);
  }
  return rows;
}

double json_number(const std::string& js, const std::string& key) {
  const auto at = js.find("\"" + key + "\": ");
  return at == std::string::npos ? -1 : std::stod(js.substr(at + key.size() + 4));
}

}  // namespace

TEST_F(BedRestart, StraightEqualsHalfPlusRestartBitwise) {
  const std::string c = write_case(kBed);
  const fs::path A = dir_ / "A", B = dir_ / "B";
  const auto r0 = lbdem(c + " --output " + A.string());
  ASSERT_EQ(r0.code, 0) << r0.out;
  const auto r1 = lbdem(c + " --output " + B.string() + " --steps 150");
  ASSERT_EQ(r1.code, 0) << r1.out;
  ASSERT_EQ(ckpt::Reader((B / ckpt::kFileName).string()).step(), 150);
  // The half-way statistics differ from the end's (the restart has
  // accumulators to carry): some samples were taken before the checkpoint.
  EXPECT_GT(json_number(slurp(B / "summary.json"), "statistics_samples"), 0);
  const auto r2 = lbdem(c + " --restart " + B.string());
  ASSERT_EQ(r2.code, 0) << r2.out;
  expect_same_end(A, B, 300);
  EXPECT_EQ(slurp(A / "gas.xdmf"), slurp(B / "gas.xdmf"));
  EXPECT_EQ(slurp(A / "particles.xdmf"), slurp(B / "particles.xdmf"));
  const std::string js = slurp(B / "summary.json");
  EXPECT_EQ(json_number(js, "restarted_from_step"), 150) << js;
  EXPECT_EQ(json_number(js, "gas_steps"), 300) << js;
  EXPECT_EQ(json_number(js, "statistics_samples"), json_number(slurp(A / "summary.json"), "statistics_samples"));
  // Both profiles hold samples (the velocity profile: particles passed the height).
  const std::string prof = slurp(A / "profiles.csv");
  EXPECT_NE(prof.find("void_fraction,0.01,"), std::string::npos) << prof;
  EXPECT_NE(prof.find("particle_velocity_z,0.008,"), std::string::npos) << prof;
  EXPECT_EQ(prof.find(",nan,"), std::string::npos) << prof;
}

// The same with the forces lagged by one gas step (gas.force_coupling:
// lagged): the forces the sub-steps take after the restart come from the
// checkpoint's coupling input, so the chain ends where the straight run ends;
// the lagged run's answer is its own (not the sequential one's).
TEST_F(BedRestart, LaggedForcesStraightEqualsHalfPlusRestartBitwise) {
  std::string text = kBed;
  const std::string key = "  drag: gidaspow\n";
  text.replace(text.find(key), key.size(), key + "  force_coupling: lagged\n");
  const std::string c = write_case(text);
  const fs::path A = dir_ / "A", B = dir_ / "B", S = dir_ / "S";
  const auto r0 = lbdem(c + " --output " + A.string());
  ASSERT_EQ(r0.code, 0) << r0.out;
  const auto r1 = lbdem(c + " --output " + B.string() + " --steps 150");
  ASSERT_EQ(r1.code, 0) << r1.out;
  const auto r2 = lbdem(c + " --restart " + B.string());
  ASSERT_EQ(r2.code, 0) << r2.out;
  expect_same_end(A, B, 300);
  EXPECT_NE(slurp(A / "summary.json").find("\"force_coupling\": \"lagged\""), std::string::npos);
  const auto r3 = lbdem(write_case(kBed, "seq.yaml") + " --output " + S.string());
  ASSERT_EQ(r3.code, 0) << r3.out;
  EXPECT_NE(slurp(A / "series.csv"), slurp(S / "series.csv")) << "the lagged forces changed nothing";
}

TEST_F(BedRestart, SigtermWritesCheckpointAndRestartIsBitwise) {
  std::string yaml = kBed;
  yaml.replace(yaml.find("steps: 300"), 10, "steps: 100000000");
  const std::string c = write_case(yaml);
  const fs::path A = dir_ / "A", B = dir_ / "B", log = dir_ / "log.txt";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    std::freopen(log.c_str(), "w", stdout);
    dup2(fileno(stdout), 2);
    execl(LBDEM_EXE, "lbdem", "run", c.c_str(), "--backend", "cpu", "--quiet", "--output", B.c_str(),
          static_cast<char*>(nullptr));
    _exit(127);
  }
  // Into the time loop (a series row beyond step 0), then SIGTERM.
  using clk = std::chrono::steady_clock;
  const auto t0 = clk::now();
  auto since = [](clk::time_point t) { return std::chrono::duration<double>(clk::now() - t).count(); };
  int st = 0;
  bool exited = false;
  auto rows = [&] {
    const std::string s = slurp(B / "series.csv");
    return std::count(s.begin(), s.end(), '\n');
  };
  while (rows() < 4 && since(t0) < 120) {
    if (waitpid(pid, &st, WNOHANG) == pid) {
      exited = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_FALSE(exited) << "lbdem ended before the signal: " << slurp(log);
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  const auto t1 = clk::now();
  while (!exited && since(t1) < 60) {
    if (waitpid(pid, &st, WNOHANG) == pid) exited = true;
    else std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const double stop_seconds = since(t1);
  if (!exited) {
    kill(pid, SIGKILL);
    waitpid(pid, &st, 0);
    FAIL() << "lbdem did not stop after SIGTERM: " << slurp(log);
  }
  RecordProperty("stop_seconds", std::to_string(stop_seconds));
  ASSERT_TRUE(WIFEXITED(st)) << slurp(log);
  EXPECT_EQ(WEXITSTATUS(st), kExitInterrupted) << slurp(log);
  EXPECT_NE(slurp(log).find("stopped by SIGTERM"), std::string::npos) << slurp(log);
  // Independent of the intervals (none falls due here): the signal's checkpoint.
  const long s = ckpt::Reader((B / ckpt::kFileName).string()).step();
  ASSERT_GT(s, 0);
  EXPECT_EQ(json_number(slurp(B / "summary.json"), "gas_steps"), s);
  // On to s + 37 (off the output grids) from the checkpoint, and straight.
  const std::string to = " --steps " + std::to_string(s + 37);
  const auto r2 = lbdem(c + " --restart " + B.string() + to);
  ASSERT_EQ(r2.code, 0) << r2.out;
  const auto r0 = lbdem(c + " --output " + A.string() + to);
  ASSERT_EQ(r0.code, 0) << r0.out;
  expect_same_end(A, B, s + 37);
}

TEST_F(BedRestart, CorruptOtherSceneOtherGridRefused) {
  const std::string c = write_case(kBed);
  const fs::path R = dir_ / "R";
  ASSERT_EQ(lbdem(c + " --output " + R.string() + " --steps 4").code, 0);
  const std::string good = slurp(R / ckpt::kFileName), series = slurp(R / "series.csv");
  auto refused = [&](const std::string& args, const std::string& what) {
    const auto r = lbdem(args);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find(what), std::string::npos) << r.out;
    EXPECT_EQ(slurp(R / "series.csv"), series);  // nothing of the run touched
    EXPECT_TRUE(fs::exists(R / "gas_00000004.h5"));
  };
  std::string bad = good;
  bad[bad.size() / 2] ^= 0x10;
  std::ofstream(R / ckpt::kFileName, std::ios::binary) << bad;
  refused(c + " --restart " + R.string(), "corrupt");
  std::ofstream(R / ckpt::kFileName, std::ios::binary) << good;
  // Another gas grid (cells of 2 mm): the identity names it.
  std::string fine = kBed;
  fine.replace(fine.find("cell_size: 4.0e-3"), 17, "cell_size: 2.0e-3");
  fine.replace(fine.find("dt: 2.0e-4"), 10, "dt: 1.0e-4");
  refused(write_case(fine, "fine.yaml") + " --restart " + R.string(), "gas_grid '3x1x12' (this run: '6x2x24')");
  // A dem scene's checkpoint is refused by the bed, the bed's by the dem scene.
  const fs::path D = dir_ / "D";
  const std::string dem = write_case(test::kRestartDem, "dem.yaml");
  ASSERT_EQ(lbdem(dem + " --output " + D.string() + " --steps 2").code, 0);
  const std::string dem_series = slurp(D / "series.csv");
  const auto r = lbdem(c + " --restart " + D.string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("scene 'dem' (this run: 'fluidized_bed')"), std::string::npos) << r.out;
  EXPECT_EQ(slurp(D / "series.csv"), dem_series);
  refused(dem + " --restart " + R.string(), "scene 'fluidized_bed' (this run: 'dem')");
}

// The profiles' standard errors are the spread of their batch means: with
// statistics.blocks 4, every profile cell's average is the sample-weighted
// mean of its four block means (profiles_blocks.csv), its sample count their
// sum, and its standard error sqrt(sum (m_b - mean m)^2 / (3 * 4)); the
// files print 6 significant digits, hence the tolerances.
TEST_F(BedRestart, ProfileStandardErrorsAreTheSpreadOfTheBlockMeans) {
  std::string text = kBed;
  const std::string key = "  interval: 3\n";
  text.replace(text.find(key), key.size(), key + "  blocks: 4\n");
  const fs::path A = dir_ / "A";
  const auto r = lbdem(write_case(text) + " --output " + A.string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto prof = csv_rows(A / "profiles.csv", "quantity,height,x,value,samples,standard_error");
  const auto blocks = csv_rows(A / "profiles_blocks.csv", "quantity,height,x,block,t_start,t_end,value,samples");
  ASSERT_EQ(prof.size(), 6u);  // two profiles of 3 cells
  ASSERT_EQ(blocks.size(), 4 * prof.size());
  int checked = 0;
  for (const auto& p : prof) {
    std::vector<double> m, n;
    for (const auto& b : blocks)
      if (b[0] == p[0] && b[1] == p[1] && b[2] == p[2] && std::stod(b[7]) > 0) {
        m.push_back(std::stod(b[6]));
        n.push_back(std::stod(b[7]));
      }
    double sn = 0, snm = 0, mean = 0, var = 0;
    for (std::size_t k = 0; k < m.size(); ++k) sn += n[k], snm += n[k] * m[k], mean += m[k] / m.size();
    for (double x : m) var += (x - mean) * (x - mean);
    EXPECT_EQ(std::stod(p[4]), sn) << p[0] << " at x " << p[2];
    if (m.size() < 2) {
      EXPECT_EQ(p[5], "nan");
      continue;
    }
    const double value = std::stod(p[3]), se = std::stod(p[5]);
    EXPECT_NEAR(value, snm / sn, 1e-5 * std::max(1.0, std::fabs(value))) << p[0] << " at x " << p[2];
    // Each printed block mean is off by up to 5e-7 of itself; se then by about as much.
    EXPECT_NEAR(se, std::sqrt(var / (m.size() - 1) / m.size()), 1e-6 * std::max(1.0, std::fabs(value)) + 1e-5 * se)
        << p[0] << " at x " << p[2];
    EXPECT_GT(se, 0) << "a bubbling bed's profile does not stand still";
    ++checked;
  }
  EXPECT_GE(checked, 3);
  // The blocks tile the window [statistics.start, time.steps * gas.dt] = [0, 0.06] s
  // (rows: profile, then block, then x).
  EXPECT_EQ(std::stod(blocks[0][4]), 0.0);
  EXPECT_NEAR(std::stod(blocks[3][4]), 0.015, 1e-12);
  EXPECT_NEAR(std::stod(blocks[9][5]), 300 * 2.0e-4, 1e-12);
  EXPECT_NE(slurp(A / "summary.json").find("\"statistics_blocks\": 4"), std::string::npos);
}
