// Case files that parse but make no sense, and files yaml-cpp would read
// wrongly: each rule has one malformed file here, refused by the real
// `lbdem` binary with exit code 2 (4 for memory), a one-line message naming
// the key (as written in the file) and the way out, and no output written.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "run_lbdem.hpp"

namespace fs = std::filesystem;

namespace {

using lbdem::test::Result;
using lbdem::test::run;

class Validation : public ::testing::Test {
 public:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lbdem_valid_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  std::string write_case(const std::string& text) {
    const auto p = dir_ / "case.yaml";
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }
  // `lbdem run` (nothing may be written) and `lbdem check` must both refuse
  // with `code`, and the message hold every string of `must`.
  Result refused(const std::string& text, const std::vector<std::string>& must, int code = 2,
                 const std::string& extra = "") {
    const std::string file = write_case(text);
    const fs::path out = dir_ / "out";
    const Result r = run("run " + file + " --backend cpu --quiet --output " + out.string() + " " + extra);
    EXPECT_EQ(r.code, code) << r.out;
    EXPECT_FALSE(fs::exists(out)) << "the refused run created its output folder";
    const Result c = run("check " + file + " " + extra);
    EXPECT_EQ(c.code, code) << c.out;
    // (A memory refusal quotes the free memory, which changes between the two.)
    if (code != 4) EXPECT_EQ(c.out, r.out) << "check and run disagree";
    else EXPECT_EQ(c.out.substr(0, c.out.find(" needs")), r.out.substr(0, r.out.find(" needs")));
    for (const auto& m : must) EXPECT_NE(r.out.find(m), std::string::npos) << "missing '" << m << "' in: " << r.out;
    // One line: "error: ...\n".
    EXPECT_EQ(r.out.rfind("error: ", 0), 0u) << r.out;
    EXPECT_EQ(r.out.find('\n'), r.out.size() - 1) << r.out;
    return r;
  }
  fs::path dir_;
};

// A DEM box [0, 1]^3 with a floor at y = 0; `particles` and `material` follow.
std::string dem_case(const std::string& particles, const std::string& material = "{stiffness: 1.0e4, restitution: 0.9}",
                     const std::string& time = "{steps: 10}") {
  return "scene: dem\n"
         "domain: {lo: [0, -1, 0], hi: [1, 1, 1]}\n"
         "walls: [{point: [0, 0, 0], normal: [0, 1, 0]}]\n"
         "physics: {gravity: [0, -9.8, 0]}\n"
         "material: " + material + "\n"
         "particles: " + particles + "\n"
         "time: " + time + "\n"
         "output: {directory: unused}\n";
}

// A resolved 24^3 periodic box (or closed, with `periodic`), one sphere of d = 8 unless `list` says otherwise.
std::string particles_case(const std::string& list = "[{position: [12, 12, 12]}]",
                           const std::string& cells = "[24, 24, 24]", const std::string& periodic = "[1, 1, 1]",
                           const std::string& gravity = "[0, -1.0e-6, 0]", const std::string& dem = "{stiffness: 5000, restitution: 0.5, substeps: 30}") {
  return "scene: particles\nunits: lattice\n"
         "domain: {cells: " + cells + ", periodic: " + periodic + "}\n"
         "fluid: {tau: 0.6}\n"
         "physics: {gravity: " + gravity + "}\n"
         "particles: {init: list, diameter: 8, density_ratio: 2, list: " + list + "}\n"
         "dem: " + dem + "\n"
         "time: {steps: 10}\n"
         "output: {directory: unused}\n";
}

TEST_F(Validation, ControlsAreAccepted) {
  EXPECT_EQ(run("check " + write_case(dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}]}"))).code, 0);
  EXPECT_EQ(run("check " + write_case(particles_case())).code, 0);
  // Touching particles and a particle resting on the floor are fine.
  EXPECT_EQ(run("check " + write_case(dem_case("{init: list, list: [{position: [0.5, 0.1, 0.5], radius: 0.1}, "
                                               "{position: [0.5, 0.3, 0.5], radius: 0.1}]}")))
                .code,
            0);
}

// ------------------------------------------------------------ particles
TEST_F(Validation, DemParticleOutsideTheDomain) {
  refused(dem_case("{init: list, list: [{position: [0.5, 1.5, 0.5], radius: 0.1}]}"),
          {"particle id 0", "outside the domain", "y = 1.5", "domain.lo, domain.hi"});
}
TEST_F(Validation, DemParticleBelowTheFloor) {
  refused(dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}, {position: [0.5, -0.5, 0.5], radius: 0.1}]}"),
          {"particle id 1", "behind walls[0]", "normal [0, 1, 0]"});
}
TEST_F(Validation, DemParticleLargerThanTheBox) {
  refused(dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.6}]}"), {"wider than the box", "along x"});
}
TEST_F(Validation, DemParticlesOverlapping) {
  refused(dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}, {position: [0.52, 0.5, 0.5], radius: 0.1}]}"),
          {"overlap", "particle id 0", "particle id 1", "move the particles apart"});
}
TEST_F(Validation, DemParticleOverlappingAWall) {
  refused(dem_case("{init: list, list: [{position: [0.5, 0.02, 0.5], radius: 0.1}]}"), {"overlaps walls[0]", "radius"});
}
TEST_F(Validation, DemOverlapAcrossAPeriodicBoundary) {
  std::string s = dem_case("{init: list, list: [{position: [0.01, 0.5, 0.5], radius: 0.1}, {position: [0.99, 0.5, 0.5], radius: 0.1}]}");
  s.replace(s.find("hi: [1, 1, 1]}"), 14, "hi: [1, 1, 1], periodic: [1, 0, 0]}");
  refused(s, {"overlap", "particle id 0", "particle id 1"});
}
TEST_F(Validation, ResolvedParticleOutsideTheDomain) {
  refused(particles_case("[{position: [12, 30, 12]}]"), {"particle id 0", "outside the domain", "domain.cells"});
}
TEST_F(Validation, ResolvedParticlesOverlapping) {
  refused(particles_case("[{position: [12, 12, 12]}, {position: [14, 12, 12]}]"), {"overlap", "particle id 1"});
}
TEST_F(Validation, ResolvedParticleInAWall) {
  // Closed along y: the walls sit at 1 and 25; a sphere of radius 4 at y = 2 cuts the lower one.
  refused(particles_case("[{position: [12, 2, 12]}]", "[24, 24, 24]", "[1, 0, 1]", "[0, 0, 0]"), {"particle id 0", "the wall"});
}
TEST_F(Validation, ResolvedParticleLargerThanTheBox) {
  refused(particles_case("[{position: [3, 12, 12]}]", "[6, 24, 24]"), {"wider than the box"});
}

