// A changed default never silently changes an old case's answer (issue 29):
// a case file that fixes one parameter of the default drag rule (fluid.magic
// beside the wall-rule weighting, or the classic weighting beside
// fluid.magic: auto) is warned at `lbdem check` and at the start of a run,
// naming the combination and its expected drag error or "no estimate"
// (imb/psm_settings.hpp); summary.json records every resolved PSM setting and
// where the rule's parameters came from.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "core/output.hpp"
#include "imb/psm_settings.hpp"
#include "run_lbdem.hpp"

namespace fs = std::filesystem;
using lbdem::test::run;

namespace {

class PsmSettingsCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lbdem_psm_settings_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write_case(const std::string& text, const std::string& name) {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }
  static std::string fixed_sphere(const std::string& fluid, const std::string& extra = "") {
    return "scene: fixed_sphere\nunits: lattice\ngeometry: {dim: 3, diameter: 4, chi: 0.5}\nfluid: " + fluid +
           "\nsteady: {tolerance: 1.0e-14, max_steps: 20}\noutput: {directory: unused}\n" + extra;
  }
  static std::string read(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  fs::path dir_;
};

// An old case file: Lambda set, no psm.weight (the wall rule by default).
TEST_F(PsmSettingsCli, CheckWarnsLambdaFromFileWithTheRuleWeighting) {
  const auto r = run("check " + write_case(fixed_sphere("{tau: 0.8, magic: 0.25}"), "old.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("fluid.magic = 0.25 set in the case file with psm.weight = noble_torczynski_wall (the "
                       "default: not set in the file)"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("no estimate"), std::string::npos) << r.out;
  // The rule's own Lambda at this d/l and tau is named.
  char rule[64];
  std::snprintf(rule, sizeof rule, "fluid.magic: auto = %.4g", lbdem::imb::psm_magic_auto(4, 0.8));
  EXPECT_NE(r.out.find(rule), std::string::npos) << r.out;
}

// The rule's own setting, and a file that names both parameters of the
// classic setting explicitly, get no warning.
TEST_F(PsmSettingsCli, CheckQuietForTheRuleAndForAFullClassicSetting) {
  auto r = run("check " + write_case(fixed_sphere("{tau: 0.8, magic: auto}"), "rule.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("set in the case file"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("fluid.magic: auto (Lambda"), std::string::npos) << r.out;
  r = run("check " + write_case(fixed_sphere("{tau: 0.8, magic: 0.25}", "psm: {weight: noble_torczynski}\n"),
                                "classic.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("set in the case file"), std::string::npos) << r.out;
}

// The classic weighting with Lambda auto (the table derived for the wall rule).
TEST_F(PsmSettingsCli, CheckWarnsLambdaAutoWithAnotherWeighting) {
  const auto r =
      run("check " + write_case(fixed_sphere("{tau: 0.8}", "psm: {weight: noble_torczynski}\n"), "mixed.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("fluid.magic: auto (Lambda"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("psm.weight = noble_torczynski:"), std::string::npos) << r.out;
}

// The warning at the start of a run, and summary.json's "psm" record.
TEST_F(PsmSettingsCli, RunWarnsAndSummaryRecordsEverySetting) {
  const fs::path out = dir_ / "out";
  const auto r = run("run " + write_case(fixed_sphere("{tau: 0.8, magic: 0.25}"), "old.yaml") +
                     " --backend cpu --overwrite --output " + out.string());
  EXPECT_NE(r.out.find("fluid.magic = 0.25 set in the case file"), std::string::npos) << r.out;
  const std::string js = read(out / "summary.json");
  for (const char* key : {"\"psm\": {", "\"weight\": \"noble_torczynski_wall\"", "\"weight_from\": \"default\"",
                          "\"magic\": 0.25", "\"magic_from\": \"file\"", "\"magic_rule\": ", "\"weight_t\": ",
                          "\"operator\": \"nebb\"", "\"fraction\": \"exact\"", "\"pipeline\": \"mapped\"",
                          "\"precision\": \"fp64\"", "\"tau\": 0.8", "\"diameter\": 4",
                          "\"expected_drag_error\": null", "\"warnings\": 1"})
    EXPECT_NE(js.find(key), std::string::npos) << key << "\n" << js;
}

// psm.even_relaxation (off by default) is recorded in summary.json; the
// superposition operator refuses it, naming the key.
TEST_F(PsmSettingsCli, EvenRelaxationIsRecordedAndRefusedWithSuperposition) {
  const fs::path out = dir_ / "out";
  auto r = run("run " + write_case(fixed_sphere("{tau: 0.8}", "psm: {even_relaxation: 0.02}\n"), "even.yaml") +
               " --backend cpu --quiet --overwrite --output " + out.string());
  // (20 steps do not reach the steady state: the run's code says so; the summary is written)
  ASSERT_TRUE(fs::exists(out / "summary.json")) << r.out;
  EXPECT_NE(read(out / "summary.json").find("\"even_relaxation\": 0.02"), std::string::npos);
  const fs::path out0 = dir_ / "out0";
  r = run("run " + write_case(fixed_sphere("{tau: 0.8}"), "default.yaml") + " --backend cpu --quiet --overwrite --output " +
          out0.string());
  ASSERT_TRUE(fs::exists(out0 / "summary.json")) << r.out;
  EXPECT_NE(read(out0 / "summary.json").find("\"even_relaxation\": 0,"), std::string::npos);
  r = run("check " + write_case(fixed_sphere("{tau: 0.8}", "psm: {operator: superposition, even_relaxation: 0.5}\n"),
                                "super.yaml"));
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("even_relaxation"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("operator: nebb"), std::string::npos) << r.out;
  r = run("check " + write_case(fixed_sphere("{tau: 0.8}", "psm: {even_relaxation: 1.5}\n"), "range.yaml"));
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("even_relaxation"), std::string::npos) << r.out;
}

// 2D scenes (disks) get the 2D map's estimate (fixed disks in square arrays,
// imb/drag_error.hpp): the shipped 2D suspensions (d/l 10, tau 0.86928, table
// fractions, fp32) and the shipped fixed-disk array (d/l 20, tau 0.52), told
// without a warning (no published bar in 2D) unless psm.max_expected_drag_error
// is set; outside the map "no estimate" says so.
TEST_F(PsmSettingsCli, CheckEstimatesIn2D) {
  for (const char* c : {"/cases/suspension/suspension_2d_small.yaml", "/cases/fixed_disk.yaml"}) {
    const auto r = run(std::string("check ") + LBDEM_SOURCE_DIR + c);
    EXPECT_EQ(r.code, 0) << c << "\n" << r.out;
    EXPECT_NE(r.out.find("expected drag error at d/l = "), std::string::npos) << c << "\n" << r.out;
    EXPECT_NE(r.out.find("% (fixed disk in a square array, chi 0.3"), std::string::npos) << c << "\n" << r.out;
    EXPECT_NE(r.out.find("no published bar in 2D"), std::string::npos) << c << "\n" << r.out;
    EXPECT_EQ(r.out.find("no estimate"), std::string::npos) << c << "\n" << r.out;
    EXPECT_EQ(r.out.find("above psm.max_expected_drag_error"), std::string::npos) << c << "\n" << r.out;
  }
  auto disk = [](double d, const std::string& extra) {
    return "scene: fixed_sphere\nunits: lattice\ngeometry: {dim: 2, diameter: " + std::to_string(d) +
           ", chi: 0.3}\nfluid: {tau: 0.8}\nsteady: {tolerance: 1.0e-14, max_steps: 20}\n"
           "output: {directory: unused}\n" + extra;
  };
  auto r = run("check " + write_case(disk(40, ""), "big.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("no estimate (outside the 2D map (d/l 8-20"), std::string::npos) << r.out;
  // A limit of the user's own applies in 2D: d/l 10, tau 0.8 expects +1.33 % (corner) > 0.5 %.
  r = run("check " + write_case(disk(10, "psm: {max_expected_drag_error: 0.005}\n"), "limit.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("above psm.max_expected_drag_error = 0.50%"), std::string::npos) << r.out;
}

// The full-size 2D suspension (the first paper's box), checked against a GPU
// node's memory (this machine may hold less): the same estimate as the small box.
TEST_F(PsmSettingsCli, CheckEstimatesForTheFullSize2DSuspension) {
  const auto r = run(std::string("check --memory 80GiB ") + LBDEM_SOURCE_DIR + "/cases/suspension/suspension_2d.yaml");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("expected drag error at d/l = 10, tau = 0.86928: +"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("% (fixed disk in a square array, chi 0.3"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("no estimate"), std::string::npos) << r.out;
}

// The particle scene: the warning at check and the record in summary.json,
// here with the rule's Lambda (from the rule, an estimate, no warning).
TEST_F(PsmSettingsCli, ParticleSceneRecordsTheSettings) {
  const std::string yaml = R"(scene: particles
units: lattice
domain: {cells: [16, 16, 16], periodic: [1, 1, 1]}
fluid: {tau: 0.8, magic: MAGIC}
physics: {gravity: [0, -1.0e-6, 0]}
particles: {init: random, diameter: 6, density_ratio: 2, solid_fraction: 0.05, seed: 3}
dem: {stiffness: 2, restitution: 0.5, substeps: 5}
time: {steps: 4}
output: {directory: unused, interval: 0, series_interval: 2}
)";
  auto with = [&](const std::string& magic) {
    std::string y = yaml;
    y.replace(y.find("MAGIC"), 5, magic);
    return y;
  };
  const auto c = run("check " + write_case(with("0.3"), "p_old.yaml"));
  EXPECT_NE(c.out.find("fluid.magic = 0.3 set in the case file with psm.weight = noble_torczynski_wall"),
            std::string::npos)
      << c.out;
  const fs::path out = dir_ / "pout";
  const auto r = run("run " + write_case(with("auto"), "p_rule.yaml") + " --backend cpu --quiet --overwrite --output " +
                     out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("set in the case file"), std::string::npos) << r.out;
  const std::string js = read(out / "summary.json");
  for (const char* key : {"\"psm\": {", "\"weight_from\": \"default\"", "\"magic_from\": \"rule\"",
                          "\"operator\": \"nebb\"", "\"fraction\": \"exact\"", "\"pipeline\": \"mapped\"",
                          "\"warnings\": 0"})
    EXPECT_NE(js.find(key), std::string::npos) << key << "\n" << js;
}


// psm.wall_lubrication (imb/wall_lubrication.hpp): off by default, told at
// check either way; on, the start report names the coefficients, summary.json
// records them, and the particles' hydrodynamic forces change; off gives the
// bits of a file without the key; a bad value is refused naming the key, the
// value and what is valid; outside the fit (tau 0.6) it is applied nowhere
// and the run says so.
class WallLubricationCli : public PsmSettingsCli {
 protected:
  // Two spheres of d/l 6 in a box closed along y (walls at y = 1 and 21), a
  // cell and a half from the floor and from the ceiling, moving down.
  static std::string scene(const std::string& psm, const std::string& dir, double tau = 0.8) {
    return "scene: particles\nunits: lattice\ndomain: {cells: [16, 20, 16], periodic: [1, 0, 1]}\n"
           "fluid: {tau: " + std::to_string(tau) + ", magic: auto}\nphysics: {gravity: [0, -1.0e-5, 0]}\n"
           "particles: {init: list, diameter: 6, density_ratio: 2, velocity: [0, -0.002, 0], "
           "list: [{position: [8, 5.5, 8]}, {position: [8, 16.5, 8]}]}\n"
           "dem: {stiffness: 20, restitution: 0.5, substeps: 12}\n" + psm +
           "time: {steps: 20}\noutput: {directory: " + dir + ", interval: 20, series_interval: 10}\n";
  }
  std::vector<double> forces(const std::string& psm, const std::string& name, std::string* summary = nullptr) {
    const fs::path out = dir_ / name;
    const auto r = run("run " + write_case(scene(psm, out.string()), name + ".yaml") +
                       " --backend cpu --quiet --overwrite");
    EXPECT_EQ(r.code, 0) << r.out;
    if (summary) *summary = read(out / "summary.json");
    try {
      return lbdem::io::read_dataset((out / "particles_00000020.h5").string(), "hydrodynamic_force");
    } catch (const std::exception& e) {
      ADD_FAILURE() << e.what();
      return {};
    }
  }
};

TEST_F(WallLubricationCli, CheckTellsTheSetting) {
  auto r = run("check " + write_case(scene("", "unused"), "default.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("psm.wall_lubrication off (the default)"), std::string::npos) << r.out;
  r = run("check " + write_case(scene("psm: {wall_lubrication: on}\n", "unused"), "on.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("psm.wall_lubrication on: a normal force 6 pi mu a U_n c a g^-p (c = 0.11, p = 2.6"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("2 wall plane(s)"), std::string::npos) << r.out;
  r = run("check " + write_case(scene("psm: {wall_lubrication: on}\n", "unused", 0.6), "tau06.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("psm.wall_lubrication on but NOT applied: Lambda"), std::string::npos) << r.out;
  r = run("check " + write_case(scene("psm: {wall_lubrication: maybe}\n", "unused"), "bad.yaml"));
  EXPECT_NE(r.code, 0) << r.out;
  for (const char* w : {"psm.wall_lubrication", "maybe", "on", "off"})
    EXPECT_NE(r.out.find(w), std::string::npos) << w << "\n" << r.out;
}

TEST_F(WallLubricationCli, OffKeepsTheBitsOnChangesTheForces) {
  std::string js_on, js_off;
  const auto absent = forces("", "absent");
  const auto off = forces("psm: {wall_lubrication: off}\n", "off", &js_off);
  const auto on = forces("psm: {wall_lubrication: on}\n", "on", &js_on);
  ASSERT_EQ(absent.size(), 6u);
  EXPECT_EQ(off, absent);  // bit for bit
  ASSERT_EQ(on.size(), 6u);
  // The spheres move down: the correction pushes the lower one up (+y) and
  // pulls the upper one toward the ceiling it leaves (+y); x and z unchanged
  // to round-off (the trajectories differ only along y).
  int up = 0;
  for (std::size_t i = 0; i < 2; ++i) {
    up += on[3 * i + 1] > off[3 * i + 1];
    EXPECT_NEAR(on[3 * i], off[3 * i], 1e-9 * std::abs(off[3 * i + 1]));
  }
  EXPECT_EQ(up, 2);
  EXPECT_NE(js_off.find("\"wall_lubrication\": {\"requested\": \"off\", \"applied\": false"), std::string::npos)
      << js_off;
  for (const char* k : {"\"wall_lubrication\": {\"requested\": \"on\", \"applied\": true", "\"c\": 0.11", "\"p\": 2.6",
                        "\"g_min\": 0.5", "\"g_max\": 8", "\"walls\": 2", "\"fit_magic_min\": 0.06"})
    EXPECT_NE(js_on.find(k), std::string::npos) << k << "\n" << js_on;
}

}  // namespace
