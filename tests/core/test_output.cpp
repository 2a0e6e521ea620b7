// HDF5/XDMF output, CSV time series and the output-folder policy.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include <unistd.h>

#include "core/error.hpp"
#include "core/output.hpp"

namespace fs = std::filesystem;
using namespace lbdem;

namespace {

// A fresh folder per test under the system temp dir, removed afterwards.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& tag) {
    path = fs::temp_directory_path() /
           ("lbdem_test_output_" + tag + "_" + std::to_string(static_cast<long>(::getpid())));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string str() const { return path.string(); }
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::size_t count(const std::string& s, const std::string& sub) {
  std::size_t n = 0;
  for (auto pos = s.find(sub); pos != std::string::npos; pos = s.find(sub, pos + sub.size())) ++n;
  return n;
}

// Minimal well-formedness: every <Tag ...> is closed in order (self-closing tags allowed).
bool balanced_xml(const std::string& s) {
  std::vector<std::string> stack;
  std::size_t pos = 0;
  while ((pos = s.find('<', pos)) != std::string::npos) {
    const auto end = s.find('>', pos);
    if (end == std::string::npos) return false;
    std::string tag = s.substr(pos + 1, end - pos - 1);
    pos = end + 1;
    if (tag.empty() || tag[0] == '?' || tag[0] == '!') continue;
    if (tag.back() == '/') continue;
    if (tag[0] == '/') {
      const std::string name = tag.substr(1);
      if (stack.empty() || stack.back() != name) return false;
      stack.pop_back();
    } else {
      stack.push_back(tag.substr(0, tag.find_first_of(" \t\n")));
    }
  }
  return stack.empty();
}

}  // namespace

TEST(Output, GridRoundTripAndXdmf) {
  TempDir d("grid");
  const long nx = 5, ny = 4, nz = 3;
  const long n = nx * ny * nz;
  std::vector<double> rho(n), u(3 * n);
  for (long i = 0; i < n; ++i) {
    rho[i] = 1.0 + 1e-13 * i + i;
    for (int c = 0; c < 3; ++c) u[3 * i + c] = 0.1 * i - c / 3.0;
  }
  io::GridWriter w(d.str(), "fluid", {nx, ny, nz}, {0.0, -1.0, 2.0}, {0.5, 0.5, 0.5});
  const std::string f0 = w.write(0, 0.0, {{"rho", 1, rho.data(), "kg/m^3"}, {"u", 3, u.data(), "m/s"}});
  const std::string f1 = w.write(10, 0.25, {{"rho", 1, rho.data(), "kg/m^3"}, {"u", 3, u.data(), "m/s"}});
  EXPECT_EQ(fs::path(f0).filename().string(), "fluid_00000000.h5");
  EXPECT_EQ(fs::path(f1).filename().string(), "fluid_00000010.h5");
  ASSERT_EQ(w.files().size(), 2u);

  EXPECT_EQ(io::read_dataset(f1, "rho"), rho);  // bitwise: float64 round trip
  EXPECT_EQ(io::read_dataset(f1, "u"), u);
  EXPECT_THROW(io::read_dataset(f1, "nope"), Error);
  EXPECT_THROW(io::read_dataset((d.path / "missing.h5").string(), "rho"), Error);

  const std::string x = slurp(d.path / "fluid.xdmf");
  EXPECT_TRUE(balanced_xml(x)) << x;
  EXPECT_NE(x.find("CollectionType=\"Temporal\""), std::string::npos);
  EXPECT_EQ(count(x, "TopologyType=\"3DCoRectMesh\" Dimensions=\"4 5 6\""), 2u);  // nodes = cells + 1, z y x
  EXPECT_EQ(count(x, "GeometryType=\"ORIGIN_DXDYDZ\""), 2u);
  EXPECT_EQ(count(x, "Center=\"Cell\""), 4u);
  EXPECT_NE(x.find("fluid_00000000.h5:/rho"), std::string::npos);
  EXPECT_NE(x.find("fluid_00000010.h5:/u"), std::string::npos);
  EXPECT_NE(x.find("Dimensions=\"3 4 5 3\""), std::string::npos);  // vector field shape (nz ny nx 3)
  EXPECT_NE(x.find("<Time Value=\"0.25\"/>"), std::string::npos);
  // No temporary file left behind by the atomic rewrite.
  for (const auto& e : fs::directory_iterator(d.path))
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
}

