// The production suspension through the particles scene (`lbdem`): the SI
// case against its lattice-unit twin, the paper's Table 2 conversion, the 2D
// random suspension, the default case's reference, the shipped suspension
// cases. The library parts are tested in their modules: the packings in
// tests/dem/test_suspension_packing.cpp, the Wen-Yu slip in
// tests/cfd/test_homogeneous_slip.cpp, the statistics and references in
// tests/imb/test_suspension_stats.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "imb/fixed_sphere.hpp"
#include "core/output.hpp"
#include "run_lbdem.hpp"

namespace lbdem::test {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The line of summary.json that starts with "key":
std::string summary_line(const std::string& js, const std::string& key) {
  const auto a = js.find("\"" + key + "\":");
  if (a == std::string::npos) return "";
  return js.substr(a, js.find('\n', a) - a);
}

double summary_number(const std::string& js, const std::string& key) {
  const auto a = js.find("\"" + key + "\": ");
  if (a == std::string::npos) return std::nan("");
  return std::stod(js.substr(a + key.size() + 4));
}

// series.csv without its `time` column (seconds in SI, steps in lattice units).
std::vector<std::vector<std::string>> series_without_time(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    if (cells.size() > 1) cells.erase(cells.begin() + 1);
    rows.push_back(cells);
  }
  return rows;
}

struct TmpDir {
  fs::path path;
  explicit TmpDir(const std::string& name) : path(fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TmpDir() { fs::remove_all(path); }
};

// SI values chosen so that every conversion is exact in binary: dx = 2^-10 m
// (d = 8 dx), rho_f = 2 kg/m^3 (dm = 2^-29 kg), tau = 0.875 (nu_lattice = 1/8)
// with nu = 2^-12 m^2/s, so dt = 2^-11 s; then g = -0.125 m/s^2 is
// -2^-15 in lattice units, k = 15.625 N/m is 2000, a speed of 2^-8 m/s is
// 2^-9, a position of 15.5 dx is 15.5.
constexpr const char* kLatticeTwin = R"(scene: particles
units: lattice
domain: {cells: [32, 32, 32], periodic: [1, 1, 1]}
fluid: {tau: 0.875, collision: trt, magic: 1.0e-3}
physics: {gravity: [0, -3.0517578125e-05, 0]}
particles: {init: random, diameter: 8, density_ratio: 8, count: 12, random_speed: 0.001953125, seed: 3}
dem: {stiffness: 2000, restitution: 0.9, substeps: 30}
psm: {fraction: table}
time: {steps: 30}
output: {directory: unused, series_interval: 10, interval: 30}
)";
constexpr const char* kSiTwin = R"(scene: particles
units: physical
domain: {size: [0.03125, 0.03125, 0.03125], periodic: [1, 1, 1]}
fluid: {density: 2, kinematic_viscosity: 0.000244140625, tau: 0.875, collision: trt, magic: 1.0e-3}
physics: {gravity: [0, -0.125, 0]}
particles: {init: random, diameter: 0.0078125, cells_per_diameter: 8, density: 16, count: 12,
            random_speed: 0.00390625, seed: 3}
dem: {stiffness: 15.625, restitution: 0.9, substeps: 30}
psm: {fraction: table}
time: {steps: 30}
output: {directory: unused, series_interval: 10, interval: 30}
)";

TEST(SuspensionUnits, SiCaseGivesExactlyTheLatticeParametersOfItsTwin) {
  TmpDir dir("lbdem_si_twin");
  std::ofstream(dir.path / "lattice.yaml") << kLatticeTwin;
  std::ofstream(dir.path / "si.yaml") << kSiTwin;
  for (const char* n : {"lattice", "si"}) {
    const auto r = run("run " + (dir.path / (std::string(n) + ".yaml")).string() + " --backend cpu --quiet --output " +
                       (dir.path / n).string());
    ASSERT_EQ(r.code, 0) << n << ": " << r.out;
  }
  const std::string a = slurp(dir.path / "lattice" / "summary.json"), b = slurp(dir.path / "si" / "summary.json");
  const std::string la = summary_line(a, "lattice"), lb = summary_line(b, "lattice");
  ASSERT_FALSE(la.empty()) << a;
  EXPECT_EQ(la, lb);  // tau, nu, diameter, density ratio, gravity, body force, stiffness, ... to 17 digits
  EXPECT_NE(summary_line(b, "units").find("physical"), std::string::npos);
  EXPECT_EQ(summary_number(b, "dx_m"), 0.0009765625);
  EXPECT_EQ(summary_number(b, "dt_s"), 0.00048828125);
  EXPECT_EQ(summary_number(b, "dm_kg"), std::ldexp(1.0, -29));
  EXPECT_EQ(summary_number(a, "dx_m"), 1.0);
  // The same run: every series column but time, and the particles, bitwise.
  const auto sa = series_without_time(dir.path / "lattice" / "series.csv");
  const auto sb = series_without_time(dir.path / "si" / "series.csv");
  ASSERT_EQ(sa.size(), 5u);  // header + steps 0, 10, 20, 30
  EXPECT_EQ(sa, sb);
  const auto pa = io::read_dataset((dir.path / "lattice" / "particles_00000030.h5").string(), "positions");
  const auto pb = io::read_dataset((dir.path / "si" / "particles_00000030.h5").string(), "positions");
  ASSERT_EQ(pa.size(), 36u);
  EXPECT_EQ(pa, pb);
  // The SI run's time column is in seconds.
  const std::string csv = slurp(dir.path / "si" / "series.csv");
  EXPECT_NE(csv.find("\n30,0.0146484375,"), std::string::npos) << csv.substr(0, 400);
}

