// `mpirun -np N lbdem run`: fluid scenes on 2, 3 and 4 ranks (1D and 2D cuts,
// chosen and given, periodic and walled axes, both streaming schemes, both
// precisions) write the fields of the one-rank run bitwise, and one set of
// files. Refusals of decompositions that cannot work. Skipped where the
// build has no MPI launcher.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/exec.hpp"
#include "run_lbdem.hpp"

namespace lbdem::test {
namespace {

namespace fs = std::filesystem;

std::vector<double> read_dataset(const std::string& file, const std::string& name) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return {};
  const hid_t d = H5Dopen2(f, name.c_str(), H5P_DEFAULT);
  std::vector<double> v;
  if (d >= 0) {
    const hid_t sp = H5Dget_space(d);
    v.resize(static_cast<std::size_t>(H5Sget_simple_extent_npoints(sp)));
    H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Sclose(sp);
    H5Dclose(d);
  }
  H5Fclose(f);
  return v;
}

struct Case {
  std::string name;
  std::string yaml;  // without output/parallel sections
  long steps;
  int ranks;
  std::string decomposition;  // "" = chosen
  std::string backend = "cpu";  // cuda: the ranks share the GPUs there are (host-staged halos)
};

std::string dir_for(const std::string& name, int ranks) {
  return (fs::temp_directory_path() / ("lbdem_mpi_" + name + "_" + std::to_string(ranks))).string();
}

Result run_ranks(const Case& c, int ranks, const std::string& outdir) {
  fs::remove_all(outdir);
  const std::string file = outdir + ".yaml";
  const bool fields = c.yaml.find("scene: fixed_sphere") == std::string::npos;  // that scene writes a summary only
  std::ofstream(file) << c.yaml << "output: {directory: " << outdir << (fields ? ", interval: 0}\n" : "}\n")
                      << (ranks > 1 && !c.decomposition.empty() ? "parallel: {decomposition: " + c.decomposition + "}\n" : "");
  const std::string args = "run " + file + " --backend " + c.backend + " --quiet --steps " + std::to_string(c.steps);
  if (ranks == 1) return run(args);
  const Result r = test::run_on_ranks(ranks, args);
  // Several ranks write pieces (core/piece_output.hpp): joined into whole files here.
  if (r.code != 0 || !fields) return r;
  const Result j = run("join " + outdir + " --all");
  return j.code == 0 ? r : Result{j.code, r.out + j.out};
}

class MpiRuns : public ::testing::TestWithParam<Case> {};

TEST_P(MpiRuns, FieldsEqualOneRankBitwise) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  const Case c = GetParam();
  if (c.backend == "cuda" && !cuda_unavailable_reason().empty()) GTEST_SKIP() << cuda_unavailable_reason();
  const std::string d1 = dir_for(c.name, 1), dn = dir_for(c.name, c.ranks);
  const Result r1 = run_ranks(c, 1, d1);
  ASSERT_EQ(r1.code, 0) << r1.out;
  const Result rn = run_ranks(c, c.ranks, dn);
  ASSERT_EQ(rn.code, 0) << rn.out;
  char tag[32];
  std::snprintf(tag, sizeof tag, "%08ld", c.steps);
  const std::string f1 = d1 + "/fields_" + tag + ".h5", fn = dn + "/fields_" + tag + ".h5";
  ASSERT_TRUE(fs::exists(f1)) << f1;
  ASSERT_TRUE(fs::exists(fn)) << fn << "\n" << rn.out;
  for (const char* field : {"density", "velocity", "pressure"}) {
    const auto a = read_dataset(f1, field), b = read_dataset(fn, field);
    ASSERT_FALSE(a.empty()) << field;
    ASSERT_EQ(a.size(), b.size()) << field;
    for (std::size_t i = 0; i < a.size(); ++i)
      ASSERT_EQ(std::memcmp(&a[i], &b[i], sizeof(double)), 0) << field << "[" << i << "]: " << a[i] << " vs " << b[i];
  }
  // One set of files, written once; the summary names the ranks.
  std::ifstream js(dn + "/summary.json");
  const std::string summary((std::istreambuf_iterator<char>(js)), std::istreambuf_iterator<char>());
  EXPECT_NE(summary.find("\"ranks\": " + std::to_string(c.ranks)), std::string::npos) << summary;
  fs::remove_all(d1);
  fs::remove_all(dn);
  fs::remove(d1 + ".yaml");
  fs::remove(dn + ".yaml");
}

const char* kTaylorGreen2d =
    "scene: taylor_green\nlattice: D2Q9\nprecision: fp64\ncollision: {model: bgk, tau: 0.8}\n"
    "fluid: {density: 1.0, kinematic_viscosity: 1.0e-6}\ndomain: {cells: [20, 20], spacing: 1.5625e-5}\n"
    "taylor_green: {velocity: 1.0e-3}\ntime: {steps: 10}\ndiagnostics: {interval: 7}\n";
const char* kChannel =
    "scene: channel\nlattice: D2Q9\nprecision: fp64\nstreaming: two_lattice\ncollision: {model: trt, tau: 0.8}\n"
    "fluid: {density: 1.2, kinematic_viscosity: 1.5e-5}\ndomain: {cells: [8, 18], spacing: 3.125e-5}\n"
    "channel: {mode: periodic, body_acceleration: 5.0}\ntime: {steps: 10}\ndiagnostics: {interval: 5}\n";