TEST(Output, Grid2D) {
  TempDir d("grid2d");
  std::vector<double> phi(6 * 7);
  for (std::size_t i = 0; i < phi.size(); ++i) phi[i] = static_cast<double>(i) * 0.5;
  io::GridWriter w(d.str(), "flow", {6, 7, 1}, {0, 0, 0}, {1, 1, 1});
  const auto f = w.write(3, 1.5, {{"phi", 1, phi.data(), "1"}});
  EXPECT_EQ(io::read_dataset(f, "phi"), phi);
  const std::string x = slurp(d.path / "flow.xdmf");
  EXPECT_TRUE(balanced_xml(x));
  EXPECT_NE(x.find("Dimensions=\"2 8 7\""), std::string::npos);
}

// compare_datasets (`lbdem compare`): equal files bitwise; one value moved by
// 1e-9 shows as that difference (exact: both values are doubles), relative to
// the field's largest magnitude; a file without the dataset is named.
TEST(Output, CompareDatasets) {
  TempDir d("compare");
  std::vector<double> phi(6 * 7), u(3 * 6 * 7);
  for (std::size_t i = 0; i < phi.size(); ++i) phi[i] = 1.0 + 0.25 * static_cast<double>(i);
  for (std::size_t i = 0; i < u.size(); ++i) u[i] = -0.5 * static_cast<double>(i);
  io::GridWriter a(d.str(), "a", {6, 7, 1}, {0, 0, 0}, {1, 1, 1}), b(d.str(), "b", {6, 7, 1}, {0, 0, 0}, {1, 1, 1});
  const auto fa = a.write(0, 0.0, {{"phi", 1, phi.data(), "1"}, {"u", 3, u.data(), "1"}});
  const auto same = b.write(0, 0.0, {{"phi", 1, phi.data(), "1"}, {"u", 3, u.data(), "1"}});
  auto diffs = io::compare_datasets(fa, same);
  ASSERT_EQ(diffs.size(), 2u);
  for (const auto& x : diffs) {
    EXPECT_TRUE(x.bitwise) << x.name;
    EXPECT_EQ(x.max_abs, 0.0) << x.name;
  }
  phi[5] += 1e-9;
  const auto moved = b.write(1, 0.0, {{"phi", 1, phi.data(), "1"}, {"u", 3, u.data(), "1"}});
  diffs = io::compare_datasets(fa, moved);
  ASSERT_EQ(diffs.size(), 2u);
  EXPECT_EQ(diffs[0].name, "phi");
  EXPECT_FALSE(diffs[0].bitwise);
  EXPECT_EQ(diffs[0].max_abs, phi[5] - (1.0 + 0.25 * 5));
  EXPECT_EQ(diffs[0].scale, 1.0 + 0.25 * 41);
  EXPECT_TRUE(diffs[1].bitwise);
  io::GridWriter c(d.str(), "c", {6, 7, 1}, {0, 0, 0}, {1, 1, 1});
  const auto other = c.write(0, 0.0, {{"phi", 1, phi.data(), "1"}});
  try {
    io::compare_datasets(fa, other);
    ADD_FAILURE() << "a missing dataset was not refused";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'u'"), std::string::npos) << e.what();
  }
}

