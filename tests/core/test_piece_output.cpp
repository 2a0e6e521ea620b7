// Snapshot pieces (core/piece_output.hpp) without MPI: four writers, one per
// piece of a 10 x 7 x 5 grid cut 2 x 2 x 1 (uneven pieces), each handed its
// owned box in storage coordinates that start at a ghost layer, write a field
// known in closed form; the join of the pieces holds exactly that field in
// every cell (float64 and float32, bit for bit), each piece exactly its box,
// no writer or the join holds more than one slab (one piece), the index is a
// spatial collection naming every piece, the manifest names every file and
// --overwrite removes exactly them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "core/output.hpp"
#include "core/piece_output.hpp"

namespace lbdem::io {
namespace {

namespace fs = std::filesystem;

double value(long x, long y, long z, int c) { return 1.0 + 0.1 * x + 0.01 * y + 0.001 * z + 1e-4 * c + 1.0 / 3.0; }

struct Folder {
  fs::path p;
  explicit Folder(const std::string& tag) {
    p = fs::temp_directory_path() / ("lbdem_pieces_" + tag + "_" + std::to_string(static_cast<long>(::getpid())));
    fs::remove_all(p);
    prepare_output_dir(p.string(), false);
  }
  ~Folder() {
    std::error_code ec;
    fs::remove_all(p, ec);
  }
};

std::vector<PieceBox> cut() {
  // x: 4 + 6, y: 3 + 4, z: whole.
  std::vector<PieceBox> out;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) out.push_back({{i ? 4L : 0L, j ? 3L : 0L, 0L}, {i ? 6L : 4L, j ? 4L : 3L, 5L}});
  return out;
}

void write_all(const std::string& dir, bool fp32, long step, std::size_t& largest, Index slab) {
  const Grid whole = Grid::whole({10, 7, 5});
  const auto pieces = cut();
  const std::vector<SlabField> fields{{"density", 1, "lattice"}, {"velocity", 3, "lattice"}};
  std::vector<PieceGridWriter> w;
  for (int r = 0; r < 4; ++r) {
    const PieceBox& p = pieces[static_cast<std::size_t>(r)];
    CellBox owned;
    for (int a = 0; a < 3; ++a) {
      owned.lo[a] = a < 2 ? 1 : 0;  // a ghost layer on the cut axes
      owned.ext[a] = static_cast<int>(p.cells[static_cast<std::size_t>(a)]);
    }
    w.emplace_back(dir, "fields", whole, pieces, r, owned);
    w.back().set_float32(fp32);
  }
  w[0].record(step);
  for (int r = 0; r < 4; ++r) {
    const PieceBox& p = pieces[static_cast<std::size_t>(r)];
    w[static_cast<std::size_t>(r)].write_piece(step, 0.5 * step, fields, slab, [&](const CellBox& b, const std::vector<double*>& out) {
      Index t = 0;
      for (int z = b.lo[2]; z < b.lo[2] + b.ext[2]; ++z)
        for (int y = b.lo[1]; y < b.lo[1] + b.ext[1]; ++y)
          for (int x = b.lo[0]; x < b.lo[0] + b.ext[0]; ++x, ++t) {
            const long gx = x - 1 + p.offset[0], gy = y - 1 + p.offset[1], gz = z + p.offset[2];
            out[0][t] = value(gx, gy, gz, 0);
            for (int c = 0; c < 3; ++c) out[1][3 * t + c] = value(gx, gy, gz, c + 1);
          }
    });
    largest = std::max(largest, w[static_cast<std::size_t>(r)].largest_buffer_values());
  }
  w[0].index(step, 0.5 * step, fields);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class Pieces : public ::testing::TestWithParam<bool> {};

TEST_P(Pieces, JoinHoldsEveryCellAndEachPieceItsBox) {
  const bool fp32 = GetParam();
  Folder d(fp32 ? "f32" : "f64");
  const std::string dir = d.p.string();
  std::size_t largest = 0;
  constexpr Index kSlab = 7;  // cells per slab: several slabs per piece
  for (long step : {0L, 5L}) write_all(dir, fp32, step, largest, kSlab);
  EXPECT_LE(largest, static_cast<std::size_t>(3 * kSlab)) << "a writer held more than one slab";
  // Each piece: its offset, its box's cells, its values.
  const auto pieces = cut();
  long total = 0;
  for (int r = 0; r < 4; ++r) {
    const std::string f = (d.p / piece_file_name("fields", 5, r, 4)).string();
    const PieceInfo in = read_piece_info(f);
    EXPECT_EQ(in.offset, pieces[static_cast<std::size_t>(r)].offset);
    EXPECT_EQ(in.cells, pieces[static_cast<std::size_t>(r)].cells);
    EXPECT_EQ(in.global, (std::array<long, 3>{10, 7, 5}));
    EXPECT_EQ(in.rank, r);
    EXPECT_EQ(in.ranks, 4);
    total += in.cells[0] * in.cells[1] * in.cells[2];
    const auto v = read_dataset(f, "velocity");
    ASSERT_EQ(v.size(), static_cast<std::size_t>(3 * in.cells[0] * in.cells[1] * in.cells[2]));
    std::size_t k = 0;
    for (long z = 0; z < in.cells[2]; ++z)
      for (long y = 0; y < in.cells[1]; ++y)
        for (long x = 0; x < in.cells[0]; ++x)
          for (int c = 0; c < 3; ++c, ++k) {
            const double want = value(x + in.offset[0], y + in.offset[1], z + in.offset[2], c + 1);
            ASSERT_EQ(v[k], fp32 ? double(float(want)) : want) << "piece " << r;
          }
  }
  EXPECT_EQ(total, 10 * 7 * 5);
  // The index: one spatial collection per step, naming the four pieces.
  const std::string x = slurp(d.p / "fields.xdmf");
  EXPECT_NE(x.find("CollectionType=\"Spatial\""), std::string::npos);
  for (int r = 0; r < 4; ++r) EXPECT_NE(x.find(piece_file_name("fields", 5, r, 4) + ":/density"), std::string::npos) << x;
  EXPECT_NE(x.find(fp32 ? "Precision=\"4\"" : "Precision=\"8\""), std::string::npos);
  // The join: every cell once, bit for bit; one piece's field in memory at a time.
  std::size_t join_largest = 0;
  const std::string whole = join_step(dir, "fields", 5, &join_largest);
  EXPECT_EQ(fs::path(whole).filename().string(), "fields_00000005.h5");
  EXPECT_LE(join_largest, static_cast<std::size_t>(3 * 6 * 4 * 5)) << "the join held more than one piece";
  const auto rho = read_dataset(whole, "density"), u = read_dataset(whole, "velocity");
  ASSERT_EQ(rho.size(), 350u);
  ASSERT_EQ(u.size(), 3 * 350u);
  for (long z = 0, i = 0; z < 5; ++z)
    for (long y = 0; y < 7; ++y)
      for (long xx = 0; xx < 10; ++xx, ++i) {
        const double want = value(xx, y, z, 0);
        ASSERT_EQ(rho[static_cast<std::size_t>(i)], fp32 ? double(float(want)) : want) << xx << " " << y << " " << z;
        for (int c = 0; c < 3; ++c) {
          const double wu = value(xx, y, z, c + 1);
          ASSERT_EQ(u[static_cast<std::size_t>(3 * i + c)], fp32 ? double(float(wu)) : wu);
        }
      }
  EXPECT_TRUE(fs::exists(d.p / "fields_joined.xdmf"));
  EXPECT_EQ(piece_steps(dir, "fields"), (std::vector<long>{0, 5}));
  // The manifest names every file; --overwrite removes exactly them.
  const auto m = read_manifest(dir);
  for (int r = 0; r < 4; ++r)
    EXPECT_NE(std::find(m.begin(), m.end(), piece_file_name("fields", 0, r, 4)), m.end());
  for (const char* n : {"fields.xdmf", "fields_00000005.h5", "fields_joined.xdmf"})
    EXPECT_NE(std::find(m.begin(), m.end(), n), m.end()) << n;
  std::ofstream(d.p / "user_notes.txt") << "mine";
  EXPECT_THROW(prepare_output_dir(dir, true), ConfigError);  // a file lbdem did not write: nothing removed
  EXPECT_TRUE(fs::exists(d.p / "fields.xdmf"));
  fs::remove(d.p / "user_notes.txt");
  prepare_output_dir(dir, true);
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(d.p)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, (std::vector<std::string>{kManifestName}));
}

INSTANTIATE_TEST_SUITE_P(Precision, Pieces, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& i) { return i.param ? "fp32" : "fp64"; });

