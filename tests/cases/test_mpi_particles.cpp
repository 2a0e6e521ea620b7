// `mpirun -np N lbdem run` of the coupled `particles` scene (PSM fluid + DEM
// particles, imb/coupled.hpp): a periodic suspension with friction and a
// balanced weight, 24^3 cells, particles of 6 cells drifting across the cuts
// and through the periodic faces, on 2, 3 and 4 ranks with 1D and 2D cuts
// (and a 3D cut on 8 ranks), fp64 and fp32 storage, the mapped pipeline
// (the deterministic path). Each run writes one set of files, and its fields
// and particle states (by global id) agree with the one-rank run's within
// 1e-12 of each quantity's largest magnitude: the hydrodynamic force of a
// particle whose cells lie on several ranks is the sum of per-rank shares, a
// grouping of the sum that differs from the one-rank gather in the last bits
// (imb/coupled.hpp). The test checks that particles did cross cut faces,
// periodic ones included. Also: ranks that hold no particle, refusals (a
// piece thinner than the ghost width, checkpoints), and the GPU path (ranks
// sharing the GPUs there are; skipped without one). Skipped where the build
// has no MPI launcher.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/exec.hpp"
#include "core/output.hpp"
#include "run_lbdem.hpp"

namespace lbdem::test {
namespace {

namespace fs = std::filesystem;

// A dataset of an output file (io::read_dataset); empty where the file or the
// dataset is missing, so that the size assertions say what is wrong.
std::vector<double> dataset(const std::string& file, const std::string& name) {
  try {
    return io::read_dataset(file, name);
  } catch (const std::exception&) {
    return {};
  }
}

constexpr long kSteps = 40;

// 20 particles of diameter 6: on every axis some 0.7 cells below 8, 12, 16
// and 24 (the cuts of 2 and 3 pieces and the periodic face), drifting up
// every axis by more than that over the run; two start 0.1-0.3 cells from a
// neighbour (contacts with friction).
const std::string kList =
    "{position: [7.3, 3.3, 7.3]}, {position: [11.3, 3.3, 15.3]}, {position: [3.3, 19.3, 7.3]}, "
    "{position: [11.3, 15.3, 7.3]}, {position: [7.3, 23.3, 23.3]}, {position: [3.3, 19.3, 19.3]}, "
    "{position: [23.3, 3.3, 15.3]}, {position: [3.3, 7.3, 19.3]}, {position: [15.3, 3.3, 3.3]}, "
    "{position: [15.3, 11.3, 23.3]}, {position: [19.3, 23.3, 11.3]}, {position: [19.3, 15.3, 15.3]}, "
    "{position: [23.3, 11.3, 23.3]}, {position: [19.3, 11.3, 7.3]}, {position: [7.3, 11.3, 23.3]}, "
    "{position: [3.3, 11.3, 11.3]}, {position: [3.3, 7.3, 3.3]}, {position: [15.3, 7.3, 11.3]}, "
    "{position: [4.1, 16.1, 2]}, {position: [5.2, 5.4, 12.8]}";

std::string yaml(const std::string& precision) {
  return "scene: particles\nunits: lattice\n"
         "domain: {cells: [24, 24, 24], periodic: [1, 1, 1]}\n"
         "fluid: {tau: 0.7, collision: trt, magic: auto, precision: " + precision + "}\n"
         "physics: {gravity: [0, -2.0e-5, 0]}\n"
         "particles: {init: list, diameter: 6, density_ratio: 8, seed: 3, velocity: [0.05, 0.04, 0.045], "
         "random_speed: 0.01, list: [" + kList + "]}\n"
         "dem: {stiffness: 50, restitution: 0.9, friction: 0.3, substeps: 12}\n"
         "psm: {fraction: table, pipeline: mapped}\n"
         "time: {steps: " + std::to_string(kSteps) + "}\n";
}

// Per test process: ctest runs the cuts side by side, each with its own one-rank reference.
std::string run_dir(const std::string& name) {
  return (fs::temp_directory_path() / ("lbdem_mpi_particles_" + std::to_string(::getpid()) + "_" + name)).string();
}

// One run on `ranks` ranks (one rank: without mpirun), output every kSteps.
Result run_case(const std::string& name, const std::string& precision, int ranks, const std::string& dims,
                const std::string& text = "", const std::string& backend = "cpu") {
  const std::string dir = run_dir(name);
  fs::remove_all(dir);
  const std::string file = dir + ".yaml";
  std::ofstream(file) << (text.empty() ? yaml(precision) : text) << "output: {directory: " << dir << ", interval: " << kSteps
                      << ", series_interval: 20, field_precision: fp64}\n"
                      << (dims.empty() ? "" : "parallel: {decomposition: " + dims + "}\n");
  // One OpenMP thread per rank (one rank: without mpirun): the runs share two cores.
  const std::string args = "run " + file + " --backend " + backend + " --quiet";
  const Result r = test::run_on_ranks(ranks, args);
  // Several ranks write their pieces (core/piece_output.hpp): joined here
  // into the whole files the comparisons read.
  if (r.code != 0 || ranks == 1) return r;
  const Result j = test::run("join " + dir + " --all");
  return j.code == 0 ? r : Result{j.code, r.out + j.out};
}

std::string tag(long step) {
  char t[32];
  std::snprintf(t, sizeof t, "%08ld", step);
  return t;
}

// Per-particle values of a snapshot keyed by global id.
std::map<long, std::vector<double>> by_id(const std::string& file, const std::string& field, int comps) {
  const auto id = dataset(file, "id"), v = dataset(file, field);
  std::map<long, std::vector<double>> m;
  if (v.size() != id.size() * static_cast<std::size_t>(comps)) return m;
  for (std::size_t i = 0; i < id.size(); ++i)
    m[std::lround(id[i])] = std::vector<double>(v.begin() + static_cast<long>(i) * comps,
                                                v.begin() + static_cast<long>(i + 1) * comps);
  return m;
}

double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

struct Cut {
  std::string name;
  std::string precision;
  int ranks;
  std::string dims;  // ranks per axis, as the case file gives them
  std::array<int, 3> d;
  std::string backend = "cpu";  // cuda: the ranks share the GPUs there are (host-staged exchanges)
};

class MpiParticles : public ::testing::TestWithParam<Cut> {};

TEST_P(MpiParticles, StatesAndFieldsEqualOneRank) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  const Cut c = GetParam();
  if (c.backend == "cuda" && !cuda_unavailable_reason().empty()) GTEST_SKIP() << cuda_unavailable_reason();
  const std::string one = "one_" + c.backend + "_" + c.precision, many = c.name;
  static std::set<std::string> done;  // the one-rank run of each precision, once
  if (!done.count(one)) {
    const Result r1 = run_case(one, c.precision, 1, "", "", c.backend);
    ASSERT_EQ(r1.code, 0) << r1.out;
    done.insert(one);
  }
  const Result rn = run_case(many, c.precision, c.ranks, c.dims, "", c.backend);
  ASSERT_EQ(rn.code, 0) << rn.out;
  const std::string d1 = run_dir(one), dn = run_dir(many);
  // The GPU's fp32 kernels sum a cell's slots in float (several particles in
  // one cell are summed in their storage order, which the cut changes): a
  // float round-off there, as in tests/imb/test_psm_halo.cpp.
  const double rel = c.backend == "cuda" && c.precision == "fp32" ? 1e-6 : 1e-12;
  // Fields: density, velocity and solid fraction of every cell.
  const std::string f1 = d1 + "/fields_" + tag(kSteps) + ".h5", fn = dn + "/fields_" + tag(kSteps) + ".h5";
  for (const char* field : {"density", "velocity", "solid_fraction"}) {
    const auto a = dataset(f1, field), b = dataset(fn, field);
    ASSERT_EQ(a.size(), 24u * 24u * 24u * (std::string(field) == "velocity" ? 3u : 1u)) << field;
    ASSERT_EQ(a.size(), b.size()) << field;
    const double tol = rel * max_abs(a);
    ASSERT_GT(max_abs(a), 0.0) << field;
    for (std::size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a[i], b[i], tol) << field << "[" << i << "]";
  }
  // Particles: the same ids, states and hydrodynamic forces.
  const std::string p1 = d1 + "/particles_" + tag(kSteps) + ".h5", pn = dn + "/particles_" + tag(kSteps) + ".h5";
  for (const auto& [field, comps] : std::vector<std::pair<std::string, int>>{
           {"positions", 3}, {"velocity", 3}, {"angular_velocity", 3}, {"hydrodynamic_force", 3}}) {
    const auto a = by_id(p1, field, comps), b = by_id(pn, field, comps);
    ASSERT_EQ(a.size(), 20u) << field;
    ASSERT_EQ(b.size(), a.size()) << field << ": particles lost or duplicated";
    double scale = 0;
    for (const auto& [id, v] : a) scale = std::max(scale, max_abs(v));
    ASSERT_GT(scale, 0.0) << field;
    for (const auto& [id, v] : a) {
      ASSERT_TRUE(b.count(id)) << "particle " << id << " missing";
      for (int k = 0; k < comps; ++k)
        EXPECT_NEAR(v[static_cast<std::size_t>(k)], b.at(id)[static_cast<std::size_t>(k)], rel * scale)
            << field << " of particle " << id << " component " << k;
    }
  }
  // The particles crossed cuts, through periodic faces too: the piece of each
  // centre (the cut splits each axis evenly) at the start and the end.
  const auto x0 = by_id(d1 + "/particles_" + tag(0) + ".h5", "positions", 3);
  const auto x1 = by_id(p1, "positions", 3);
  ASSERT_EQ(x0.size(), x1.size());
  int moved = 0, wrapped = 0;
  for (const auto& [id, a] : x0) {
    const auto& b = x1.at(id);
    bool changed = false;
    for (int k = 0; k < 3; ++k) {
      const double s = 24.0 / c.d[static_cast<std::size_t>(k)];
      const auto piece = [&](double x) { return static_cast<int>(std::floor((x - 24 * std::floor(x / 24)) / s)); };
      if (piece(a[static_cast<std::size_t>(k)]) != piece(b[static_cast<std::size_t>(k)])) {
        changed = true;
        // Drifting up every axis: a lower piece index at the end means the centre wrapped.
        if (c.d[static_cast<std::size_t>(k)] > 1 && piece(b[static_cast<std::size_t>(k)]) < piece(a[static_cast<std::size_t>(k)]))
          ++wrapped;
      }
    }
    moved += changed ? 1 : 0;
  }
  EXPECT_GE(moved, 2) << "too few particles changed rank: the test would not test migration";
  EXPECT_GE(wrapped, 1) << "no particle crossed a periodic face that is a cut";
  // One set of files; the summary names the ranks and counts every particle.
  std::ifstream js(dn + "/summary.json");
  const std::string summary((std::istreambuf_iterator<char>(js)), std::istreambuf_iterator<char>());
  EXPECT_NE(summary.find("\"ranks\": " + std::to_string(c.ranks)), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"particles\": 20,"), std::string::npos) << summary;
  EXPECT_TRUE(fs::exists(dn + "/series.csv"));
  fs::remove_all(dn);
  fs::remove(dn + ".yaml");
}