// ------------------------------------------------------------ absurd values
TEST_F(Validation, AbsurdStiffnessNeedsForce) {
  const std::string s = dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}]}",
                                 "{stiffness: 1.0e30, restitution: 0.9}", "{end: 1}");
  refused(s, {"time.end", "material.stiffness", "years", "--force"});
  EXPECT_EQ(run("check " + write_case(s) + " --force").code, 0);
}
TEST_F(Validation, EndTimeBeyondAStepCounterRefusedEvenWithForce) {
  // end / dt far beyond a 64-bit count: refused with the keys, never cast out of range.
  const std::string s = dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}]}",
                                 "{stiffness: 1.0e5, restitution: 0.9}", "{end: 1.0e60}");
  refused(s, {"time.end", "64-bit step counter"});
  const auto r = run("check " + write_case(s) + " --force");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("64-bit step counter"), std::string::npos) << r.out;
}
TEST_F(Validation, OldEndTimeSpellingWorksWithAWarningNamingTheNewKey) {
  // time.end_time is the old spelling of time.end: it still runs, with a
  // warning that names the new key; both at once are refused.
  const std::string list = "{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}]}";
  const auto r = run("check " + write_case(dem_case(list, "{stiffness: 1.0e4, restitution: 0.9}", "{end_time: 1.0e-3}")));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("key 'time.end_time' is deprecated; write it as 'time.end'"), std::string::npos) << r.out;
  refused(dem_case(list, "{stiffness: 1.0e4, restitution: 0.9}", "{end_time: 1.0e-3, end: 1.0e-3}"),
          {"time.end_time", "old spelling", "time.end"});
}
TEST_F(Validation, StepsOverrideAlsoPlanned) {
  const auto r = run("check " + write_case(particles_case()) + " --force");
  EXPECT_EQ(r.code, 0) << r.out;
  refused(particles_case().replace(particles_case().find("steps: 10}"), 10, "steps: 100000000000000}"),
          {"time.steps", "years", "--force"});
}
TEST_F(Validation, OneByOneCavity) {
  refused("scene: lid_driven_cavity\nlattice: D2Q9\ncollision: {model: trt, tau: 0.6}\n"
          "fluid: {density: 1.0, kinematic_viscosity: 1.0e-6}\ndomain: {cells: [1, 1], spacing: 1.0e-4}\n"
          "lid_driven_cavity: {lid_velocity: 0.001}\ntime: {steps: 10}\n",
          {"domain.cells", "lid-driven cavity", "at least 4"});
}
TEST_F(Validation, ShortSpherePeriod) {
  refused("scene: fixed_sphere\nunits: lattice\ngeometry: {dim: 3, diameter: 2, chi: 0.75}\nfluid: {tau: 0.6}\n"
          "steady: {}\noutput: {directory: unused}\n",
          {"geometry.diameter", "geometry.chi", "L >= 4"});
}

