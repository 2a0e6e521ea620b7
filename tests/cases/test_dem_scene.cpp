// The DEM case files run through the scene driver (few steps), and bad input
// is refused with a message naming the key.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cases/scenes.hpp"
#include "core/error.hpp"
#include "core/output.hpp"

using namespace lbdem;
namespace fs = std::filesystem;

namespace {
RunOptions quick(const fs::path& out, long steps) {
  RunOptions o;
  o.backend = "cpu";
  o.steps = steps;
  o.output = out.string();
  o.overwrite = true;
  o.quiet = true;
  return o;
}
}  // namespace

TEST(DemCases, AllCaseFilesRun) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(fs::path(LBDEM_SOURCE_DIR) / "cases")) {
    const std::string name = e.path().filename().string();
    if (name.rfind("dem_", 0) != 0 || e.path().extension() != ".yaml") continue;
    const fs::path out = fs::temp_directory_path() / ("lbdem_test_" + e.path().stem().string());
    const Config cfg = Config::load_file(e.path().string());
    EXPECT_EQ(run_case(cfg, quick(out, 20)), 0) << name;
    EXPECT_TRUE(fs::exists(out / "series.csv")) << name;
    EXPECT_TRUE(fs::exists(out / "particles.xdmf")) << name;
    fs::remove_all(out);
    ++n;
  }
  EXPECT_GE(n, 4);
}

// A snapshot written by one run restarts another (init: hdf5): same ids,
// positions, velocities and masses.
TEST(DemCases, RestartFromHdf5Snapshot) {
  const fs::path out = fs::temp_directory_path() / "lbdem_test_dem_restart";
  const fs::path out2 = fs::temp_directory_path() / "lbdem_test_dem_restart2";
  const Config cfg = Config::load_file((fs::path(LBDEM_SOURCE_DIR) / "cases" / "dem_03_stacked_particles.yaml").string());
  ASSERT_EQ(run_case(cfg, quick(out, 10)), 0);
  const fs::path snap = out / "particles_00000010.h5";
  ASSERT_TRUE(fs::exists(snap));
  const std::string yaml = "scene: dem\n"
                           "domain: {lo: [-2.0e-3, -1.0e-3, -2.0e-3], hi: [2.0e-3, 3.0e-3, 2.0e-3]}\n"
                           "walls: [{point: [0, 0, 0], normal: [0, 1, 0]}, {point: [0, 1.8e-3, 0], normal: [0, -1, 0]}]\n"
                           "physics: {gravity: [0, -9.80665, 0]}\n"
                           "material: {stiffness: 1.0e3, restitution: 1.0}\n"
                           "particles: {init: hdf5, file: " + snap.string() + "}\n"
                           "time: {steps: 0}\n"
                           "output: {directory: x}\n";
  ASSERT_EQ(run_case(Config::from_string(yaml), quick(out2, 0)), 0);
  const auto a = io::read_dataset(snap.string(), "positions");
  const auto b = io::read_dataset((out2 / "particles_00000000.h5").string(), "positions");
  EXPECT_EQ(a, b);
  EXPECT_EQ(io::read_dataset(snap.string(), "mass"), io::read_dataset((out2 / "particles_00000000.h5").string(), "mass"));
  fs::remove_all(out);
  fs::remove_all(out2);
}

TEST(DemCases, BadInputIsRefusedWithTheKey) {
  const std::string base = R"(scene: dem
domain: {lo: [0, 0, 0], hi: [1, 1, 1]}
physics: {gravity: [0, -9.8, 0]}
material: {stiffness: 1.0e4, restitution: 0.9}
particles: {init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}, {position: [0.5, 0.8, 0.5], radius: 0.1}]}
output: {directory: /tmp/lbdem_dem_bad}
)";
  const fs::path out = fs::temp_directory_path() / "lbdem_dem_bad";
  auto expect_error = [&](const std::string& yaml, const std::string& key) {
    try {
      run_case(Config::from_string(yaml), quick(out, 1));
      ADD_FAILURE() << "accepted: " << yaml;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  };
  expect_error(base + "time: {steps: 10, dtt: 1}\n", "dtt");                       // unknown key
  expect_error(base + "time: {steps: 10, dt: 1.0}\n", "dt");                       // dt > t_c/50
  expect_error(base + "time: {steps: 10}\nextra: 1\n", "extra");                  // unknown top-level key
  expect_error(base + "time: {steps: 10, end: 1}\n", "time.end");            // both
  expect_error(base + "time: {steps: 10}\nwalls: [{point: [0,0,0], normal: [0,0,0]}]\n", "normal");
  RunOptions v = quick(out, 1);
  v.validate_only = true;
  EXPECT_EQ(run_case(Config::from_string(base + "time: {steps: 10}\n"), v), 0);
  fs::remove_all(out);
}
