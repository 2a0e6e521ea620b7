// Snapshots in pieces through the real binary on 4 CPU ranks
// (core/piece_output.hpp): a particle suspension and a fluid scene write one
// file per rank and step holding exactly the rank's owned box (the pieces
// tile the grid once); `lbdem join` makes of them the one-rank run's file,
// bit for bit for the fluid at every step (the suspension within float32
// round-off: its per-rank sums of forces and of shared cells' solid fractions
// group their terms by the cut, tests/cases/test_mpi_particles.cpp); no
// rank's output held more than one slab of its piece (summary.json), whose
// "timing" holds every phase per rank; the manifest names every piece, so
// --overwrite by a one-rank run leaves none behind. Skipped without an MPI
// launcher.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "core/output.hpp"
#include "core/piece_output.hpp"
#include "run_lbdem.hpp"

namespace lbdem::test {
namespace {

namespace fs = std::filesystem;

std::string dir_of(const std::string& name) {
  return (fs::temp_directory_path() / ("lbdem_pieces_" + std::to_string(::getpid()) + "_" + name)).string();
}
std::string tag(long s) {
  char t[32];
  std::snprintf(t, sizeof t, "%08ld", s);
  return t;
}
std::string slurp(const std::string& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
double json_number(const std::string& js, const std::string& key) {
  const std::regex re("\"" + key + "\": ([-0-9.eE+]+)");
  std::smatch m;
  return std::regex_search(js, m, re) ? std::stod(m[1]) : -1.0;
}

const char* kSuspension =
    "scene: particles\nunits: lattice\ndomain: {cells: [24, 24, 24], periodic: [1, 1, 1]}\n"
    "fluid: {tau: 0.7, collision: trt, magic: auto, precision: fp32}\nphysics: {gravity: [0, -2.0e-5, 0]}\n"
    "particles: {init: list, diameter: 6, density_ratio: 8, velocity: [0.05, 0.04, 0.045], "
    "list: [{position: [7.3, 3.3, 7.3]}, {position: [11.3, 15.3, 7.3]}, {position: [3.3, 19.3, 19.3]}, "
    "{position: [19.3, 11.3, 7.3]}, {position: [15.3, 7.3, 11.3]}, {position: [12, 12, 12]}]}\n"
    "dem: {stiffness: 50, restitution: 0.9, substeps: 12}\npsm: {fraction: table, pipeline: mapped}\n"
    "time: {steps: 20}\n";
const char* kBox =
    "scene: periodic_box\nlattice: D3Q19\nprecision: fp32\nstreaming: aa\ncollision: {model: trt, tau: 0.6}\n"
    "fluid: {density: 1.2, kinematic_viscosity: 1.5e-5}\ndomain: {cells: [14, 12, 10], spacing: 1.0e-4}\n"
    "periodic_box: {initial_velocity: [0.1, 0.05, 0.02]}\ntime: {steps: 20}\ndiagnostics: {interval: 10}\n";

Result run_case(const std::string& name, const char* yaml, int ranks, const std::string& extra = "") {
  const std::string dir = dir_of(name);
  if (extra.empty()) fs::remove_all(dir);
  // A 2 x 2 x 1 cut on several ranks (pieces of 12 cells, thicker than the particles' ghost width).
  std::ofstream(dir + ".yaml") << yaml << "output: {directory: " << dir << ", interval: 10}\n"
                               << (ranks > 1 ? "parallel: {decomposition: [2, 2, 1]}\n" : "");
  return run_on_ranks(ranks, "run " + dir + ".yaml --backend cpu --quiet " + extra);
}

// The pieces of `step` tile the whole grid once, each holding its own box of the one-rank file's values.
void expect_pieces(const std::string& dir1, const std::string& dirn, const std::string& prefix, long step,
                   const std::vector<std::string>& fields, bool bitwise) {
  std::vector<int> seen;
  std::array<long, 3> g{};
  for (int r = 0; r < 4; ++r) {
    const std::string f = dirn + "/" + io::piece_file_name(prefix, step, r, 4);
    ASSERT_TRUE(fs::exists(f)) << f;
    const io::PieceInfo in = io::read_piece_info(f);
    g = in.global;
    if (seen.empty()) seen.assign(static_cast<std::size_t>(g[0] * g[1] * g[2]), 0);
    EXPECT_EQ(in.rank, r);
    EXPECT_EQ(in.ranks, 4);
    for (const auto& name : fields) {
      const auto whole = io::read_dataset(dir1 + "/" + prefix + "_" + tag(step) + ".h5", name);
      const auto mine = io::read_dataset(f, name);
      const std::size_t comps = whole.size() / seen.size();
      ASSERT_EQ(mine.size(), static_cast<std::size_t>(in.cells[0] * in.cells[1] * in.cells[2]) * comps) << f << " " << name;
      std::size_t k = 0;
      for (long z = 0; z < in.cells[2]; ++z)
        for (long y = 0; y < in.cells[1]; ++y)
          for (long x = 0; x < in.cells[0]; ++x) {
            const auto gi = static_cast<std::size_t>((x + in.offset[0]) + g[0] * ((y + in.offset[1]) + g[1] * (z + in.offset[2])));
            if (name == fields[0]) ++seen[gi];
            for (std::size_t c = 0; c < comps; ++c, ++k) {
              if (bitwise)
                ASSERT_EQ(std::memcmp(&mine[k], &whole[comps * gi + c], sizeof(double)), 0) << f << " " << name << " cell " << gi;
              else
                ASSERT_NEAR(mine[k], whole[comps * gi + c], 1e-6) << f << " " << name << " cell " << gi;
            }
          }
    }
  }
  for (std::size_t i = 0; i < seen.size(); ++i) ASSERT_EQ(seen[i], 1) << "cell " << i << " in " << seen[i] << " pieces";
}

void expect_joined_bitwise(const std::string& dir1, const std::string& dirn, const std::string& prefix, long step,
                           const std::vector<std::string>& fields) {
  for (const auto& name : fields) {
    const auto a = io::read_dataset(dir1 + "/" + prefix + "_" + tag(step) + ".h5", name);
    const auto b = io::read_dataset(dirn + "/" + prefix + "_" + tag(step) + ".h5", name);
    ASSERT_FALSE(a.empty()) << name;
    ASSERT_EQ(a.size(), b.size()) << name;
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0) << prefix << " " << name << " step " << step;
  }
}

TEST(MpiPieces, SuspensionPiecesJoinToOneRank) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  const Result r1 = run_case("susp1", kSuspension, 1);
  ASSERT_EQ(r1.code, 0) << r1.out;
  const Result r4 = run_case("susp4", kSuspension, 4);
  ASSERT_EQ(r4.code, 0) << r4.out;
  const std::string d1 = dir_of("susp1"), d4 = dir_of("susp4");
  // No whole file on several ranks until joined; every piece on record.
  EXPECT_FALSE(fs::exists(d4 + "/fields_" + tag(20) + ".h5"));
  const auto m = io::read_manifest(d4);
  for (long s : {0L, 10L, 20L})
    for (int r = 0; r < 4; ++r)
      for (const char* p : {"fields", "particles"})
        EXPECT_NE(std::find(m.begin(), m.end(), io::piece_file_name(p, s, r, 4)), m.end()) << p << " " << s << " " << r;
  const std::vector<std::string> fields{"density", "velocity", "solid_fraction"};
  // The solid fraction of a cell two particles share is a sum whose order
  // (owned, then ghosts) follows the cut: float32 round-off apart.
  expect_pieces(d1, d4, "fields", 0, {"density", "velocity"}, true);
  expect_pieces(d1, d4, "fields", 0, {"solid_fraction"}, false);
  expect_pieces(d1, d4, "fields", 20, fields, false);
  // fp32 storage: float32 on disk.
  EXPECT_NE(slurp(d4 + "/fields.xdmf").find("Precision=\"4\""), std::string::npos);
  // No rank held more than a slab of its piece: at most 3 values (velocity) per cell of the largest piece,
  // which is a quarter of the grid here.
  const std::string js = slurp(d4 + "/summary.json");
  const double buf = json_number(js, "largest_host_buffer_values"), piece = json_number(js, "largest_piece_cells");
  EXPECT_GT(buf, 0) << js;
  EXPECT_LE(buf, 3 * piece) << js;
  EXPECT_LE(piece, 24.0 * 24 * 24 / 4) << js;
  // Phase times per rank (summary.json "timing"): every phase and set-up
  // phase there, non-negative, max >= mean; one rank's phases together within its loop time.
  for (const char* k : {"fluid_psm", "force_reduction", "dem", "ghost_sync", "map", "exposed_communication", "packing",
                        "particle_distribution", "fluid_initial_state", "first_map"}) {
    std::string pattern = "\"";
    pattern += k;
    pattern += "\": \\{\"max\": ([-0-9.eE+]+), \"mean\": ([-0-9.eE+]+)\\}";
    const std::regex re(pattern);
    std::smatch mm;
    ASSERT_TRUE(std::regex_search(js, mm, re)) << k << "\n" << js;
    EXPECT_GE(std::stod(mm[2]), 0.0) << k;
    EXPECT_GE(std::stod(mm[1]), std::stod(mm[2])) << k;
  }
  const double loop = json_number(js, "loop_seconds"), sum = json_number(js, "phase_sum_seconds");
  EXPECT_GT(sum, 0.0) << js;
  EXPECT_LE(sum, loop) << js;
  EXPECT_GE(json_number(js, "output_fraction_of_run"), 0.0) << js;
  EXPECT_GE(json_number(js, "setup_seconds"), 0.0) << js;
  // Particles per rank: 6 particles over 4 ranks, the worst row's max at least the mean.
  const std::regex ppr("\"particles_per_rank\": \\{\"max\": ([0-9.eE+]+), \"mean\": ([0-9.eE+]+)");
  std::smatch pm;
  ASSERT_TRUE(std::regex_search(js, pm, ppr)) << js;
  EXPECT_DOUBLE_EQ(std::stod(pm[2]), 6.0 / 4.0);
  EXPECT_GE(std::stod(pm[1]), 2.0);  // 6 particles on 4 ranks: some rank owns 2 or more
  const Result j = run("join " + d4 + " --all");
  ASSERT_EQ(j.code, 0) << j.out;
  expect_joined_bitwise(d1, d4, "fields", 0, {"density", "velocity"});
  {
    const auto a = io::read_dataset(d1 + "/fields_" + tag(20) + ".h5", "solid_fraction"),
               b = io::read_dataset(d4 + "/fields_" + tag(20) + ".h5", "solid_fraction");
    ASSERT_EQ(a.size(), 24u * 24 * 24);
    ASSERT_EQ(b.size(), a.size());
    double most = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      most = std::max(most, a[i]);
      ASSERT_NEAR(a[i], b[i], 1e-6) << i;
    }
    EXPECT_GT(most, 0.99);  // cells inside a particle
  }
  // Particles: the same set (by id) with the same positions at the start.
  auto by_id = [](const std::string& f) {
    const auto id = io::read_dataset(f, "id"), x = io::read_dataset(f, "positions");
    std::map<long, std::array<double, 3>> out;
    for (std::size_t i = 0; i < id.size(); ++i) out[long(id[i])] = {x[3 * i], x[3 * i + 1], x[3 * i + 2]};
    return out;
  };
  for (long s : {0L, 20L}) {
    const auto a = by_id(d1 + "/particles_" + tag(s) + ".h5"), b = by_id(d4 + "/particles_" + tag(s) + ".h5");
    ASSERT_EQ(a.size(), 6u);
    ASSERT_EQ(b.size(), a.size()) << "step " << s;
    for (const auto& [id, x] : a)
      for (std::size_t k = 0; k < 3; ++k)
        if (s == 0) EXPECT_EQ(x[k], b.at(id)[k]);
        else EXPECT_NEAR(x[k], b.at(id)[k], 1e-9);
  }
  // --overwrite by a one-rank run removes every piece and the joined files.
  const Result again = run_case("susp4", kSuspension, 1, "--overwrite --steps 10");
  ASSERT_EQ(again.code, 0) << again.out;
  for (const auto& e : fs::directory_iterator(d4)) {
    const std::string n = e.path().filename().string();
    EXPECT_EQ(n.find("_r000"), std::string::npos) << n << " left behind";
    EXPECT_NE(n, "fields_00000020.h5");
  }
  fs::remove_all(d1);
  fs::remove_all(d4);
  fs::remove(d1 + ".yaml");
  fs::remove(d4 + ".yaml");
}