// Particles: per-piece files and a join that keeps every particle once.
TEST(PieceParticles, JoinConcatenatesThePieces) {
  Folder d("particles");
  const std::string dir = d.p.string();
  std::vector<PieceParticleWriter> w;
  for (int r = 0; r < 3; ++r) w.emplace_back(dir, "particles", r, 3);
  w[0].record(2);
  std::vector<long> counts{2, 0, 3};
  std::vector<std::pair<std::string, int>> names{{"id", 1}};
  long next = 0;
  for (int r = 0; r < 3; ++r) {
    const long n = counts[static_cast<std::size_t>(r)];
    std::vector<double> x(static_cast<std::size_t>(3 * n)), id(static_cast<std::size_t>(n));
    for (long i = 0; i < n; ++i, ++next) {
      id[static_cast<std::size_t>(i)] = double(next);
      for (int k = 0; k < 3; ++k) x[static_cast<std::size_t>(3 * i + k)] = 10.0 * next + k;
    }
    w[static_cast<std::size_t>(r)].write_piece(2, 1.0, n, x.data(), {{"id", 1, id.data()}});
  }
  w[0].index(2, 1.0, counts, names);
  const std::string xd = slurp(d.p / "particles.xdmf");
  EXPECT_NE(xd.find("particles_00000002_r0000.h5:/positions"), std::string::npos);
  EXPECT_EQ(xd.find("particles_00000002_r0001.h5:/positions"), std::string::npos) << "an empty piece is not indexed";
  const std::string whole = join_step(dir, "particles", 2);
  const auto id = read_dataset(whole, "id"), x = read_dataset(whole, "positions"), c = read_dataset(whole, "connectivity");
  ASSERT_EQ(id.size(), 5u);
  ASSERT_EQ(x.size(), 15u);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(id[i], double(i));
    EXPECT_EQ(c[i], double(i));
    for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(x[3 * i + k], 10.0 * double(i) + double(k));
  }
}

// A piece missing from the folder is named.
TEST(PieceJoin, MissingPieceIsNamed) {
  Folder d("missing");
  std::size_t largest = 0;
  write_all(d.p.string(), false, 3, largest, 1000);
  fs::remove(d.p / piece_file_name("fields", 3, 2, 4));
  try {
    join_step(d.p.string(), "fields", 3);
    FAIL() << "joined with a piece missing";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("fields_00000003_r0002.h5"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(d.p / "fields_00000003.h5"));
}

}  // namespace
}  // namespace lbdem::io
