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

// 2D scenes (disks) are outside the drag map: `check` says so instead of
// printing nothing (the shipped 2D suspension and a 2D fixed-disk array).
TEST_F(PsmSettingsCli, CheckSaysNoEstimateIn2D) {
  auto r = run(std::string("check ") + LBDEM_SOURCE_DIR + "/cases/suspension/suspension_2d_small.yaml");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("expected drag error"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("no estimate (2D"), std::string::npos) << r.out;
  r = run("check " + write_case("scene: fixed_sphere\nunits: lattice\ngeometry: {dim: 2, diameter: 8, chi: 0.5}\n"
                                "fluid: {tau: 0.8}\nsteady: {tolerance: 1.0e-14, max_steps: 20}\n"
                                "output: {directory: unused}\n",
                                "disk.yaml"));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("no estimate (2D"), std::string::npos) << r.out;
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

}  // namespace