// ------------------------------------------------------------ key names and Mach
TEST_F(Validation, SubstepsNamedAsWritten) {
  // Two particles: the shortest contact is theirs.
  const auto r = refused(particles_case("[{position: [6, 12, 12]}, {position: [18, 12, 12]}]", "[24, 24, 24]", "[1, 1, 1]",
                                        "[0, -1.0e-6, 0]", "{stiffness: 5000, restitution: 0.5, substeps: 2}"),
                         {"dem.substeps", "dem.stiffness"});
  EXPECT_EQ(r.out.find("coupling."), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("material."), std::string::npos) << r.out;
}
TEST_F(Validation, AbsurdStiffnessInAResolvedScene) {
  refused(particles_case("[{position: [6, 12, 12]}, {position: [18, 12, 12]}]", "[24, 24, 24]", "[1, 1, 1]",
                         "[0, -1.0e-6, 0]", "{stiffness: 1.0e30, restitution: 0.5, substeps: 30}"),
          {"dem.substeps", "soften dem.stiffness"});
}
TEST_F(Validation, ResolvedMachNamesGravityAndEveryWayOut) {
  const auto r = refused(particles_case("[{position: [12, 12, 12]}]", "[24, 24, 24]", "[1, 1, 1]", "[0, -1.0e-2, 0]"),
                         {"Mach", "physics.gravity", "fluid.tau", "particles.density_ratio", "finer grid"});
  EXPECT_EQ(r.out.find("coupling."), std::string::npos) << r.out;
}
TEST_F(Validation, ResolvedMachNamesTheInitialVelocity) {
  std::string s = particles_case();
  s.replace(s.find("density_ratio: 2,"), 17, "density_ratio: 2, velocity: [0.5, 0, 0],");
  refused(s, {"Mach", "particles.velocity", "smaller lattice time step"});
}
TEST_F(Validation, UnbalancedPeriodicWeightNamesBalanceWeight) {
  std::string s = particles_case();
  s.replace(s.find("physics: {"), 10, "physics: {balance_weight: false, ");
  const auto r = refused(s, {"physics.balance_weight", "physics.gravity"});
  EXPECT_EQ(r.out.find("fluid.body_force"), std::string::npos) << r.out;
}
TEST_F(Validation, FluidMachNamesTheSpeedKeyAndEveryWayOut) {
  refused("scene: channel\nlattice: D2Q9\ncollision: {model: trt, tau: 0.8}\n"
          "fluid: {density: 1.2, kinematic_viscosity: 1.5e-5}\ndomain: {cells: [4, 16], spacing: 6.25e-5}\n"
          "channel: {mode: periodic, body_acceleration: 5000.0}\ntime: {steps: 10}\n",
          {"Mach", "channel.body_acceleration", "collision.tau", "time.dt", "domain.spacing", "diagnostics.max_mach"});
}