const char* kCavity =
    "scene: lid_driven_cavity\nlattice: D2Q9\nprecision: fp32\ncollision: {model: trt, tau: 0.6}\n"
    "fluid: {density: 1.0, kinematic_viscosity: 1.0e-4}\ndomain: {cells: [20, 22], spacing: 7.8125e-5}\n"
    "lid_driven_cavity: {lid_velocity: 1.0}\ntime: {steps: 10}\ndiagnostics: {interval: 10}\n";
const char* kTaylorGreen3d =
    "scene: taylor_green\nlattice: D3Q19\nprecision: fp32\nstreaming: aa\ncollision: {model: trt, tau: 0.8}\n"
    "fluid: {density: 1.0, kinematic_viscosity: 1.0e-6}\ndomain: {cells: [12, 12, 12], spacing: 1.5625e-5}\n"
    "taylor_green: {velocity: 1.0e-3}\ntime: {steps: 10}\ndiagnostics: {interval: 4}\n";
const char* kBox =
    "scene: periodic_box\nlattice: D3Q19\nprecision: fp64\nstreaming: two_lattice\ncollision: {model: bgk, tau: 0.6}\n"
    "fluid: {density: 1.2, kinematic_viscosity: 1.5e-5}\ndomain: {cells: [10, 9, 8], spacing: 1.0e-4}\n"
    "periodic_box: {initial_velocity: [0.1, 0.05, 0.0]}\ntime: {steps: 10}\ndiagnostics: {interval: 10}\n";

INSTANTIATE_TEST_SUITE_P(
    Cases, MpiRuns,
    ::testing::Values(Case{"tg2d_2", kTaylorGreen2d, 11, 2, ""}, Case{"tg2d_4", kTaylorGreen2d, 11, 4, "[2, 2, 1]"},
                      Case{"channel_3", kChannel, 9, 3, "[1, 3, 1]"}, Case{"channel_2x", kChannel, 9, 2, "[2, 1, 1]"},
                      Case{"cavity_4", kCavity, 9, 4, "[2, 2, 1]"}, Case{"tg3d_2z", kTaylorGreen3d, 7, 2, "[1, 1, 2]"},
                      Case{"tg3d_4", kTaylorGreen3d, 8, 4, "[1, 2, 2]"}, Case{"box_3", kBox, 6, 3, ""},
                      // The GPU path end to end: streams, pinned staging, ranks sharing a GPU.
                      Case{"gpu_tg3d_2", kTaylorGreen3d, 9, 2, "[2, 1, 1]", "cuda"},
                      Case{"gpu_channel_3", kChannel, 9, 3, "[1, 3, 1]", "cuda"},
                      Case{"gpu_box_4", kBox, 7, 4, "[2, 1, 2]", "cuda"}),
    [](const ::testing::TestParamInfo<Case>& i) { return i.param.name; });

TEST(MpiRunsRefused, DecompositionThatCannotWork) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  // Ranks per axis whose product is not the rank count, and a cut thinner than two cells.
  for (const std::string d : {"[3, 1, 1]", "[1, 1, 5]"}) {
    Case c{"refused", kBox, 5, 2, d};
    if (d == "[1, 1, 5]") c.ranks = 5;  // 8 cells along z: fewer than 2 per rank
    const std::string dn = dir_for("refused", c.ranks);
    const Result r = run_ranks(c, c.ranks, dn);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find("parallel.decomposition"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(dn + "/summary.json"));
    fs::remove_all(dn);
    fs::remove(dn + ".yaml");
  }
}

}  // namespace
}  // namespace lbdem::test

namespace lbdem::test {
namespace {
// The fixed-sphere array on 2 and 4 ranks (the sphere across the cuts; forces
// and mean velocity summed over ranks): the drag coefficient of the one-rank
// run to round-off (the sums over cells are grouped by rank).
double summary_number(const std::string& file, const std::string& key) {
  std::ifstream in(file);
  const std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto at = s.find("\"" + key + "\": ");
  if (at == std::string::npos) return std::nan("");
  return std::stod(s.substr(at + key.size() + 4));
}

TEST(MpiRuns, FixedSphereDragEqualsOneRank) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  const std::string yaml =
      "scene: fixed_sphere\nunits: lattice\ngeometry: {dim: 3, diameter: 6, chi: 0.5, offset: 0.5}\n"
      "fluid: {tau: 0.6, collision: trt, magic: 1.0e-4, precision: fp64, re_p: 0.2}\n"
      "psm: {fraction: table, operator: nebb, weight: noble_torczynski, slots: 4}\n"
      "steady: {tolerance: 1.0e-5, max_steps: 200}\n";
  double K1 = 0;
  for (const auto& [ranks, dims] : std::vector<std::pair<int, std::string>>{{1, ""}, {2, "[2, 1, 1]"}, {4, "[1, 2, 2]"}}) {
    Case c{"fixed_sphere", yaml, 200, ranks, dims};
    const std::string d = dir_for("fixed_sphere", ranks);
    // Not converged in 200 steps: exit 1 by design; the summary is written.
    const Result r = run_ranks(c, ranks, d);
    ASSERT_TRUE(r.code == 0 || r.code == 1) << r.out;
    const double K = summary_number(d + "/summary.json", "K");
    ASSERT_TRUE(std::isfinite(K)) << r.out;
    if (ranks == 1) K1 = K;
    else EXPECT_NEAR(K, K1, 1e-11 * std::abs(K1)) << ranks << " ranks";
    EXPECT_EQ(summary_number(d + "/summary.json", "ranks"), ranks);
    std::filesystem::remove_all(d);
    std::filesystem::remove(d + ".yaml");
  }
}
}  // namespace
}  // namespace lbdem::test