TEST(Output, ParticlesRoundTripAndXdmf) {
  TempDir d("part");
  const long n = 7;
  std::vector<double> pos(3 * n), r(n), v(3 * n);
  for (long i = 0; i < n; ++i) {
    r[i] = 0.1 * (i + 1);
    for (int c = 0; c < 3; ++c) {
      pos[3 * i + c] = i + 0.25 * c;
      v[3 * i + c] = -i * 1e-7 + c;
    }
  }
  io::ParticleWriter w(d.str(), "particles");
  const auto f = w.write(5, 2.0, n, pos.data(), {{"radius", 1, r.data()}, {"velocity", 3, v.data()}});
  EXPECT_EQ(io::read_dataset(f, "positions"), pos);
  EXPECT_EQ(io::read_dataset(f, "radius"), r);
  EXPECT_EQ(io::read_dataset(f, "velocity"), v);
  const std::string x = slurp(d.path / "particles.xdmf");
  EXPECT_TRUE(balanced_xml(x)) << x;
  EXPECT_NE(x.find("TopologyType=\"Polyvertex\" NumberOfElements=\"7\" NodesPerElement=\"1\">"), std::string::npos);
  // ParaView's Xdmf3 readers count the cells from the topology's data item:
  // it must be there, with one entry per particle, naming a dataset 0..n-1.
  const auto top = x.find("<Topology");
  const auto top_end = x.find("</Topology>", top);
  ASSERT_NE(top_end, std::string::npos) << x;
  const std::string topo = x.substr(top, top_end - top);
  EXPECT_NE(topo.find("<DataItem Dimensions=\"7\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">"
                      "particles_00000005.h5:/connectivity</DataItem>"),
            std::string::npos)
      << topo;
  EXPECT_EQ(io::read_dataset(f, "connectivity"), (std::vector<double>{0, 1, 2, 3, 4, 5, 6}));
  EXPECT_NE(x.find("GeometryType=\"XYZ\""), std::string::npos);
  EXPECT_NE(x.find("particles_00000005.h5:/positions"), std::string::npos);
  EXPECT_NE(x.find("particles_00000005.h5:/radius"), std::string::npos);
  EXPECT_NE(x.find("particles_00000005.h5:/velocity"), std::string::npos);
  EXPECT_NE(x.find("Name=\"velocity\" AttributeType=\"Vector\""), std::string::npos);
}

TEST(Output, TimeSeriesRows) {
  TempDir d("ts");
  const auto p = d.path / "forces.csv";
  {
    io::TimeSeries ts(p.string(), {"step", "time", "fx"});
    ASSERT_TRUE(ts.is_open());
    ts.append({1, 0.1, 1.0 / 3.0});
    // Flushed: the row is on disk before the series closes.
    EXPECT_NE(slurp(p).find("1,0.10000000000000001,0.33333333333333331"), std::string::npos) << slurp(p);
    ts.append({2, 0.2, -2.5e-300});
    EXPECT_THROW(ts.append({1, 2}), Error);
  }
  std::ifstream in(p);
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(in, line)) lines.push_back(line);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0], "step,time,fx");
  EXPECT_DOUBLE_EQ(std::stod(lines[1].substr(lines[1].rfind(',') + 1)), 1.0 / 3.0);
  EXPECT_EQ(std::stod(lines[2].substr(lines[2].rfind(',') + 1)), -2.5e-300);
}

TEST(Output, PrepareCreatesFolder) {
  TempDir d("prep_new");
  const auto sub = d.path / "a" / "b";
  io::prepare_output_dir(sub.string(), false);
  EXPECT_TRUE(fs::is_directory(sub));
  // Only the (empty) run manifest: the probe is removed.
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(sub)) names.push_back(e.path().filename().string());
  EXPECT_EQ(names, std::vector<std::string>{io::kManifestName});
  EXPECT_TRUE(io::read_manifest(sub.string()).empty());
  io::prepare_output_dir(sub.string(), false);    // a folder holding only a manifest counts as empty
}

TEST(Output, PrepareRefusesNonEmptyAndKeepsFiles) {
  TempDir d("prep_full");
  { std::ofstream(d.path / "old.h5") << "keep me"; }
  { std::ofstream(d.path / "notes.txt") << "mine"; }
  try {
    io::prepare_output_dir(d.str(), false);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(d.str()), std::string::npos) << msg;
    EXPECT_NE(msg.find("--overwrite"), std::string::npos) << msg;
  }
  EXPECT_EQ(slurp(d.path / "old.h5"), "keep me");
  EXPECT_EQ(slurp(d.path / "notes.txt"), "mine");
}