INSTANTIATE_TEST_SUITE_P(
    Cuts, MpiParticles,
    ::testing::Values(Cut{"x2_fp64", "fp64", 2, "[2, 1, 1]", {2, 1, 1}}, Cut{"y3_fp64", "fp64", 3, "[1, 3, 1]", {1, 3, 1}},
                      Cut{"xz4_fp64", "fp64", 4, "[2, 1, 2]", {2, 1, 2}}, Cut{"xyz8_fp64", "fp64", 8, "[2, 2, 2]", {2, 2, 2}},
                      Cut{"z2_fp32", "fp32", 2, "[1, 1, 2]", {1, 1, 2}}, Cut{"xy4_fp32", "fp32", 4, "[2, 2, 1]", {2, 2, 1}},
                      // The GPU path end to end (one GPU per rank, or ranks sharing one).
                      Cut{"gpu_x2_fp64", "fp64", 2, "[2, 1, 1]", {2, 1, 1}, "cuda"},
                      Cut{"gpu_xy4_fp32", "fp32", 4, "[2, 2, 1]", {2, 2, 1}, "cuda"}),
    [](const ::testing::TestParamInfo<Cut>& i) { return i.param.name; });

// One particle on three ranks along x (pieces of 16 cells): the two outer
// ranks hold neither it nor a ghost of it and step plain fluid; the run
// still agrees with one rank.
TEST(MpiParticlesEmpty, RanksWithoutParticles) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  const std::string text =
      "scene: particles\nunits: lattice\ndomain: {cells: [48, 16, 16], periodic: [1, 1, 1]}\n"
      "fluid: {tau: 0.7, collision: trt, magic: auto, precision: fp64}\nphysics: {gravity: [0, -2.0e-5, 0]}\n"
      "particles: {init: list, diameter: 6, density_ratio: 4, velocity: [0.03, 0.0, 0.0], "
      "list: [{position: [24.5, 8, 8]}]}\n"
      "dem: {stiffness: 50, restitution: 0.9, substeps: 12}\npsm: {fraction: table, pipeline: mapped}\n"
      "time: {steps: " + std::to_string(kSteps) + "}\n";
  const Result r1 = run_case("empty_1", "fp64", 1, "", text);
  ASSERT_EQ(r1.code, 0) << r1.out;
  const Result r3 = run_case("empty_3", "fp64", 3, "[3, 1, 1]", text);
  ASSERT_EQ(r3.code, 0) << r3.out;
  const std::string f1 = run_dir("empty_1") + "/fields_" + tag(kSteps) + ".h5",
                    f3 = run_dir("empty_3") + "/fields_" + tag(kSteps) + ".h5";
  for (const char* field : {"density", "velocity", "solid_fraction"}) {
    const auto a = dataset(f1, field), b = dataset(f3, field);
    ASSERT_FALSE(a.empty()) << field;
    ASSERT_EQ(a.size(), b.size()) << field;
    for (std::size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(a[i], b[i], 1e-12 * max_abs(a)) << field << "[" << i << "]";
  }
  const auto x1 = by_id(run_dir("empty_1") + "/particles_" + tag(kSteps) + ".h5", "positions", 3),
             x3 = by_id(run_dir("empty_3") + "/particles_" + tag(kSteps) + ".h5", "positions", 3);
  ASSERT_EQ(x1.size(), 1u);
  ASSERT_EQ(x3.size(), 1u);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(x1.at(0)[k], x3.at(0)[k], 1e-12 * 48);
  EXPECT_GT(x1.at(0)[0], 25.0);  // it moved along x (within the middle piece)
  for (const char* n : {"empty_1", "empty_3"}) {
    fs::remove_all(run_dir(n));
    fs::remove(run_dir(n) + ".yaml");
  }
}

