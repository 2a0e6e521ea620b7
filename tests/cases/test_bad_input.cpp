// Bad input: every malformed case gives a clear error (naming the key, the
// value and what is valid), a non-zero exit, and leaves existing output
// untouched. Runs the real `lbdem` binary.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "run_lbdem.hpp"

namespace fs = std::filesystem;

namespace {

const char* kBase = R"(scene: channel
lattice: D2Q9
precision: fp64
streaming: aa
collision: {model: trt, tau: 0.8, magic: 0.1875}
fluid: {density: 1.2, kinematic_viscosity: 1.5e-5}
domain: {cells: [4, 16], spacing: 6.25e-5}
channel: {mode: periodic, body_acceleration: 5.0}
time: {steps: 10}
diagnostics: {interval: 5}
)";

using lbdem::test::Result;
using lbdem::test::run;

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lbdem_bad_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "out");
    // An existing run: must survive every failed attempt byte for byte.
    std::ofstream(dir_ / "out" / "fields.xdmf") << "previous run";
    std::ofstream(dir_ / "out" / "diagnostics.csv") << "step\n1\n";
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write_case(const std::string& text) {
    const auto p = dir_ / "case.yaml";
    std::ofstream(p) << text;
    return p.string();
  }
  // Replaces the first line starting with `key` in the base case.
  static std::string with(const std::string& key_line_prefix, const std::string& replacement) {
    std::string s = kBase;
    const auto pos = s.find(key_line_prefix);
    EXPECT_NE(pos, std::string::npos) << key_line_prefix;
    const auto end = s.find('\n', pos);
    return s.substr(0, pos) + replacement + s.substr(end);
  }
  void expect_refused(const std::string& case_text, const std::vector<std::string>& must_contain,
                      const std::string& extra_args = "") {
    const auto r = run("run " + write_case(case_text) + " --backend cpu --quiet --output " + (dir_ / "out").string() +
                       " " + extra_args);
    EXPECT_NE(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("error:"), std::string::npos) << r.out;
    for (auto& m : must_contain) EXPECT_NE(r.out.find(m), std::string::npos) << "missing '" << m << "' in: " << r.out;
    expect_output_untouched();
  }
  void expect_output_untouched() {
    std::size_t n = 0;
    for (auto& e : fs::directory_iterator(dir_ / "out")) { (void)e; ++n; }
    EXPECT_EQ(n, 2u) << "files were added to the output folder";
    std::ifstream a(dir_ / "out" / "fields.xdmf");
    std::stringstream ss;
    ss << a.rdbuf();
    EXPECT_EQ(ss.str(), "previous run");
  }
  fs::path dir_;
};