// The first paper's Table 2 (3D column): its SI values give its lattice values.
TEST(SuspensionUnits, PaperTable2Conversion) {
  TmpDir dir("lbdem_table2");
  std::ofstream(dir.path / "case.yaml") << R"(scene: particles
units: physical
domain: {size: [0.0003, 0.0003, 0.0003], periodic: [1, 1, 1]}
fluid: {density: 1.3, kinematic_viscosity: 2.308e-5, collision: trt, magic: 1.0e-3, precision: fp32}
physics: {gravity: [0, -9.8, 0]}
particles: {init: random, diameter: 7.5e-5, cells_per_diameter: 10, density: 900, count: 16, random_speed: 0.0625}
dem: {stiffness: 27.25, restitution: 0.9, substeps: 10}
psm: {fraction: table}
time: {dt: 6.0e-7, steps: 2}
output: {directory: unused, series_interval: 1}
)";
  const auto r = run("run " + (dir.path / "case.yaml").string() + " --backend cpu --quiet --output " +
                     (dir.path / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string js = slurp(dir.path / "out" / "summary.json");
  EXPECT_NEAR(summary_number(js, "tau"), 0.5 + 3 * 0.2462, 3 * 5e-5);  // nu 0.2462 (Table 2, 4 digits)
  EXPECT_NEAR(summary_number(js, "nu"), 0.2462, 5e-5);
  EXPECT_NEAR(summary_number(js, "density_ratio"), 692.3, 0.05);
  EXPECT_NEAR(summary_number(js, "stiffness"), 17892, 17892 * 1e-3);
  EXPECT_DOUBLE_EQ(summary_number(js, "diameter"), 10.0);
  const auto g = js.find("\"gravity\": [0, ");
  ASSERT_NE(g, std::string::npos) << js;
  EXPECT_NEAR(std::stod(js.substr(g + 15)), -4.704e-7, 1e-10);
  EXPECT_EQ(summary_line(js, "lattice").find("\"cells\": [40, 40, 40]") != std::string::npos, true) << js;
}

// The default case (scripts/run_default.sh), 40 steps: its check is in
// summary.json with the Sangani-Acrivos reference of d/L = 0.25 in the
// physical-unit case's lattice units, and its output is what ParaView opens.
TEST(SuspensionUnits, DefaultCaseReportsItsReference) {
  TmpDir dir("lbdem_default_case");
  const auto r = run(std::string("run ") + LBDEM_SOURCE_DIR + "/cases/settling_sphere_periodic.yaml --backend cpu "
                     "--steps 40 --output " + (dir.path / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("check: terminal slip"), std::string::npos) << r.out;
  const std::string js = slurp(dir.path / "out" / "summary.json");
  EXPECT_DOUBLE_EQ(summary_number(js, "chi"), 0.25);
  // W / ((1 - phi)^2 3 pi mu d K(0.25)): W = (2 - 1) (4/3 pi 4^3) |g| (lattice), mu = 0.1, d = 8.
  const double g = 9.81 * 1e-5 * 1e-5 / 1e-4, W = 4.0 / 3.0 * M_PI * 64 * g, phi = M_PI / 6 * 0.25 * 0.25 * 0.25;
  const double K = W / (summary_number(js, "slip") * (1 - phi) * (1 - phi) * 3 * M_PI * 0.1 * 8);
  EXPECT_NEAR(K, imb::sangani_acrivos_K(0.25), 1e-9 * K);
  // ... which is Hasimoto's dilute limit 1 / (1 - 1.7601 c^1/3 + c - 1.5593 c^2), c = phi, to a percent.
  const double c = phi, hasimoto = 1 / (1 - 1.7601 * std::cbrt(c) + c - 1.5593 * c * c);
  EXPECT_NEAR(K, hasimoto, 0.01 * hasimoto);
  EXPECT_TRUE(fs::exists(dir.path / "out" / "fields.xdmf"));
  EXPECT_TRUE(fs::exists(dir.path / "out" / "particles.xdmf"));
}

// A 2D suspension (random disks, D2Q9) runs: the DEM keeps the disks in their
// plane (its z axis is no one-cell period), and the series has its statistics.
// The disks are one cell deep (mass 50 pi 4^2): their contacts need 64 DEM
// sub-steps at this stiffness.
TEST(SuspensionUnits, TwoDimensionalRandomSuspensionRuns) {
  TmpDir dir("lbdem_2d_susp");
  std::ofstream(dir.path / "case.yaml") << R"(scene: particles
units: lattice
domain: {cells: [64, 128], periodic: [1, 1]}
fluid: {tau: 0.8, collision: trt, magic: 1.0e-3}
physics: {gravity: [0, -1.0e-6, 0]}
particles: {init: random, diameter: 8, density_ratio: 50, solid_fraction: 0.1, random_speed: 1.0e-3, seed: 2}
dem: {stiffness: 20000, restitution: 0.9, substeps: 64}
psm: {fraction: table}
time: {steps: 20}
output: {directory: unused, series_interval: 10}
)";
  const auto r = run("run " + (dir.path / "case.yaml").string() + " --backend cpu --quiet --output " +
                     (dir.path / "out").string());
  ASSERT_EQ(r.code, 0) << r.out;
  const auto rows = series_without_time(dir.path / "out" / "series.csv");
  ASSERT_EQ(rows.size(), 4u);
  const auto& head = rows[0];
  const auto col = std::find(head.begin(), head.end(), "var_vx") - head.begin();
  ASSERT_LT(static_cast<std::size_t>(col), head.size());
  // 16 disks (0.1 of 64 x 128 over pi 4^2), random speeds 1e-3 in the plane: variance ~ 1e-6 / 2 per axis.
  EXPECT_GT(std::stod(rows[1][static_cast<std::size_t>(col)]), 1e-7);
  const auto z = std::find(head.begin(), head.end(), "var_vz") - head.begin();
  EXPECT_EQ(std::stod(rows[3][static_cast<std::size_t>(z)]), 0.0);
  // The fluid's balancing body force carries the disks' net weight, each
  // (50 - 1) pi 4^2 |g| (a disk one cell deep, the first paper's Table 2),
  // over the 64 x 128 cells.
  const std::string js = slurp(dir.path / "out" / "summary.json");
  const double n = summary_number(js, "particle_count");
  const auto at = js.find("\"body_force\": [");
  ASSERT_NE(at, std::string::npos) << js;
  const double fy = std::stod(js.substr(js.find(',', at) + 1));
  EXPECT_NEAR(fy, n * 49 * M_PI * 16 * 1e-6 / (64.0 * 128), 1e-12 * fy) << js;
}

TEST(SuspensionUnits, BoxNotAWholeNumberOfCellsIsRefusedNamingTheKey) {
  TmpDir dir("lbdem_si_box");
  std::string t = kSiTwin;
  t.replace(t.find("[0.03125, 0.03125, 0.03125]"), 27, "[0.03125, 0.0315, 0.03125]");
  std::ofstream(dir.path / "case.yaml") << t;
  const auto r = run("check " + (dir.path / "case.yaml").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("domain.size"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("whole number of cells"), std::string::npos) << r.out;
}

TEST(SuspensionUnits, TauAndDtTogetherAreRefused) {
  TmpDir dir("lbdem_si_taudt");
  std::string t = kSiTwin;
  t.replace(t.find("time: {steps: 30}"), 17, "time: {steps: 30, dt: 0.00048828125}");
  std::ofstream(dir.path / "case.yaml") << t;
  const auto r = run("check " + (dir.path / "case.yaml").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("fluid.tau"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("time.dt"), std::string::npos) << r.out;
}


// The production suspensions (cases/suspension/; not in the shipped-case walks
// of the key-name and fuzz tests, whose every check would place their
// thousands of particles): the reduced boxes pass `lbdem check`; the full
// sizes of the first paper pass every check but possibly the memory one (this
// machine may hold less than a GPU node): 0, or 4 naming the memory.
TEST(SuspensionCases, PaperCasesPassTheChecks) {
  for (const char* f : {"suspension_3d_small.yaml", "suspension_3d_half.yaml", "suspension_2d_small.yaml"}) {
    const auto r = run(std::string("check ") + LBDEM_SOURCE_DIR + "/cases/suspension/" + f);
    EXPECT_EQ(r.code, 0) << f << ": " << r.out;
  }
  for (const char* f : {"suspension_3d.yaml", "suspension_2d.yaml"}) {
    const auto r = run(std::string("check ") + LBDEM_SOURCE_DIR + "/cases/suspension/" + f);
    EXPECT_TRUE(r.code == 0 || (r.code == 4 && r.out.find("memory") != std::string::npos)) << f << ": " << r.out;
  }
}

}  // namespace
}  // namespace lbdem::test
