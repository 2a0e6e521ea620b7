// particles.packing: blocks through the real binary (dem/block_packing.hpp):
// a random suspension on 4 CPU ranks, each rank packing only its own piece's
// particles, starts from exactly the one-rank run's particles (ids, positions
// and velocities bit for bit in the joined snapshot of step 0), with the same
// count and fluid body force in summary.json, and no rank's snapshot piece
// holds more than its share. Without the key a case packs as before (the
// default is the one lattice over the box). Skipped without an MPI launcher.
#include <gtest/gtest.h>

#include <cmath>
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
  return (fs::temp_directory_path() / ("lbdem_blocks_" + std::to_string(::getpid()) + "_" + name)).string();
}
std::string slurp(const std::string& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}
std::string json_text(const std::string& js, const std::string& key) {
  const std::regex re("\"" + key + "\": (\\[[^\\]]*\\]|[^,}]+)");
  std::smatch m;
  return std::regex_search(js, m, re) ? std::string(m[1]) : std::string();
}

// d = 8 cells, solid fraction ~0.1 of a 40 x 96 x 40 periodic box, weight
// balanced; 4 ranks cut y into pieces of 24 cells (the ghost width 2 r + skin is 8.8).
const char* kCase =
    "scene: particles\nunits: lattice\ndomain: {cells: [40, 96, 40], periodic: [1, 1, 1]}\n"
    "fluid: {tau: 0.8, collision: trt, magic: auto, precision: fp32}\nphysics: {gravity: [0, -1.0e-6, 0]}\n"
    "particles: {init: random, packing: blocks, diameter: 8, density_ratio: 50, count: 57, random_speed: 0.002, "
    "seed: 3}\ndem: {stiffness: 50, restitution: 0.9, substeps: 10}\npsm: {fraction: table, pipeline: fused}\n"
    "time: {steps: 4}\n";

Result run_case(const std::string& name, int ranks) {
  const std::string dir = dir_of(name);
  fs::remove_all(dir);
  std::ofstream(dir + ".yaml") << kCase << "output: {directory: " << dir << ", interval: 2}\n"
                               << (ranks > 1 ? "parallel: {decomposition: [1, 4, 1]}\n" : "");
  return run_on_ranks(ranks, "run " + dir + ".yaml --backend cpu --quiet");
}

struct Particle {
  double x[3], v[3];
};

std::map<long, Particle> by_id(const std::vector<std::string>& files) {
  std::map<long, Particle> out;
  for (const auto& f : files) {
    const auto id = io::read_dataset(f, "id"), x = io::read_dataset(f, "positions"), v = io::read_dataset(f, "velocity");
    for (std::size_t i = 0; i < id.size(); ++i) {
      Particle p;
      for (std::size_t k = 0; k < 3; ++k) {
        p.x[k] = x[3 * i + k];
        p.v[k] = v[3 * i + k];
      }
      EXPECT_TRUE(out.emplace(long(id[i]), p).second) << "id " << id[i] << " twice";
    }
  }
  return out;
}

TEST(BlockPackingCase, FourRanksStartFromTheOneRankParticles) {
  if (std::string(LBDEM_MPIEXEC).empty()) GTEST_SKIP() << "built without an MPI launcher";
  const Result r1 = run_case("one", 1);
  ASSERT_EQ(r1.code, 0) << r1.out;
  const Result r4 = run_case("four", 4);
  ASSERT_EQ(r4.code, 0) << r4.out;
  const std::string d1 = dir_of("one"), d4 = dir_of("four");
  const auto a = by_id({d1 + "/particles_00000000.h5"});
  std::vector<std::string> pieces;
  for (int r = 0; r < 4; ++r) {
    pieces.push_back(d4 + "/" + io::piece_file_name("particles", 0, r, 4));
    // Each rank holds its own particles only: a quarter of the box's, within a few.
    EXPECT_LT(io::read_dataset(pieces.back(), "id").size(), 57u / 2) << pieces.back();
  }
  const auto b = by_id(pieces);
  ASSERT_EQ(a.size(), 57u);
  ASSERT_EQ(b.size(), a.size());
  for (const auto& [id, p] : a) {
    ASSERT_TRUE(b.count(id)) << "id " << id;
    EXPECT_EQ(std::memcmp(&p, &b.at(id), sizeof p), 0) << "id " << id;
  }
  // The same count, solid fraction and fluid body force (the weight balance) on any rank count.
  const std::string s1 = slurp(d1 + "/summary.json"), s4 = slurp(d4 + "/summary.json");
  for (const char* k : {"particle_count", "solid_fraction", "body_force"}) {
    EXPECT_FALSE(json_text(s1, k).empty()) << k << "\n" << s1;
    EXPECT_EQ(json_text(s1, k), json_text(s4, k)) << k;
  }
  EXPECT_EQ(json_text(s1, "particle_count"), "57");
  for (const auto& d : {d1, d4}) {
    fs::remove_all(d);
    fs::remove(d + ".yaml");
  }
}

TEST(BlockPackingCase, UnknownPackingNamesTheKey) {
  const std::string dir = dir_of("bad");
  std::string yaml = kCase;
  yaml.replace(yaml.find("packing: blocks"), 15, "packing: tiles");
  std::ofstream(dir + ".yaml") << yaml << "output: {directory: " << dir << "}\n";
  const Result r = run_on_ranks(1, "run " + dir + ".yaml --backend cpu --quiet");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("particles.packing"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("blocks"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir)) << "nothing written for a refused case";
  fs::remove(dir + ".yaml");
}

}  // namespace
}  // namespace lbdem::test
