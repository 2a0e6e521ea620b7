// Field output slab by slab (GridWriter::write_slabs): the same file as the
// whole-grid write, bit for bit, for any slab size; float32 storage; and the
// slab boxes (slabs_of) hold every cell once within the size asked for.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>
#include <unistd.h>

#include "core/memory_use.hpp"
#include "core/output.hpp"

namespace fs = std::filesystem;
using namespace lbdem;

namespace {

struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& tag) {
    path = fs::temp_directory_path() / ("lbdem_test_slabs_" + tag + "_" + std::to_string(static_cast<long>(::getpid())));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string str() const { return path.string(); }
};

// Values that differ in every cell and component, with bits below float precision.
double value(Index cell, int comp) { return std::sin(0.37 * double(cell) + 1.1 * comp) * (1 + 1e-9 * double(cell)); }

}  // namespace

TEST(SlabsOf, EveryCellOnceWithinTheCap) {
  for (const std::array<int, 3> ext : {std::array<int, 3>{7, 5, 3}, {64, 1, 1}, {13, 11, 1}, {1, 1, 9}}) {
    CellBox box;
    box.lo[0] = 2;
    box.lo[1] = 1;
    box.lo[2] = 3;
    for (int a = 0; a < 3; ++a) box.ext[a] = ext[static_cast<std::size_t>(a)];
    for (Index cap : {Index{1}, Index{3}, Index{7}, Index{8}, Index{35}, Index{36}, Index{1000}}) {
      std::vector<int> hits(static_cast<std::size_t>(box.size()), 0);
      for (const CellBox& b : slabs_of(box, cap)) {
        EXPECT_LE(b.size(), cap);
        EXPECT_FALSE(b.empty());
        for (int z = b.lo[2]; z < b.lo[2] + b.ext[2]; ++z)
          for (int y = b.lo[1]; y < b.lo[1] + b.ext[1]; ++y)
            for (int x = b.lo[0]; x < b.lo[0] + b.ext[0]; ++x) {
              ASSERT_TRUE(x >= box.lo[0] && x < box.lo[0] + box.ext[0] && y >= box.lo[1] &&
                          y < box.lo[1] + box.ext[1] && z >= box.lo[2] && z < box.lo[2] + box.ext[2]);
              ++hits[static_cast<std::size_t>((x - box.lo[0]) + box.ext[0] * ((y - box.lo[1]) + box.ext[1] * (z - box.lo[2])))];
            }
      }
      for (int h : hits) ASSERT_EQ(h, 1) << "cap " << cap;
    }
  }
}

// A scalar and a vector field written whole (write) and by slabs of several
// sizes (write_slabs) read back identical; float32 storage reads back the
// values rounded to float, and the XDMF index says Precision 4 for them.
TEST(GridWriterSlabs, SlabsEqualWholeWrite) {
  TempDir dir("whole");
  const std::array<long, 3> dims{13, 7, 5};
  const Index n = dims[0] * dims[1] * dims[2];
  std::vector<double> s(static_cast<std::size_t>(n)), v(3 * s.size());
  for (Index c = 0; c < n; ++c) {
    s[static_cast<std::size_t>(c)] = value(c, 0);
    for (int a = 0; a < 3; ++a) v[static_cast<std::size_t>(3 * c + a)] = value(c, a + 1);
  }
  io::GridWriter w(dir.str(), "fields", dims, {0, 0, 0}, {1, 1, 1});
  w.write(0, 0.0, {{"s", 1, s.data(), "1"}, {"v", 3, v.data(), "m/s"}});
  const auto s0 = io::read_dataset(dir.str() + "/fields_00000000.h5", "s");
  const auto v0 = io::read_dataset(dir.str() + "/fields_00000000.h5", "v");
  ASSERT_EQ(s0, s);
  ASSERT_EQ(v0, v);
  long step = 1;
  auto fill = [&](const CellBox& b, const std::vector<double*>& out) {
    Index t = 0;
    for (int z = b.lo[2]; z < b.lo[2] + b.ext[2]; ++z)
      for (int y = b.lo[1]; y < b.lo[1] + b.ext[1]; ++y)
        for (int x = b.lo[0]; x < b.lo[0] + b.ext[0]; ++x, ++t) {
          const Index c = x + dims[0] * (y + dims[1] * z);
          out[0][t] = s[static_cast<std::size_t>(c)];
          for (int a = 0; a < 3; ++a) out[1][3 * t + a] = v[static_cast<std::size_t>(3 * c + a)];
        }
  };
  for (Index cap : {Index{1}, Index{5}, Index{13}, Index{27}, Index{91}, Index{200}, n}) {
    const std::string path = w.write_slabs(step, double(step), {{"s", 1, "1"}, {"v", 3, "m/s"}}, cap, fill);
    EXPECT_EQ(io::read_dataset(path, "s"), s0) << "cap " << cap;
    EXPECT_EQ(io::read_dataset(path, "v"), v0) << "cap " << cap;
    ++step;
  }
  w.set_float32(true);
  const std::string path = w.write_slabs(step, double(step), {{"s", 1, "1"}, {"v", 3, "m/s"}}, 17, fill);
  const auto s32 = io::read_dataset(path, "s");
  const auto v32 = io::read_dataset(path, "v");
  ASSERT_EQ(s32.size(), s.size());
  ASSERT_EQ(v32.size(), v.size());
  for (std::size_t i = 0; i < s.size(); ++i) ASSERT_EQ(s32[i], double(static_cast<float>(s[i])));
  for (std::size_t i = 0; i < v.size(); ++i) ASSERT_EQ(v32[i], double(static_cast<float>(v[i])));
  EXPECT_NE(s32, s0);  // the rounding happened
  std::ifstream in(dir.path / "fields.xdmf");
  std::stringstream x;
  x << in.rdbuf();
  const std::string xdmf = x.str();
  char tag[32];
  std::snprintf(tag, sizeof tag, "%08ld", step);
  EXPECT_NE(xdmf.find("Precision=\"4\" Format=\"HDF\">fields_" + std::string(tag) + ".h5:/s"), std::string::npos) << xdmf;
  EXPECT_NE(xdmf.find("Precision=\"8\" Format=\"HDF\">fields_00000001.h5:/s"), std::string::npos) << xdmf;
  EXPECT_LT(fs::file_size(path), fs::file_size(dir.path / "fields_00000001.h5"));
}