TEST_F(BadInput, BaseCaseRuns) {
  // Control: the base case is valid, so the refusals below are the edits'.
  const auto r = run("run " + write_case(kBase) + " --backend cpu --quiet --output " + (dir_ / "fresh").string());
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(dir_ / "fresh" / "fields.xdmf"));
}
TEST_F(BadInput, MissingKey) {
  expect_refused(with("fluid:", "fluid: {kinematic_viscosity: 1.5e-5}"), {"missing required key 'fluid.density'"});
}
TEST_F(BadInput, WrongType) {
  expect_refused(with("collision:", "collision: {model: trt, tau: fast}"), {"collision.tau", "fast", "must be a number"});
}
TEST_F(BadInput, OutOfRange) {
  expect_refused(with("collision:", "collision: {model: trt, tau: 0.8, magic: -1}"), {"collision.magic", "-1", "must be in"});
}
TEST_F(BadInput, UnknownTopLevelKeySuggests) {
  expect_refused(std::string(kBase) + "outptu: {directory: x}\n", {"unknown key 'outptu'", "did you mean 'output'"});
}
TEST_F(BadInput, UnknownNestedKeySuggests) {
  expect_refused(with("fluid:", "fluid: {density: 1.2, kinematic_viscosity: 1.5e-5, viscosty: 1}"),
                 {"unknown key 'fluid.viscosty'", "kinematic_viscosity"});
}
TEST_F(BadInput, TauAtOrBelowHalf) {
  expect_refused(with("collision:", "collision: {model: trt, tau: 0.5}"), {"collision.tau", "0.5", "must be > 0.5"});
}
TEST_F(BadInput, BgkTooCloseToHalf) {
  expect_refused(with("collision:", "collision: {model: bgk, tau: 0.505}"), {"collision.tau", "BGK"});
}
TEST_F(BadInput, UnstableMach) {
  expect_refused(with("channel:", "channel: {mode: periodic, body_acceleration: 5000.0}"),
                 {"Mach", "exceeds the limit", "collision.tau"});
}
TEST_F(BadInput, DomainTooLargeForMemory) {
  std::string s = with("lattice:", "lattice: D3Q19");
  s = with("domain:", "domain: {cells: [65536, 65536, 65536], spacing: 1e-6}");
  s.replace(s.find("lattice: D2Q9"), 13, "lattice: D3Q19");
  s.replace(s.find("body_acceleration: 5.0"), 22, "body_acceleration: 1e-6");
  expect_refused(s, {"domain.cells", "MiB"});
}
TEST_F(BadInput, UnwritableOutputFolder) {
  std::ofstream(dir_ / "a_file") << "x";
  const auto r = run("run " + write_case(kBase) + " --backend cpu --quiet --output " + (dir_ / "a_file" / "sub").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find((dir_ / "a_file").string()), std::string::npos) << r.out;
  expect_output_untouched();
}
TEST_F(BadInput, NonEmptyOutputNeedsOverwrite) {
  expect_refused(kBase, {(dir_ / "out").string(), "--overwrite"});
}
TEST_F(BadInput, UnknownLattice) {
  expect_refused(with("lattice:", "lattice: D3Q27"), {"'lattice'", "D3Q27", "D2Q9, D3Q19"});
}
TEST_F(BadInput, WrongCellCount) {
  expect_refused(with("domain:", "domain: {cells: [4, 16, 3], spacing: 6.25e-5}"), {"domain.cells", "a list of 2"});
}
TEST_F(BadInput, StepsAndEndBoth) {
  expect_refused(with("time:", "time: {steps: 10, end: 1.0}"), {"time", "exactly one"});
}
TEST_F(BadInput, NegativeViscosity) {
  expect_refused(with("fluid:", "fluid: {density: 1.2, kinematic_viscosity: -1e-5}"),
                 {"fluid.kinematic_viscosity", "greater than 0"});
}
TEST_F(BadInput, YamlSyntaxError) {
  expect_refused("scene: channel\nfluid: {density: 1.2\n", {"YAML syntax error at line"});
}
TEST_F(BadInput, UnknownSceneSuggests) {
  expect_refused(with("scene:", "scene: chanel"), {"'scene'", "did you mean 'channel'"});
}
TEST_F(BadInput, UnknownPrecision) {
  expect_refused(with("precision:", "precision: fp16"), {"'precision'", "fp16", "fp32, fp64"});
}
TEST_F(BadInput, MissingCaseFile) {
  const auto r = run("run " + (dir_ / "nope.yaml").string() + " --backend cpu --output " + (dir_ / "out").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("cannot open"), std::string::npos) << r.out;
  expect_output_untouched();
}
TEST_F(BadInput, CheckCommandRefusesToo) {
  const auto r = run("check " + write_case(with("collision:", "collision: {model: trt, tau: 0.4}")));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("collision.tau"), std::string::npos) << r.out;
}

}  // namespace

namespace {

TEST(Watchdog, StopsWithDiagnosisAndKeepsOutput) {
  // A periodic box accelerated far past the Mach limit: the up-front check
  // passes (reference speed 0.01 m/s), the watchdog must stop the run with
  // the step, the cell and the value, exit 3, and keep the output written
  // before the failure.
  const fs::path dir = fs::temp_directory_path() / ("lbdem_watchdog_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "case.yaml") << R"(scene: periodic_box
lattice: D2Q9
collision: {model: bgk, tau: 0.8}
fluid: {density: 1.0, kinematic_viscosity: 1.0e-5}
domain: {cells: [8, 8], spacing: 1.0e-3}
periodic_box: {body_acceleration: [2000.0, 0, 0], reference_velocity: 0.01}
time: {steps: 5000}
output: {interval: 10}
diagnostics: {interval: 10, max_mach: 0.3}
)";
  const auto r = run("run " + (dir / "case.yaml").string() + " --backend cpu --quiet --output " + (dir / "out").string());
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_NE(r.out.find("Mach"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("at step"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("at cell ("), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(dir / "out" / "fields.xdmf"));
  EXPECT_TRUE(fs::exists(dir / "out" / "fields_00000000.h5"));
  fs::remove_all(dir);
}

}  // namespace

// The fused PSM pipeline evaluates table or linear fractions in its kernel; a
// case that asks for it with exact fractions is refused before anything runs,
// naming the key and the way out.
TEST_F(BadInput, FusedPipelineWithExactFractionsIsRefused) {
  const std::string text = R"(scene: particles
units: lattice
domain: {cells: [24, 24, 24], periodic: [1, 1, 1]}
fluid: {tau: 0.6}
physics: {gravity: [0, 0, 0]}
particles:
  init: list
  diameter: 8
  density_ratio: 2
  list:
    - {position: [12, 12, 12]}
dem: {stiffness: 5000, restitution: 0.5, substeps: 30}
psm: {fraction: exact, pipeline: fused}
time: {steps: 10}
)";
  expect_refused(text, {"psm.pipeline", "exact", "mapped"});
}