// A cut whose pieces are thinner than the particles' ghost width is refused
// before anything is written, naming the key.
TEST(MpiParticlesRefused, PieceThinnerThanGhostWidth) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  const Result r = run_case("thin", "fp64", 4, "[4, 1, 1]");  // 6 cells per piece < 2 r + skin = 6.6
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("parallel.decomposition"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ghost width"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(run_dir("thin") + "/summary.json"));
  fs::remove_all(run_dir("thin"));
  fs::remove(run_dir("thin") + ".yaml");
  // A checkpoint section on several ranks writes one checkpoint (restarts:
  // test_mpi_restart.cpp).
  const Result ck = run_case("ckpt", "fp64", 2, "[2, 1, 1]", yaml("fp64") + "checkpoint: {interval: 20}\n");
  EXPECT_EQ(ck.code, 0) << ck.out;
  EXPECT_TRUE(fs::exists(run_dir("ckpt") + "/checkpoint.lbdem")) << ck.out;
  fs::remove_all(run_dir("ckpt"));
  fs::remove(run_dir("ckpt") + ".yaml");
}


// psm.wall_lubrication on several ranks: each rank adds the wall gap
// correction to the particles it owns (no gather), after the ranks' shares
// of the hydrodynamic force are summed. Five spheres of d/l 6 in a box
// closed along y (walls at y = 1 and 25), two near the floor and two near the
// ceiling, moving down, one on the y cut; on 2 ranks cut along y (the floor's
// spheres on one rank, the ceiling's on the other) and along x, the states
// and forces agree with one rank within 1e-12, and the correction is there
// (the one-rank run without it differs).
TEST(MpiParticlesWallLubrication, RanksAgreeWithOneRank) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  auto text = [](const std::string& wl) {
    return "scene: particles\nunits: lattice\ndomain: {cells: [16, 24, 16], periodic: [1, 0, 1]}\n"
           "fluid: {tau: 0.8, collision: trt, magic: auto, precision: fp64}\nphysics: {gravity: [0, -1.0e-5, 0]}\n"
           "particles: {init: list, diameter: 6, density_ratio: 2, velocity: [0, -0.002, 0], "
           "list: [{position: [4, 5.5, 4]}, {position: [12, 6.0, 12]}, {position: [4, 20.5, 12]}, "
           "{position: [12, 20, 4]}, {position: [8, 13, 8]}]}\n"
           "dem: {stiffness: 20, restitution: 0.5, substeps: 12}\npsm: {pipeline: mapped, wall_lubrication: " + wl +
           "}\ntime: {steps: " + std::to_string(kSteps) + "}\n";
  };
  const std::vector<std::pair<std::string, Result>> runs = {
      {"wl_1", run_case("wl_1", "fp64", 1, "", text("on"))},
      {"wl_off", run_case("wl_off", "fp64", 1, "", text("off"))},
      {"wl_y2", run_case("wl_y2", "fp64", 2, "[1, 2, 1]", text("on"))},
      {"wl_x2", run_case("wl_x2", "fp64", 2, "[2, 1, 1]", text("on"))}};
  for (const auto& [n, r] : runs) ASSERT_EQ(r.code, 0) << n << "\n" << r.out;
  auto particles = [](const std::string& n, const std::string& field) {
    return by_id(run_dir(n) + "/particles_" + tag(kSteps) + ".h5", field, 3);
  };
  for (const char* field : {"positions", "velocity", "hydrodynamic_force"}) {
    const auto a = particles("wl_1", field);
    ASSERT_EQ(a.size(), 5u) << field;
    double scale = 0;
    for (const auto& [id, v] : a) scale = std::max(scale, max_abs(v));
    for (const char* many : {"wl_y2", "wl_x2"}) {
      const auto b = particles(many, field);
      ASSERT_EQ(b.size(), a.size()) << many << " " << field;
      for (const auto& [id, v] : a)
        for (std::size_t k = 0; k < 3; ++k)
          EXPECT_NEAR(v[k], b.at(id)[k], 1e-12 * scale) << many << " " << field << " of particle " << id << " [" << k << "]";
    }
  }
  // The four spheres near a wall feel the correction (their y force differs
  // from the run without it by far more than round-off); the middle one's
  // only through the flow.
  const auto on = particles("wl_1", "hydrodynamic_force"), off = particles("wl_off", "hydrodynamic_force");
  ASSERT_EQ(off.size(), 5u);
  int corrected = 0;
  for (const auto& [id, v] : on) corrected += std::abs(v[1] - off.at(id)[1]) > 1e-3 * std::abs(off.at(id)[1]);
  EXPECT_GE(corrected, 4);
  for (const auto& [n, r] : runs) {
    fs::remove_all(run_dir(n));
    fs::remove(run_dir(n) + ".yaml");
  }
}

}  // namespace
}  // namespace lbdem::test