TEST(Output, WritersRecordEveryFileInTheManifest) {
  TempDir d("manifest");
  io::prepare_output_dir(d.str(), false);
  std::vector<double> a(4, 1.0), pos(3, 0.5);
  io::GridWriter g(d.str(), "fields", {2, 2, 1}, {0, 0, 0}, {1, 1, 1});
  g.write(0, 0.0, {{"a", 1, a.data(), ""}});
  g.write(5, 1.0, {{"a", 1, a.data(), ""}});
  g.write(5, 1.0, {{"a", 1, a.data(), ""}});  // the same step again: named once
  io::ParticleWriter p(d.str(), "particles");
  p.write(0, 0.0, 1, pos.data(), {});
  { io::TimeSeries ts((d.path / "series.csv").string(), {"step"}); }
  io::write_text_atomically((d.path / "summary.json").string(), "{}\n");
  auto m = io::read_manifest(d.str());
  std::sort(m.begin(), m.end());
  const std::vector<std::string> expect{"fields.xdmf",          "fields_00000000.h5", "fields_00000005.h5",
                                        "particles.xdmf",       "particles_00000000.h5", "series.csv",
                                        "summary.json"};
  EXPECT_EQ(m, expect);
  // Every file in the folder is named (the manifest aside), and no temporary is left.
  for (const auto& e : fs::directory_iterator(d.path)) {
    const std::string n = e.path().filename().string();
    if (n == io::kManifestName) continue;
    EXPECT_TRUE(std::binary_search(m.begin(), m.end(), n)) << n;
  }
  EXPECT_EQ(slurp(d.path / "summary.json"), "{}\n");
}

TEST(Output, OverwriteRemovesOnlyManifestFiles) {
  TempDir d("overwrite");
  const fs::path out = d.path / "run";
  io::prepare_output_dir(out.string(), false);
  std::vector<double> a(4, 1.0);
  {
    io::GridWriter g(out.string(), "fields", {2, 2, 1}, {0, 0, 0}, {1, 1, 1});
    g.write(0, 0.0, {{"a", 1, a.data(), ""}});
    io::write_text_atomically((out / "summary.json").string(), "{}");
  }
  // Temporaries a killed run left behind are ours too.
  { std::ofstream(out / "fields_00000000.h5.tmp4242") << "partial"; }
  { std::ofstream(out / "fields.xdmf.tmp17") << "partial"; }
  { std::ofstream(out / ".lbdem_write_probe_99") << "probe"; }
  io::prepare_output_dir(out.string(), true);
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(out)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{io::kManifestName});
  EXPECT_TRUE(io::read_manifest(out.string()).empty());  // a fresh manifest for the new run
}

TEST(Output, OverwriteRefusesForeignEntriesAndDeletesNothing) {
  TempDir d("foreign");
  const fs::path out = d.path / "run";
  io::prepare_output_dir(out.string(), false);
  std::vector<double> a(4, 1.0);
  io::GridWriter g(out.string(), "fields", {2, 2, 1}, {0, 0, 0}, {1, 1, 1});
  g.write(0, 0.0, {{"a", 1, a.data(), ""}});
  // The user's own things, some with our extensions, one hidden, a symlink
  // (named like one of our files) to a file outside, a folder.
  { std::ofstream(out / "mydata.csv") << "mine"; }
  { std::ofstream(out / "important.h5") << "mine"; }
  { std::ofstream(out / ".hidden") << "mine"; }
  { std::ofstream(out / "mydata.csv.tmp12") << "mine"; }  // a temporary of no file of ours
  { std::ofstream(d.path / "outside.txt") << "outside"; }
  fs::create_directories(out / "sub");
  { std::ofstream(out / "sub" / "x.h5") << "mine"; }
  fs::remove(out / "fields.xdmf");
  fs::create_symlink(d.path / "outside.txt", out / "fields.xdmf");
  try {
    io::prepare_output_dir(out.string(), true);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    for (const char* n : {"mydata.csv", "mydata.csv.tmp12", "important.h5", ".hidden", "sub", "fields.xdmf",
                          "nothing was deleted"})
      EXPECT_NE(msg.find(n), std::string::npos) << n << " not in: " << msg;
    EXPECT_EQ(msg.find("fields_00000000.h5"), std::string::npos) << msg;  // ours: not named
  }
  for (const char* n : {"mydata.csv", "important.h5", ".hidden", "fields_00000000.h5", "sub/x.h5"})
    EXPECT_TRUE(fs::exists(out / n)) << n;
  EXPECT_TRUE(fs::is_symlink(out / "fields.xdmf"));
  EXPECT_EQ(slurp(d.path / "outside.txt"), "outside");
  EXPECT_EQ(io::read_manifest(out.string()).size(), 2u);  // the manifest itself is kept as it was
}