// ------------------------------------------------------------ memory
// Refused with exit code 4 before anything is allocated or packed.
void expect_quick_resource_refusal(Validation& t, const std::string& text, const std::string& key) {
  const auto t0 = std::chrono::steady_clock::now();
  t.refused(text, {key, "MiB"}, 4);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0 * 1.0)
      << "two commands (run, check) took longer than a second each";
}
TEST_F(Validation, HugeDemLatticeRefusedAtOnce) {
  expect_quick_resource_refusal(*this,
                                dem_case("{init: lattice, count: [1000, 1000, 1000], origin: [0.001, 0.001, 0.001], "
                                         "spacing: [0.0009, 0.0009, 0.0009], radius: 0.0004}"),
                                "particles.count");
}
TEST_F(Validation, MillionCubedSuspensionRefusedAtOnce) {
  std::string s = particles_case().replace(particles_case().find("[24, 24, 24]"), 12, "[1000000, 1000000, 1000000]");
  expect_quick_resource_refusal(*this, s, "domain.cells");
}
TEST_F(Validation, RandomSuspensionRefusedBeforePacking) {
  std::string s = "scene: particles\nunits: lattice\ndomain: {cells: [3000, 3000, 3000], periodic: [1, 1, 1]}\n"
                  "fluid: {tau: 0.6}\nphysics: {gravity: [0, -1.0e-6, 0]}\n"
                  "particles: {init: random, diameter: 8, density_ratio: 100, solid_fraction: 0.1}\n"
                  "dem: {stiffness: 20000, restitution: 0.9, substeps: 25}\ntime: {steps: 10}\n"
                  "output: {directory: unused}\n";
  expect_quick_resource_refusal(*this, s, "domain.cells");
}

