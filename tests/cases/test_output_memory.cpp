// Output and memory of a particle scene through the real binary:
//  - `lbdem check` prints the device memory by component and in total;
//  - fields written in the background (output.background: true, a host
//    thread writes while the run goes on) are the files written in the
//    foreground, slab by slab, bit for bit; float32 fields are the same
//    values rounded, in the foreground and in the background alike;
//  - summary.json lists the bytes the fluid and the coupling hold.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "core/output.hpp"
#include "run_lbdem.hpp"

namespace fs = std::filesystem;

namespace {

const char* kCase = R"(scene: particles
units: lattice
domain: {cells: [40, 26, 18], periodic: [1, 1, 1]}
fluid: {tau: 0.8, precision: fp32}
physics: {gravity: [0, -1.0e-6, 0]}
particles:
  init: list
  diameter: 7
  density_ratio: 2
  velocity: [0.002, 0.001, -0.001]
  list: [{position: [8, 8, 8]}, {position: [30, 18, 3]}, {position: [38.5, 2, 12]}]
dem: {stiffness: 50, restitution: 0.5, substeps: 10}
psm: {fraction: table}
time: {steps: 6}
)";

struct Dir {
  fs::path path;
  explicit Dir(const std::string& tag) {
    path = fs::temp_directory_path() / ("lbdem_outmem_" + tag + "_" + std::to_string(static_cast<long>(::getpid())));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Dir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

std::string write_case(const fs::path& dir, const std::string& name, const std::string& output) {
  const fs::path p = dir / name;
  std::ofstream(p) << kCase << "output: {directory: " << (dir / (name + ".out")).string() << ", " << output << "}\n";
  return p.string();
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST(ParticleOutput, CheckPrintsMemoryByComponent) {
  Dir d("check");
  const std::string c = write_case(d.path, "a.yaml", "interval: 3");
  const auto r = lbdem::test::run("check '" + c + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* part : {"device memory", "populations", "flags", "output staging", "tile lists", "total", "B/cell",
                           "scene 'particles' ok"})
    EXPECT_NE(r.out.find(part), std::string::npos) << part << "\n" << r.out;
  // fp32 D3Q19 in place: 76 B/cell of populations (rows padded to 64 cells).
  const std::size_t at = r.out.find("  populations ");
  ASSERT_NE(at, std::string::npos) << r.out;
  std::istringstream line(r.out.substr(at));
  std::string name;
  double per_cell = 0;
  line >> name >> per_cell;
  EXPECT_NEAR(per_cell, 76.0 * 18752 / 18720, 0.01) << r.out;
}

TEST(ParticleOutput, BackgroundWritesTheSameFiles) {
  Dir d("bg");
  const std::string fg = write_case(d.path, "fg.yaml", "interval: 3, background: false, field_precision: fp64");
  const std::string bg = write_case(d.path, "bg.yaml", "interval: 3, background: true, field_precision: fp64");
  const std::string f32 = write_case(d.path, "f32.yaml", "interval: 3, field_precision: storage");
  const std::string b32 = write_case(d.path, "b32.yaml", "interval: 3, background: true, field_precision: storage");
  for (const std::string& c : {fg, bg, f32, b32}) {
    const auto r = lbdem::test::run("run '" + c + "' --quiet");
    ASSERT_EQ(r.code, 0) << r.out;
  }
  const fs::path a = d.path / "fg.yaml.out", b = d.path / "bg.yaml.out", h = d.path / "f32.yaml.out",
                 hb = d.path / "b32.yaml.out";
  for (const char* step : {"00000000", "00000003", "00000006"}) {
    const std::string fa = (a / ("fields_" + std::string(step) + ".h5")).string();
    const std::string fb = (b / ("fields_" + std::string(step) + ".h5")).string();
    const std::string fh = (h / ("fields_" + std::string(step) + ".h5")).string();
    for (const char* name : {"density", "velocity", "solid_fraction"}) {
      const auto va = lbdem::io::read_dataset(fa, name);
      ASSERT_FALSE(va.empty());
      EXPECT_EQ(va, lbdem::io::read_dataset(fb, name)) << step << " " << name;
      const auto vh = lbdem::io::read_dataset(fh, name);
      ASSERT_EQ(vh.size(), va.size());
      for (std::size_t i = 0; i < va.size(); ++i) ASSERT_EQ(vh[i], double(static_cast<float>(va[i]))) << name << " " << i;
      // float32 in the background (the piece kept in float on the host): the foreground's float32 values
      EXPECT_EQ(vh, lbdem::io::read_dataset((hb / ("fields_" + std::string(step) + ".h5")).string(), name)) << step;
    }
    double solid = 0;
    for (double e : lbdem::io::read_dataset(fa, "solid_fraction")) solid += e;
    EXPECT_NEAR(solid, 3 * 4.0 / 3.0 * M_PI * 3.5 * 3.5 * 3.5, 5.0) << step;  // three spheres of d = 7
    const std::string pa = (a / ("particles_" + std::string(step) + ".h5")).string();
    const std::string pb = (b / ("particles_" + std::string(step) + ".h5")).string();
    EXPECT_EQ(lbdem::io::read_dataset(pa, "positions"), lbdem::io::read_dataset(pb, "positions")) << step;
  }
  EXPECT_EQ(slurp(a / "series.csv"), slurp(b / "series.csv"));
  const std::string sum = slurp(a / "summary.json");
  EXPECT_NE(sum.find("\"memory_bytes\": {\"populations\": "), std::string::npos) << sum;
  EXPECT_NE(sum.find("\"tile lists\""), std::string::npos) << sum;
}