TEST(MpiPieces, FluidPiecesJoinToOneRankBitwise) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  const Result r1 = run_case("box1", kBox, 1);
  ASSERT_EQ(r1.code, 0) << r1.out;
  const Result r4 = run_case("box4", kBox, 4);
  ASSERT_EQ(r4.code, 0) << r4.out;
  const std::string d1 = dir_of("box1"), d4 = dir_of("box4");
  const std::vector<std::string> fields{"density", "velocity", "pressure", "boundary"};
  for (long s : {0L, 10L, 20L}) expect_pieces(d1, d4, "fields", s, fields, true);
  const Result j = run("join " + d4 + " --step 20");
  ASSERT_EQ(j.code, 0) << j.out;
  expect_joined_bitwise(d1, d4, "fields", 20, fields);
  EXPECT_FALSE(fs::exists(d4 + "/fields_" + tag(10) + ".h5")) << "--step joins that step only";
  const Result bad = run("join " + d4 + " --step 7");
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.out.find("--step 7"), std::string::npos) << bad.out;
  fs::remove_all(d1);
  fs::remove_all(d4);
  fs::remove(d1 + ".yaml");
  fs::remove(d4 + ".yaml");
}


// Background snapshots on 2 CPU ranks (imb/snapshot_pack.hpp: the owned box
// packed in one piece, the writer thread writing from it) write the
// foreground's pieces byte for byte: float32 and float64 files of a 3D
// suspension and float32 files of a 2D one, at every snapshot; the particle
// pieces too; summary.json splits the background time.
TEST(MpiPieces, BackgroundPiecesMatchForegroundOnTwoRanks) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  const std::string k2d =
      "scene: particles\nunits: lattice\ndomain: {cells: [40, 30], periodic: [1, 1]}\n"
      "fluid: {tau: 0.7, collision: trt, magic: auto, precision: fp32}\nphysics: {gravity: [0, -2.0e-5, 0]}\n"
      "particles: {init: list, diameter: 6, density_ratio: 8, velocity: [0.05, 0.04, 0], "
      "list: [{position: [7.3, 3.3]}, {position: [19.6, 15.3]}, {position: [31.3, 22.4]}]}\n"
      "dem: {stiffness: 50, restitution: 0.9, substeps: 12}\npsm: {fraction: table}\ntime: {steps: 20}\n";
  struct Variant {
    std::string name, yaml, fields, cut;
  };
  const std::vector<Variant> variants{{"f32", kSuspension, "storage", "[2, 1, 1]"},
                                      {"f64", kSuspension, "fp64", "[1, 2, 1]"},
                                      {"2d", k2d, "storage", "[1, 2, 1]"}};
  for (const Variant& v : variants) {
    std::string dirs[2];
    for (int bg = 0; bg < 2; ++bg) {
      const std::string dir = dir_of("bg_" + v.name + std::to_string(bg));
      fs::remove_all(dir);
      std::ofstream(dir + ".yaml") << v.yaml << "output: {directory: " << dir << ", interval: 10, field_precision: "
                                   << v.fields << ", background: " << (bg ? "true" : "false")
                                   << "}\nparallel: {decomposition: " << v.cut << "}\n";
      const Result r = run_on_ranks(2, "run " + dir + ".yaml --backend cpu --quiet");
      ASSERT_EQ(r.code, 0) << v.name << " background " << bg << "\n" << r.out;
      dirs[bg] = dir;
    }
    for (long s : {0L, 10L, 20L})
      for (int r = 0; r < 2; ++r) {
        const std::string fa = dirs[0] + "/" + io::piece_file_name("fields", s, r, 2);
        const std::string fb = dirs[1] + "/" + io::piece_file_name("fields", s, r, 2);
        for (const char* name : {"density", "velocity", "solid_fraction"}) {
          const auto a = io::read_dataset(fa, name), b = io::read_dataset(fb, name);
          ASSERT_FALSE(a.empty()) << fa << " " << name;
          ASSERT_EQ(a.size(), b.size()) << fb << " " << name;
          EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0) << fb << " " << name;
        }
        const std::string pa = dirs[0] + "/" + io::piece_file_name("particles", s, r, 2);
        const std::string pb = dirs[1] + "/" + io::piece_file_name("particles", s, r, 2);
        for (const char* name : {"id", "positions", "hydrodynamic_force"})
          EXPECT_EQ(io::read_dataset(pa, name), io::read_dataset(pb, name)) << pb << " " << name;
      }
    const std::string xa = slurp(dirs[0] + "/fields.xdmf"), xb = slurp(dirs[1] + "/fields.xdmf");
    EXPECT_EQ(xa, xb) << v.name;
    EXPECT_NE(xa.find(v.fields == "fp64" ? "Precision=\"8\"" : "Precision=\"4\""), std::string::npos) << xa;
    const std::string js = slurp(dirs[1] + "/summary.json");
    EXPECT_GE(json_number(js, "background_copy_seconds"), 0.0) << js;
    EXPECT_GT(json_number(js, "background_write_seconds"), 0.0) << js;
    // The rank's whole piece in host memory, five values a cell: no more.
    EXPECT_EQ(json_number(js, "largest_host_buffer_values"), 5 * json_number(js, "largest_piece_cells")) << js;
    for (const std::string& d : dirs) {
      fs::remove_all(d);
      fs::remove(d + ".yaml");
    }
  }
}
}  // namespace
}  // namespace lbdem::test