TEST(Output, OverwriteWithoutManifestRefusesAndNamesFiles) {
  // Files an older lbdem wrote (no manifest) look like ours but cannot be told
  // from the user's: refused, named, nothing deleted.
  TempDir d("nomanifest");
  { std::ofstream(d.path / "fields_00000000.h5") << "old"; }
  { std::ofstream(d.path / "diagnostics.csv") << "old"; }
  try {
    io::prepare_output_dir(d.str(), true);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    for (const char* n : {"fields_00000000.h5", "diagnostics.csv", "no run manifest", "nothing was deleted"})
      EXPECT_NE(msg.find(n), std::string::npos) << n << " not in: " << msg;
  }
  EXPECT_EQ(slurp(d.path / "fields_00000000.h5"), "old");
  EXPECT_EQ(slurp(d.path / "diagnostics.csv"), "old");
  EXPECT_FALSE(fs::exists(d.path / io::kManifestName));
}

TEST(Output, ManifestNamesNeverReachOutsideTheFolder) {
  // A manifest naming paths with folders (edited by hand, or hostile) removes nothing outside.
  TempDir d("hostile");
  const fs::path out = d.path / "run";
  fs::create_directories(out);
  { std::ofstream(d.path / "victim.txt") << "keep"; }
  { std::ofstream(out / io::kManifestName) << "../victim.txt\n/etc/passwd\n..\n"; }
  io::prepare_output_dir(out.string(), true);
  EXPECT_EQ(slurp(d.path / "victim.txt"), "keep");
  EXPECT_TRUE(io::read_manifest(out.string()).empty());
}

TEST(Output, PrepareRefusesUnwritable) {
  // Under a regular file: fails even as root.
  TempDir d("prep_bad");
  { std::ofstream(d.path / "file") << "x"; }
  const std::string bad = (d.path / "file" / "out").string();
  try {
    io::prepare_output_dir(bad, false);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
  }
  EXPECT_THROW(io::prepare_output_dir((d.path / "file").string(), true), ConfigError);
  EXPECT_EQ(slurp(d.path / "file"), "x");
}

TEST(Output, WriterThrowsWithPathOnUnwritableFolder) {
  TempDir d("w_bad");
  { std::ofstream(d.path / "file") << "x"; }
  io::GridWriter w((d.path / "file").string(), "g", {2, 2, 1}, {0, 0, 0}, {1, 1, 1});
  std::vector<double> a(4, 1.0);
  try {
    w.write(0, 0.0, {{"a", 1, a.data(), ""}});
    FAIL() << "expected Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("g_00000000.h5"), std::string::npos) << e.what();
  }
}

namespace {
// A 64 KiB tmpfs: a disk that fills up. Needs the right to mount (root in a
// container that allows it); tests using it skip cleanly otherwise.
struct SmallDisk {
  TempDir dir{"smalldisk"};
  bool mounted = false;
  SmallDisk() {
    const std::string cmd = "mount -t tmpfs -o size=64k tmpfs '" + dir.str() + "' >/dev/null 2>&1";
    mounted = std::system(cmd.c_str()) == 0;
  }
  ~SmallDisk() {
    if (mounted) std::system(("umount '" + dir.str() + "' >/dev/null 2>&1").c_str());
  }
};
}  // namespace

TEST(Output, DiskFullIsOneLineAndLeavesNoTemporary) {
  SmallDisk disk;
  if (!disk.mounted) GTEST_SKIP() << "cannot mount a small tmpfs here";
  const std::string dir = disk.dir.str();
  io::prepare_output_dir(dir, false);
  // 32 x 32 x 16 doubles = 128 KiB: more than the disk holds.
  std::vector<double> big(32 * 32 * 16, 1.25);
  io::GridWriter g(dir, "fields", {32, 32, 16}, {0, 0, 0}, {1, 1, 1});
  testing::internal::CaptureStderr();
  std::string msg;
  try {
    g.write(0, 0.0, {{"density", 1, big.data(), ""}});
    ADD_FAILURE() << "expected ResourceError";
  } catch (const ResourceError& e) {
    msg = e.what();
  }
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(err.find("HDF5-DIAG"), std::string::npos) << err;  // the HDF5 error stack is not printed
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;           // one line
  EXPECT_NE(msg.find((fs::path(dir) / "fields_00000000.h5").string()), std::string::npos) << msg;
  EXPECT_NE(msg.find("No space left on device"), std::string::npos) << msg;
  EXPECT_NE(msg.find("errno 28"), std::string::npos) << msg;
  EXPECT_FALSE(fs::exists(fs::path(dir) / "fields_00000000.h5"));  // no truncated file under the final name
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}
