// The fluidized_bed scene (cases/src/cfd_case.cpp) through lbdem::run_case on
// the host backend, with the shipped case files:
//  * DEM06 (cases/fluidized_bed_dem06.yaml): the particle velocity of the
//    series against the reference curve of the settling ODE within 0.1 %
//    (REFERENCES: v(0.01 s) = -0.01255261, v(0.10 s) = -0.05263133,
//    v(0.35 s) = -0.05739251 m/s); the first point alone is a quick test.
//  * the small bed (cases/fluidized_bed_small.yaml): a short run writes its
//    outputs, the gas mass balance closes, the pressure drop is finite; the
//    watchdog stops a run whose Courant number passes its limit.
//  * fluidized at 0.27 m/s (about 1.1 U_mf, uniform expansion), the
//    time-averaged pressure drop equals the bed's buoyant weight per area
//    within 2 % (long); the fixed bed below U_mf gives U_mf within 15 % of
//    Ergun's prediction (long).
//  * bad inputs: each refusal names the key as the case file writes it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "cases/scenes.hpp"
#include "core/config.hpp"
#include "core/error.hpp"

namespace {

namespace fs = std::filesystem;
using namespace lbdem;

std::string case_path(const std::string& name) { return std::string(LBDEM_SOURCE_DIR) + "/cases/" + name; }

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Replaces the first occurrence of `from` (which must be there).
std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "'" << from << "' not in the case file";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// series.csv as columns by name.
std::map<std::string, std::vector<double>> read_series(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> names;
  {
    std::stringstream s(line);
    std::string n;
    while (std::getline(s, n, ',')) names.push_back(n);
  }
  std::map<std::string, std::vector<double>> cols;
  while (std::getline(in, line)) {
    std::stringstream s(line);
    std::string v;
    for (std::size_t k = 0; k < names.size() && std::getline(s, v, ','); ++k) cols[names[k]].push_back(std::stod(v));
  }
  return cols;
}

class CfdScene : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lbdem_cfd_scene_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  int run_text(const std::string& text, std::optional<long> steps = std::nullopt) {
    const Config cfg = Config::from_string(text, "case.yaml");
    RunOptions opt;
    opt.backend = "cpu";
    opt.quiet = true;
    opt.output = dir_.string();
    opt.overwrite = true;
    opt.steps = steps;
    return run_case(cfg, opt);
  }
  // The message of the ConfigError a check of `text` throws ("" if none).
  static std::string refusal(const std::string& text) {
    try {
      const Config cfg = Config::from_string(text, "case.yaml");
      RunOptions opt;
      opt.backend = "cpu";
      opt.quiet = true;
      opt.validate_only = true;
      run_case(cfg, opt);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

void expect_dem06(const std::map<std::string, std::vector<double>>& s, double t, double v_ref) {
  const auto& time = s.at("time");
  const auto& vz = s.at("vz_0");
  for (std::size_t i = 0; i < time.size(); ++i) {
    if (std::fabs(time[i] - t) > 1e-9) continue;
    EXPECT_NEAR(vz[i], v_ref, 1e-3 * std::fabs(v_ref)) << "t = " << t;
    std::printf("t %.2f s: v %.8f (reference %.8f) m/s, relative error %.2e\n", t, vz[i], v_ref,
                std::fabs(vz[i] / v_ref - 1));
    return;
  }
  ADD_FAILURE() << "no series row at t = " << t;
}

TEST_F(CfdScene, Dem06FirstPointWithinTenthOfAPercent) {
  ASSERT_EQ(run_text(read_text(case_path("fluidized_bed_dem06.yaml")), 200), 0);
  const auto s = read_series((dir_ / "series.csv").string());
  expect_dem06(s, 0.01, -0.01255261);
}

TEST_F(CfdScene, Dem06WholeCurveWithinTenthOfAPercent) {
  ASSERT_EQ(run_text(read_text(case_path("fluidized_bed_dem06.yaml"))), 0);
  const auto s = read_series((dir_ / "series.csv").string());
  expect_dem06(s, 0.01, -0.01255261);
  expect_dem06(s, 0.10, -0.05263133);
  expect_dem06(s, 0.35, -0.05739251);
  // One particle in the gas: the pressure drop is its buoyant weight per area.
  EXPECT_NEAR(s.at("pressure_drop_over_weight").back(), 1.0, 1e-3);
}

TEST_F(CfdScene, SmallBedWritesItsOutputAndBalancesTheGas) {
  const std::string text = replaced(read_text(case_path("fluidized_bed_small.yaml")), "statistics: {start: 0.3",
                                    "statistics: {start: 0.002");
  ASSERT_EQ(run_text(text, 30), 0);
  for (const char* f : {"series.csv", "summary.json", "gas.xdmf", "particles.xdmf"})
    EXPECT_TRUE(fs::exists(dir_ / f)) << f;
  const auto s = read_series((dir_ / "series.csv").string());
  ASSERT_GE(s.at("step").size(), 2u);
  for (std::size_t i = 1; i < s.at("step").size(); ++i) {
    // Continuity holds to the pressure solver's tolerance.
    EXPECT_LT(std::fabs(s.at("mass_imbalance")[i]), 1e-8);
    EXPECT_NEAR(s.at("gas_inflow")[i], 1.225 * 0.27 * 4e-3 * 4e-3, 1e-12);
    EXPECT_TRUE(std::isfinite(s.at("pressure_drop")[i]));
    EXPECT_GT(s.at("pressure_drop")[i], 0);
    EXPECT_LT(s.at("max_courant")[i], 0.5);
  }
  const std::string summary = read_text((dir_ / "summary.json").string());
  EXPECT_NE(summary.find("\"scene\": \"fluidized_bed\""), std::string::npos);
  EXPECT_NE(summary.find("\"particles\": 190"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"interrupted\": false"), std::string::npos);
  EXPECT_EQ(summary.find("\"statistics_samples\": 0,"), std::string::npos) << summary;
  // One rank, the particle path: every sub-step but the first of each gas step runs fused (the default).
  EXPECT_NE(summary.find("\"dem_fused_steps\": "), std::string::npos) << summary;
  EXPECT_EQ(summary.find("\"dem_fused_steps\": 0,"), std::string::npos) << summary;
}

TEST_F(CfdScene, WatchdogStopsAtTheCourantLimitNamingTheKeys) {
  std::string text = replaced(read_text(case_path("fluidized_bed_small.yaml")), "max_courant: 0.5", "max_courant: 0.01");
  text = replaced(text, "check_interval: 100", "check_interval: 10");
  try {
    run_text(text, 40);
    ADD_FAILURE() << "no DivergenceError";
  } catch (const DivergenceError& e) {
    const std::string m = e.what();
    for (const char* k : {"diagnostics.max_courant", "gas.dt", "gas.cell_size", "Courant"})
      EXPECT_NE(m.find(k), std::string::npos) << k << " not in: " << m;
  }
  // The run's files up to the stop, with the diagnosis.
  const std::string summary = read_text((dir_ / "summary.json").string());
  EXPECT_NE(summary.find("\"diverged\": \"case.yaml: the largest Courant number"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"gas_steps\": 10,"), std::string::npos) << summary;
}

TEST_F(CfdScene, BadInputsNameTheirKeys) {
  const std::string base = read_text(case_path("fluidized_bed_small.yaml"));
  ASSERT_EQ(refusal(base), "");
  struct Bad {
    std::string from, to, key;
  };
  const std::vector<Bad> bad = {
      {"cell_size: 4.0e-3", "cell_size: 3.0e-3", "gas.cell_size"},         // does not divide the box
      {"cell_size: 4.0e-3", "cell_size: 1.0e-3", "gas.cell_size"},         // smaller than a particle
      {"drag: gidaspow", "drag: stokes", "gas.drag"},
      {"void_fraction: linear", "void_fraction: smooth", "gas.void_fraction"},
      {"dt: 2.0e-4", "dt: 1.0e-2", "gas.dt"},                               // Courant number of the inflow
      {"density: 1.225", "density: -1", "gas.density"},
      {"viscosity: 1.8e-5", "visocity: 1.8e-5", "visocity"},
      {"z_hi: {type: outlet, pressure: 0}", "z_hi: {type: no_slip}", "gas.boundaries"},
      {"x_hi: {type: periodic}", "x_hi: {type: no_slip}", "gas.boundaries.x_hi"},
      {"z_lo: {type: inlet, velocity: 0.27}", "z_lo: {type: inlet, velocity: -0.5}", "gas.boundaries.z_lo.velocity"},
      {"z_lo: {type: inlet, velocity: 0.27}",
       "z_lo: {type: inlet, velocity: 0.27, patch: {lo: [0, 0], hi: [0.1, 0.1], velocity: 1}}",
       "gas.boundaries.z_lo.patch.hi"},
      {"count: 190", "count: 1900", "particles.count"},
      {"dem: {steps_per_collision: 50}", "dem: {substeps: 2}", "dem.substeps"},
      {"dem: {steps_per_collision: 50}", "dem: {dt: 1.0e-4}", "dem.dt"},
      {"dem: {steps_per_collision: 50}", "dem: {dt: 1.0e-6, substeps: 10}", "dem.substeps"},
      {"stiffness: 100", "stiffness: 0", "material.stiffness"},
      {"start: 0.3, interval: 5", "start: 0.3, interval: 5, profiles: [{quantity: void_fraction, height: 1.0}]",
       "statistics.profiles[0].height"},
      {"max_courant: 0.5", "max_courant: 2", "diagnostics.max_courant"},
      {"time: {end: 1.3}", "time: {end: 1.3, steps: 10}", "time.end"},
      {"void_fraction: linear", "void_fraction: linear\n  pressure_solver: {type: jacobi}", "gas.pressure_solver.type"},
  };
  for (const Bad& b : bad) {
    const std::string m = refusal(replaced(base, b.from, b.to));
    EXPECT_NE(m.find(b.key), std::string::npos) << b.to << " -> \"" << m << "\"";
    EXPECT_NE(m.find("case.yaml"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  // Multigrid needs periodic axes of even length or of one cell (red-black
  // ordering): one cell is accepted, three are refused naming the key.
  const std::string mg = replaced(base, "void_fraction: linear", "void_fraction: linear\n  pressure_solver: {type: multigrid}");
  EXPECT_EQ(refusal(mg), "");
  const std::string m = refusal(replaced(mg, "hi: [4.0e-3, 4.0e-3, 0.08]", "hi: [1.2e-2, 4.0e-3, 0.08]"));
  EXPECT_NE(m.find("gas.pressure_solver.type"), std::string::npos) << m;
  EXPECT_NE(m.find("case.yaml"), std::string::npos) << m;
  EXPECT_NE(m.find("3 cells"), std::string::npos) << m;
}

// Fluidized at 0.27 m/s (about 1.1 U_mf: the bed expands uniformly and
// stays off the distributor), the gas carries the bed: the pressure drop
// averaged over 1 s is the buoyant weight per area within 2 %.
TEST_F(CfdScene, FluidizedPressureDropPlateauIsTheBedWeight) {
  ASSERT_EQ(run_text(read_text(case_path("fluidized_bed_small.yaml"))), 0);
  const std::string summary = read_text((dir_ / "summary.json").string());
  const auto at = summary.find("\"mean_pressure_drop_over_weight\": ");
  ASSERT_NE(at, std::string::npos) << summary;
  const double ratio = std::stod(summary.substr(at + 34));
  std::printf("time-averaged pressure drop / (buoyant weight / area) = %.4f\n", ratio);
  EXPECT_NEAR(ratio, 1.0, 0.02);
}

// Fixed bed (below U_mf): the pressure drop at two superficial velocities,
// fitted as a U + b U^2 (Ergun's form), reaches the bed weight at U_mf within
// 15 % of Ergun's prediction at the packing of the settled bed (Gidaspow's
// dense branch is Ergun's law, so what is tested is the scene's coupling:
// void fraction, interpolation, set I forces, pressure-drop measurement).
TEST_F(CfdScene, FixedBedGivesUmfNearErgun) {
  const double d = 1.2e-3, rho_s = 1000, rho = 1.225, mu = 1.8e-5, g = 9.80665, L = 4e-3;
  std::vector<double> ratio, phi;
  for (const char* U : {"0.1", "0.2"}) {
    std::string text = replaced(read_text(case_path("fluidized_bed_small.yaml")), "velocity: 0.27",
                                std::string("velocity: ") + U);
    text = replaced(text, "end: 1.3", "end: 0.15");
    text = replaced(text, "start: 0.3, interval: 5", "start: 0.1, interval: 5");
    ASSERT_EQ(run_text(text), 0);
    const std::string summary = read_text((dir_ / "summary.json").string());
    const auto at = summary.find("\"mean_pressure_drop_over_weight\": ");
    const auto ah = summary.find("\"mean_bed_height_m\": ");
    ASSERT_TRUE(at != std::string::npos && ah != std::string::npos) << summary;
    ratio.push_back(std::stod(summary.substr(at + 34)));
    const double height = std::stod(summary.substr(ah + 22));
    phi.push_back(190 * 3.14159265358979 * d * d * d / 6 / (L * L * height));
    std::printf("U %s m/s: pressure drop / weight %.4f, bed packing %.3f\n", U, ratio.back(), phi.back());
  }
  ASSERT_LT(ratio[0], ratio[1]);
  ASSERT_LT(ratio[1], 0.95);
  const double u1 = 0.1, u2 = 0.2, r1 = ratio[0], r2 = ratio[1];
  const double b = (r2 / u2 - r1 / u1) / (u2 - u1), a = r1 / u1 - b * u1;
  const double umf = (-a + std::sqrt(a * a + 4 * b)) / (2 * b);
  const double ph = 0.5 * (phi[0] + phi[1]), eps = 1 - ph;
  const double A2 = 1.75 * ph * rho / (eps * eps * eps * d);
  const double A1 = 150 * ph * ph * mu / (eps * eps * eps * d * d);
  const double A0 = (rho_s - rho) * g * ph;
  const double umf_ergun = (-A1 + std::sqrt(A1 * A1 + 4 * A2 * A0)) / (2 * A2);
  std::printf("U_mf: from the fixed bed %.4f m/s, Ergun at phi %.3f: %.4f m/s\n", umf, ph, umf_ergun);
  EXPECT_NEAR(umf, umf_ergun, 0.15 * umf_ergun);
}

}  // namespace