// ------------------------------------------------------------ the YAML itself
TEST_F(Validation, DuplicatedKey) {
  refused(dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}]}") + "physics: {gravity: [0, 0, 0]}\n",
          {"case.yaml:9:", "'physics' appears twice", "first at line 4"});
}
TEST_F(Validation, DuplicatedNestedKey) {
  refused(dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1, radius: 0.2}]}"),
          {"case.yaml:6:", "'particles.list[0].radius' appears twice"});
}
TEST_F(Validation, TwoDocuments) {
  refused(dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}]}") + "---\nscene: channel\n",
          {"case.yaml:9:", "more than one YAML document"});
}
TEST_F(Validation, ComplexKey) {
  refused(dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}]}") + "? [a, b]\n: 1\n",
          {"case.yaml:9:", "is a list", "plain names"});
}
TEST_F(Validation, BadConversionNamesFileLineKeyAndType) {
  refused(dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: [1, 2]}]}"),
          {"case.yaml:6:", "particles.list[0].radius", "must be a number"});
  refused(dem_case("{init: list, list: [{position: [0.5, {a: 1}, 0.5], radius: 0.1}]}"),
          {"case.yaml:6:", "particles.list[0].position", "a list of 3 numbers"});
}
TEST_F(Validation, DeepNestingReportedPlainly) {
  const auto r = refused("scene: dem\ndomain: " + std::string(200000, '[') + "\n", {"case.yaml:", "nest"});
  EXPECT_EQ(r.out.find("column"), std::string::npos) << r.out.substr(0, 300);
  EXPECT_LT(r.out.size(), 300u);
  std::string blocks = "scene: dem\n";
  for (int i = 0; i < 40; ++i) blocks += std::string(2 * i, ' ') + "k" + std::to_string(i) + ":\n";
  refused(blocks + std::string(80, ' ') + "x: 1\n", {"case.yaml:", "levels deep"});
}
// Nested aliases: 9 levels of 10 copies expand to 10^9 values, small in the
// file and in memory (yaml-cpp shares an aliased node) but exponential to
// walk. Refused by the node count as the parser meets the alias that passes
// it, in far less than the generous bound below.
std::string billion_laughs() {
  std::string s = "scene: dem\na0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]\n";
  for (int i = 1; i <= 9; ++i) {
    // (appended piecewise: GCC 12 warns, -Wrestrict, a false positive, on "x" + std::string)
    const std::string prev = std::string("*a").append(std::to_string(i - 1));
    s.append("a").append(std::to_string(i)).append(": &a").append(std::to_string(i)).append(" [");
    for (int k = 0; k < 10; ++k) s += (k ? ", " : "") + prev;
    s += "]\n";
  }
  return s;
}
TEST_F(Validation, BillionLaughsRefusedByTheNodeCount) {
  const auto t0 = std::chrono::steady_clock::now();
  // a0 to a4 expand to ~1.2 * 10^5 nodes, each alias in a5 to ~1.1 * 10^5 more:
  // the count passes 10^6 inside a5, on line 7.
  const auto r = refused(billion_laughs(), {"case.yaml:7:", "expands to more than 1000000 values", "alias", "csv"});
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0)
      << "two refusals should take milliseconds each";
}
TEST_F(Validation, WideAliasesCountedAsCopies) {
  // 2,000 copies of a list of 1,000 values: 2 * 10^6 values from a 12 kB file.
  std::string s = "scene: dem\nx: &x [";
  for (int k = 0; k < 1000; ++k) s += (k ? ",1" : "1");
  s += "]\ny: [";
  for (int k = 0; k < 2000; ++k) s += (k ? ", *x" : "*x");
  refused(s + "]\n", {"case.yaml:3:", "expands to more than 1000000"});
}
TEST_F(Validation, ManyAnchorsWithinTheLimitAccepted) {
  // Aliases are fine as such: a shared material section used twice.
  const std::string c = dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}]}", "&m {stiffness: 1.0e4, restitution: 0.9}") + "unused_copy: *m\n";
  const auto r = run("check " + write_case(c));
  // The alias expands fine; the extra key is then refused by name (not by size).
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("unknown key 'unused_copy'"), std::string::npos) << r.out;
}
TEST_F(Validation, HugeCaseFileRefusedUnread) {
  // A sparse 64 GiB file: refused after reading at most the limit.
  const auto p = dir_ / "huge.yaml";
  std::ofstream(p) << "scene: dem\n";
  fs::resize_file(p, std::uintmax_t{64} << 30);
  const auto t0 = std::chrono::steady_clock::now();
  for (const char* cmd : {"check ", "run "}) {
    const auto r = run(std::string(cmd) + p.string() + (cmd[0] == 'r' ? " --output " + (dir_ / "out").string() : ""));
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_EQ(r.out.rfind("error: ", 0), 0u) << r.out;
    EXPECT_NE(r.out.find("larger than 4 MiB, the limit of a case file"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find('\n'), r.out.size() - 1) << r.out;
  }
  EXPECT_FALSE(fs::exists(dir_ / "out"));
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
}
TEST_F(Validation, CaseFileThatIsNotARegularFileRefused) {
  for (const auto& [path, kind] : std::vector<std::pair<std::string, std::string>>{
           {"/dev/zero", "character device"}, {dir_.string(), "folder"}}) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = run("check " + path);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find(path + ": the case file is not a regular file (it is a " + kind + ")"), std::string::npos)
        << r.out;
    EXPECT_EQ(r.out.find('\n'), r.out.size() - 1) << r.out;
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  }
  const auto fifo = dir_ / "pipe.yaml";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const auto r = run("check " + fifo.string());  // (opening a FIFO to read would block until a writer comes)
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("(it is a pipe)"), std::string::npos) << r.out;
}
TEST_F(Validation, LongValueClipped) {
  const auto r = refused(dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}]}") + "scene2: " +
                             std::string(1 << 20, 'x') + "\n",
                         {"unknown key 'scene2'"});
  EXPECT_LT(r.out.size(), 600u);
  const auto r2 = refused("scene: " + std::string(1 << 20, 'y') + "\n", {"'scene' = yyyy", "...", "bytes)"});
  EXPECT_LT(r2.out.size(), 600u);
}
TEST_F(Validation, InvisibleCharacterInKeyShown) {
  std::string s = dem_case("{init: list, list: [{position: [0.5, 0.5, 0.5], radius: 0.1}]}");
  s.replace(s.find("material:"), 9, "mate\xe2\x80\x8brial:");
  refused(s, {"material", "mate\\u200brial", "non-printing"});
}

}  // namespace
