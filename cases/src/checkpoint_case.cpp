// The checkpoint side of the scene drivers (cases/src/checkpoint_case.hpp).
#include "checkpoint_case.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <exception>
#include <optional>
#include <span>

#include "cfd/gas_solver.hpp"
#include "core/error.hpp"
#include "dem/system.hpp"
#include "imb/coupled.hpp"
#include "lbm/boundary.hpp"
#include "lbm/lattice.hpp"

namespace lbdem::cases {

namespace {

void save_run(ckpt::Writer& w, const RunValues& values) {
  w.section("run");
  w.put_vector(values);
}

RunValues load_run(ckpt::Reader& r) {
  r.section("run");
  return r.get_vector<double>(1 << 16);
}

}  // namespace

ckpt::Identity fluid_identity(const std::string& scene, const lbm::LbmSetup& s) {
  const auto& g = s.domain.global;
  const auto& p = s.domain.periodic;
  ckpt::Identity id;
  id.add("scene", scene)
      .add("lattice", lbm::to_string(s.lattice))
      .add("precision", lbm::to_string(s.precision))
      .add("streaming", lbm::to_string(s.streaming))
      .add("collision", lbm::to_string(s.collision))
      .add("grid", std::to_string(g[0]) + "x" + std::to_string(g[1]) + "x" + std::to_string(g[2]))
      .add("periodic", std::string(p[0] ? "1" : "0") + (p[1] ? "1" : "0") + (p[2] ? "1" : "0"));
  return id;
}

void save_coupled(ckpt::Writer& w, lbm::LbmSolver& fluid, const dem::DemSystem& dem, const imb::CoupledSolver& cs,
                  const RunValues& values) {
  save_run(w, values);
  w.section("lbm");
  fluid.save_state(w);
  w.section("dem");
  dem.save_state(w);
  w.section("coupling");
  cs.save_state(w);
}

RunValues load_coupled(ckpt::Reader& r, lbm::LbmSolver& fluid, dem::DemSystem& dem, imb::CoupledSolver& cs) {
  RunValues v = load_run(r);
  r.section("lbm");
  fluid.load_state(r);
  r.section("dem");
  dem.load_state(r);
  r.section("coupling");
  cs.load_state(r);
  r.finish();
  return v;
}

void save_fluid(ckpt::Writer& w, lbm::LbmSolver& fluid, const RunValues& values) {
  save_run(w, values);
  w.section("lbm");
  fluid.save_state(w);
}

RunValues load_fluid(ckpt::Reader& r, lbm::LbmSolver& fluid) {
  RunValues v = load_run(r);
  r.section("lbm");
  fluid.load_state(r);
  r.finish();
  return v;
}

void save_dem(ckpt::Writer& w, const dem::DemSystem& dem, const RunValues& values) {
  save_run(w, values);
  w.section("dem");
  dem.save_state(w);
}

RunValues load_dem(ckpt::Reader& r, dem::DemSystem& dem) {
  RunValues v = load_run(r);
  r.section("dem");
  dem.load_state(r);
  r.finish();
  return v;
}

void save_bed(ckpt::Writer& w, const cfd::GasSolver& gas, const dem::DemSystem& dem, const RunValues& values) {
  save_run(w, values);
  w.section("gas");
  gas.save_state(w);
  w.section("dem");
  dem.save_state(w);
}

RunValues load_bed(ckpt::Reader& r, cfd::GasSolver& gas, dem::DemSystem& dem) {
  RunValues v = load_run(r);
  r.section("gas");
  gas.load_state(r);
  r.section("dem");
  dem.load_state(r);
  r.finish();
  return v;
}

io::TimeSeries open_series(const ckpt::Run& run, const std::string& path, const std::vector<std::string>& columns,
                           long interval) {
  const auto rows = run.kept_rows(path, columns, interval);
  io::TimeSeries ts(path, columns);
  for (const auto& row : rows) ts.append(row);
  return ts;
}

void prepare_output_on_writer(ckpt::Run& run, bool writer, const halo::Comm& comm, bool overwrite,
                              const std::string& outdir) {
  std::exception_ptr failed;
  if (writer) {
    try {
      run.prepare_output(overwrite);
    } catch (...) {
      failed = std::current_exception();
    }
  }
  if (comm.any(failed != nullptr)) {
    if (failed) std::rethrow_exception(failed);
    throw Error("rank 0 could not prepare the output directory " + outdir);
  }
}

// ---------------------------------------------------------------------------
// Several ranks
// ---------------------------------------------------------------------------
namespace {

// Tag of the messages that carry a rank's sections to rank 0 and back (Comm::exchange).
constexpr int kSectionTag = 7001;
// Bytes a rank sends to rank 0, or rank 0 broadcasts, at a time.
constexpr std::size_t kChunkBytes = std::size_t{4} << 20;
constexpr std::uint32_t kTagPiece = 0x4c425031;  // "LBP1": the layout of a fluid piece

int lattice_q(const lbm::LbmSetup& s) { return s.lattice == lbm::LatticeKind::D2Q9 ? 9 : 19; }

// Lattice velocities c_q of the set-up's lattice.
std::vector<std::array<int, 3>> lattice_c(const lbm::LbmSetup& s) {
  std::vector<std::array<int, 3>> c;
  auto fill = [&](auto lat) {
    using L = decltype(lat);
    for (int q = 0; q < L::Q; ++q) c.push_back({L::c(q, 0), L::c(q, 1), L::c(q, 2)});
  };
  if (s.lattice == lbm::LatticeKind::D2Q9) fill(lbm::D2Q9{});
  else fill(lbm::D3Q19{});
  return c;
}

// Rank 0's part of a collective step that can fail: every rank learns
// whether it did; rank 0 rethrows its error, the others throw ConfigError
// (the CLI prints rank 0's line only).
void agree(const halo::Comm& comm, const std::exception_ptr& failed, const std::string& what) {
  if (!comm.any(failed != nullptr)) return;
  if (failed) std::rethrow_exception(failed);
  throw ConfigError("rank 0 could not " + what);
}

// The rank count a checkpoint was written on (1: a one-rank checkpoint, whose header has no layout lines).
int file_ranks(ckpt::Reader& r) {
  const std::string v = r.meta("ranks");
  if (v.empty()) return 1;
  try {
    const int k = std::stoi(v);
    if (k >= 1) return k;
  } catch (const std::exception&) {
  }
  r.mismatch("a rank count '" + v + "' in the header");
}

// Point-to-point between rank 0 and rank `peer`: one chunk each way (an empty one to the side that only receives).
std::vector<std::byte> swap_chunk(const halo::Comm& comm, int peer, std::vector<std::byte> out) {
  const int tag = kSectionTag;
  std::vector<std::vector<std::byte>> send(1);
  send[0] = std::move(out);
  auto got = comm.exchange(std::span<const int>(&peer, 1), std::span<const int>(&tag, 1), send,
                           std::span<const int>(&tag, 1));
  return std::move(got[0]);
}

// A chunked section (SharedWriter::rank_sections): chunks of (u64 length, bytes), ended by a zero length.
class ChunkSource final : public ckpt::Source {
 public:
  explicit ChunkSource(ckpt::Source& in) : in_(in) {}
  void read(void* data, std::size_t bytes) override {
    auto* p = static_cast<std::byte*>(data);
    while (bytes > 0) {
      if (left_ == 0) {
        left_ = in_.get<std::uint64_t>();
        if (left_ == 0) mismatch("its data end early");
      }
      const auto k = static_cast<std::size_t>(std::min<std::uint64_t>(left_, bytes));
      in_.read(p, k);
      p += k;
      bytes -= k;
      left_ -= k;
    }
  }
  [[noreturn]] void mismatch(const std::string& what) const override {
    in_.mismatch(what);
    throw Error(what);  // not reached: the source throws
  }
  // The section read to its end.
  void finish() {
    if (left_ != 0 || in_.get<std::uint64_t>() != 0) in_.mismatch("bytes left unread at the end of a rank's section");
  }

 private:
  ckpt::Source& in_;
  std::uint64_t left_ = 0;
};

// Bytes in memory as a section.
class BytesSource final : public ckpt::Source {
 public:
  explicit BytesSource(const std::vector<std::byte>& b) : b_(b) {}
  void read(void* data, std::size_t bytes) override {
    if (at_ + bytes > b_.size()) mismatch("its data end early");
    std::memcpy(data, b_.data() + at_, bytes);
    at_ += bytes;
  }
  // Printed by every rank (the CLI prints only rank 0's ConfigError).
  [[noreturn]] void mismatch(const std::string& what) const override {
    throw Error("restart: a part of the checkpoint does not fit this run: " + what);
  }
  bool done() const { return at_ == b_.size(); }

 private:
  const std::vector<std::byte>& b_;
  std::size_t at_ = 0;
};

}  // namespace

ckpt::Identity rank_layout(int ranks, const std::string& dims) {
  ckpt::Identity l;
  l.add("ranks", std::to_string(ranks)).add("decomposition", dims);
  return l;
}

ckpt::Run open_run(const std::string& outdir, const ckpt::Policy& policy, const ckpt::Identity& id,
                   const std::optional<std::string>& restart, const halo::Comm& comm) {
  if (!comm.distributed()) return ckpt::Run(outdir, policy, id, restart);
  std::exception_ptr failed;
  std::optional<ckpt::Run> run;
  if (comm.root()) {
    try {
      run.emplace(outdir, policy, id, restart);
    } catch (...) {
      failed = std::current_exception();
    }
  } else {
    run.emplace(outdir, policy, id, std::nullopt);
  }
  agree(comm, failed, "open the checkpoint to restart from");
  if (restart) {
    const long step = comm.max(comm.root() ? run->restart_step() : 0L);
    if (!comm.root()) run->follow(step);
  }
  return std::move(*run);
}

// Rank 0's sink: the writer, until a write fails; then the bytes still to
// come are dropped (the other ranks are still sending) and commit() reports.
struct SharedWriter::State {
  struct Guard final : ckpt::Sink {
    State* st = nullptr;
    void write(const void* data, std::size_t bytes) override {
      if (st->failed || !st->w) return;
      try {
        st->w->write(data, bytes);
      } catch (...) {
        st->failed = std::current_exception();
      }
    }
  };
  // Bytes gathered into chunks of kChunkBytes; flush() passes a chunk on.
  struct Chunking : ckpt::Sink {
    std::vector<std::byte> buf;
    void write(const void* data, std::size_t bytes) override {
      const auto* p = static_cast<const std::byte*>(data);
      while (bytes > 0) {
        const std::size_t k = std::min(bytes, kChunkBytes - buf.size());
        buf.insert(buf.end(), p, p + k);
        p += k;
        bytes -= k;
        if (buf.size() == kChunkBytes) flush();
      }
    }
    virtual void flush() = 0;
  };
  // A rank other than 0: chunks sent to rank 0.
  struct Forward final : Chunking {
    const halo::Comm* comm = nullptr;
    // (An empty chunk ends the rank's section.)
    void flush() override {
      swap_chunk(*comm, 0, std::move(buf));
      buf.clear();
    }
  };
  // Rank 0's own data of a chunked section: chunks of up to kChunkBytes.
  struct Chunks final : Chunking {
    Guard* guard = nullptr;
    void flush() override {
      if (buf.empty()) return;
      guard->put<std::uint64_t>(buf.size());
      guard->write(buf.data(), buf.size());
      buf.clear();
    }
  };
  std::unique_ptr<ckpt::Writer> w;
  std::exception_ptr failed;
  Guard guard;
  Forward fwd;
  Chunks chunks;
};

SharedWriter::SharedWriter(ckpt::Run& run, const halo::Comm& comm, long step, double time)
    : run_(run), comm_(comm), step_(step), st_(std::make_unique<State>()) {
  st_->guard.st = st_.get();
  st_->fwd.comm = &comm;
  st_->chunks.guard = &st_->guard;
  if (comm.root()) {
    try {
      st_->w = run.open_writer(step, time);
    } catch (...) {
      st_->failed = std::current_exception();
    }
  }
}

SharedWriter::~SharedWriter() = default;

void SharedWriter::begin(const std::string& name) {
  if (st_->failed || !st_->w) return;
  try {
    st_->w->section(name);
  } catch (...) {
    st_->failed = std::current_exception();
  }
}

ckpt::Sink& SharedWriter::sink() { return st_->guard; }

ckpt::Sink& SharedWriter::chunk_sink() {
  st_->chunks.buf.clear();
  return st_->chunks;
}

void SharedWriter::close_chunks() {
  st_->chunks.flush();
  st_->guard.put<std::uint64_t>(0);
  st_->chunks.buf = {};
}

void SharedWriter::receive(const std::string& name, int rank, bool chunked) {
  begin(name);
  for (;;) {
    const auto got = swap_chunk(comm_, rank, {});
    if (got.empty()) break;
    if (chunked) st_->guard.put<std::uint64_t>(got.size());
    st_->guard.write(got.data(), got.size());
  }
  if (chunked) st_->guard.put<std::uint64_t>(0);
}

ckpt::Sink& SharedWriter::forward() {
  st_->fwd.buf.clear();
  st_->fwd.buf.reserve(kChunkBytes);
  return st_->fwd;
}

void SharedWriter::close_forward() {
  if (!st_->fwd.buf.empty()) st_->fwd.flush();
  st_->fwd.flush();  // the empty chunk: the end
  st_->fwd.buf = {};
}

void SharedWriter::commit() {
  if (comm_.root() && !st_->failed && st_->w) {
    try {
      st_->w->commit();
    } catch (...) {
      st_->failed = std::current_exception();
    }
  }
  agree(comm_, st_->failed, "write the checkpoint");
  run_.written(step_);
}

void save_fluid_piece(ckpt::Sink& out, lbm::LbmSolver& fluid) {
  const lbm::LbmSetup& s = fluid.setup();
  const Grid& p = s.domain;
  const GridView g = p.view();
  const CellBox o = p.owned();
  const int q_count = lattice_q(s), tb = fluid.storage_bytes();
  out.put<std::uint32_t>(kTagPiece);
  for (int a = 0; a < 3; ++a) out.put<std::int64_t>(p.offset[static_cast<std::size_t>(a)]);
  for (int a = 0; a < 3; ++a) out.put<std::int64_t>(p.local[static_cast<std::size_t>(a)]);
  out.put<std::int32_t>(q_count);
  out.put<std::int32_t>(tb);
  out.put<std::int32_t>(static_cast<std::int32_t>(s.streaming));
  out.put<std::int64_t>(fluid.steps_done());
  // Owned rows of a storage array, x fastest.
  auto rows = [&](const std::byte* a, std::size_t bytes) {
    for (int z = 0; z < o.ext[2]; ++z)
      for (int y = 0; y < o.ext[1]; ++y) {
        const auto c = static_cast<std::size_t>(g.index(o.lo[0], y + o.lo[1], z + o.lo[2]));
        out.write(a + c * bytes, static_cast<std::size_t>(o.ext[0]) * bytes);
      }
  };
  std::vector<std::uint8_t> flags(static_cast<std::size_t>(g.n));
  fluid.read_flags(flags.data());
  rows(reinterpret_cast<const std::byte*>(flags.data()), 1);
  // Ghost copies of boundary cells: the reflections this piece's fluid cells
  // stored there (lbm/kernels.hpp: a reflected value goes into the boundary
  // cell's slot, which the same fluid cell reads next step; on a cut grid
  // that slot lies in the writer's ghost copy, not in the owner's cell).
  std::vector<std::int32_t> where;  // global coordinates
  std::vector<std::size_t> at;      // storage index
  for (int z = 0; z < g.nz; ++z)
    for (int y = 0; y < g.ny; ++y)
      for (int x = 0; x < g.nx; ++x) {
        const int c[3] = {x, y, z};
        bool owned = true;
        for (int a = 0; a < 3; ++a)
          if (c[a] < o.lo[a] || c[a] >= o.lo[a] + o.ext[a]) owned = false;
        const auto i = static_cast<std::size_t>(g.index(x, y, z));
        if (owned || !lbm::reflects(flags[i])) continue;
        for (int a = 0; a < 3; ++a) {
          const auto ua = static_cast<std::size_t>(a);
          long w = c[a] + p.offset[ua] - p.ghost_on(a);
          w = (w % p.global[ua] + p.global[ua]) % p.global[ua];
          where.push_back(static_cast<std::int32_t>(w));
        }
        at.push_back(i);
      }
  std::vector<std::byte> slot(static_cast<std::size_t>(g.n) * static_cast<std::size_t>(tb));
  std::vector<std::byte> ghosts(at.size() * static_cast<std::size_t>(q_count) * static_cast<std::size_t>(tb));
  for (int q = 0; q < q_count; ++q) {
    fluid.read_slot(q, slot.data());
    rows(slot.data(), static_cast<std::size_t>(tb));
    for (std::size_t k = 0; k < at.size(); ++k)
      std::memcpy(ghosts.data() + (static_cast<std::size_t>(q) * at.size() + k) * static_cast<std::size_t>(tb),
                  slot.data() + at[k] * static_cast<std::size_t>(tb), static_cast<std::size_t>(tb));
  }
  out.put<std::uint64_t>(at.size());
  if (!where.empty()) out.write(where.data(), where.size() * sizeof(std::int32_t));
  if (!ghosts.empty()) out.write(ghosts.data(), ghosts.size());
}

void save_fluid(ckpt::Run& run, const halo::Comm& comm, long step, double time, lbm::LbmSolver& fluid,
                const RunValues& values) {
  if (!comm.distributed()) {
    run.write(step, time, [&](ckpt::Writer& w) { save_fluid(w, fluid, values); });
    return;
  }
  SharedWriter w(run, comm, step, time);
  w.root_section("run", [&](ckpt::Sink& out) { out.put_vector(values); });
  w.rank_sections("lbm", [&](ckpt::Sink& out) { save_fluid_piece(out, fluid); });
  w.commit();
}

RunValues load_run_shared(ckpt::Run& run, const halo::Comm& comm) {
  std::vector<std::byte> bytes;
  std::exception_ptr failed;
  if (comm.root()) {
    try {
      const RunValues v = load_run(run.reader());
      bytes.resize(v.size() * sizeof(double));
      if (!v.empty()) std::memcpy(bytes.data(), v.data(), bytes.size());
    } catch (...) {
      failed = std::current_exception();
    }
  }
  agree(comm, failed, "read the checkpoint");
  comm.broadcast(bytes, 0);
  RunValues v(bytes.size() / sizeof(double));
  if (!v.empty()) std::memcpy(v.data(), bytes.data(), bytes.size());
  return v;
}

namespace {

// What rank 0 broadcasts while it reads the fluid sections: a slab of slot q
// of the cells of a global box (x fastest, in the storage precision) follows
// the head; `done` ends it with the step count; `failed` says rank 0 refused.
struct SlabHead {
  std::int32_t kind = 0;  // 0 slab, 1 done, 2 failed, 3 boundary cells (below)
  std::int32_t q = 0;
  std::int64_t t = 0;
  std::int32_t lo[3] = {0, 0, 0};
  std::int32_t ext[3] = {0, 0, 0};
  // The owned box of the piece the values come from (global).
  std::int32_t src_lo[3] = {0, 0, 0};
  std::int32_t src_ext[3] = {0, 0, 0};
  // kind 3: `count` ghost copies of boundary cells of that piece follow:
  // their global coordinates (3 x i32 each), then slot by slot their values.
  std::int64_t count = 0;
};

// Boxes of whole rows of `box` (x fastest: each box's cells follow the
// previous box's in the box's own order) of at most `cap` cells where rows allow.
std::vector<CellBox> row_slabs(const CellBox& box, Index cap) {
  std::vector<CellBox> out;
  if (box.empty()) return out;
  const Index row = box.ext[0], plane = row * box.ext[1];
  if (plane <= cap) {
    const int planes = static_cast<int>(std::max<Index>(1, cap / plane));
    for (int z = 0; z < box.ext[2]; z += planes) {
      CellBox b = box;
      b.lo[2] = box.lo[2] + z;
      b.ext[2] = std::min(planes, box.ext[2] - z);
      out.push_back(b);
    }
    return out;
  }
  const int rows = static_cast<int>(std::max<Index>(1, cap / row));
  for (int z = 0; z < box.ext[2]; ++z)
    for (int y = 0; y < box.ext[1]; y += rows) {
      CellBox b = box;
      b.lo[1] = box.lo[1] + y;
      b.ext[1] = std::min(rows, box.ext[1] - y);
      b.lo[2] = box.lo[2] + z;
      b.ext[2] = 1;
      out.push_back(b);
    }
  return out;
}

// The storage coordinates along axis a of `p` that hold global cell g (the
// owned cell or ghost copies, periodic images included): at most 3.
int images(const Grid& p, int a, long g, int* out) {
  const auto ua = static_cast<std::size_t>(a);
  const long base = p.offset[ua] - p.ghost_on(a);
  const long n = p.local[ua] + 2L * p.ghost_on(a);
  int k = 0;
  for (long shift : {0L, -p.global[ua], p.global[ua]}) {
    if (shift != 0 && !p.periodic[ua]) continue;
    const long s = g - base + shift;
    if (s >= 0 && s < n) out[k++] = static_cast<int>(s);
  }
  return k;
}

std::string flag_name(std::uint8_t f) { return f == 0 ? "fluid" : "boundary entry " + std::to_string(f); }

}  // namespace

void load_fluid_shared(ckpt::Run& run, const halo::Comm& comm, lbm::LbmSolver& fluid, const Grid& whole,
                       const std::vector<std::uint8_t>& flags) {
  const lbm::LbmSetup& s = fluid.setup();
  const Grid& p = s.domain;
  const GridView g = p.view();
  const int q_count = lattice_q(s);
  const auto tb = static_cast<std::size_t>(fluid.storage_bytes());
  const auto cells = static_cast<std::size_t>(g.n);
  // This rank's slots, read first so that cells no slab names (ghosts of
  // boundary cells, beyond walled ends) keep what initialize() gave them.
  std::vector<std::byte> pop(static_cast<std::size_t>(q_count) * cells * tb);
  for (int q = 0; q < q_count; ++q) fluid.read_slot(q, pop.data() + static_cast<std::size_t>(q) * cells * tb);
  std::vector<std::uint8_t> mine_flags(cells);
  fluid.read_flags(mine_flags.data());
  const CellBox own = p.owned();
  auto is_owned = [&](int a, int c) { return c >= own.lo[a] && c < own.lo[a] + own.ext[a]; };
  const auto cq = lattice_c(s);
  // The slot q of boundary cell b (global) holds the reflection stored by the
  // fluid cell b + c_q (two-lattice) or b - c_q (A-A): the piece that owns
  // that cell has it. A writer beyond a closed face: any piece (the slot is
  // never read).
  const int sigma = s.streaming == lbm::StreamKind::TwoLattice ? 1 : -1;
  auto writer_in = [&](const SlabHead& h, const long* b, int q) {
    for (int a = 0; a < 3; ++a) {
      const auto ua = static_cast<std::size_t>(a);
      long x = b[a] + sigma * cq[static_cast<std::size_t>(q)][ua];
      if (x < 0 || x >= whole.global[ua]) {
        if (!whole.periodic[ua]) return true;
        x = (x % whole.global[ua] + whole.global[ua]) % whole.global[ua];
      }
      if (x < h.src_lo[a] || x >= h.src_lo[a] + h.src_ext[a]) return false;
    }
    return true;
  };
  std::int64_t steps = -1;
  // One slab: each cell's values go to the storage cells that hold it (the
  // owned cell; a ghost copy only where it copies a fluid cell).
  auto place = [&](const std::vector<std::byte>& msg) {
    SlabHead h;
    std::memcpy(&h, msg.data(), sizeof h);
    if (h.kind == 3) {
      // Ghost copies of boundary cells of the source piece: the slots its fluid cells wrote.
      const auto n = static_cast<std::size_t>(h.count);
      if (h.count < 0 || msg.size() != sizeof h + n * (3 * sizeof(std::int32_t) + static_cast<std::size_t>(q_count) * tb))
        throw Error("restart: boundary cells of the fluid state of the wrong size reached rank " +
                    std::to_string(comm.rank()));
      std::vector<std::int32_t> xyz(3 * n);
      std::memcpy(xyz.data(), msg.data() + sizeof h, xyz.size() * sizeof(std::int32_t));
      const std::byte* vals = msg.data() + sizeof h + xyz.size() * sizeof(std::int32_t);
      int im[3][3], cnt[3];
      for (std::size_t k = 0; k < n; ++k) {
        const long b[3] = {xyz[3 * k], xyz[3 * k + 1], xyz[3 * k + 2]};
        for (int a = 0; a < 3; ++a) cnt[a] = images(p, a, b[a], im[a]);
        for (int q = 0; q < q_count; ++q) {
          if (!writer_in(h, b, q)) continue;
          const std::byte* src = vals + (static_cast<std::size_t>(q) * n + k) * tb;
          std::byte* dst = pop.data() + static_cast<std::size_t>(q) * cells * tb;
          for (int kz = 0; kz < cnt[2]; ++kz)
            for (int ky = 0; ky < cnt[1]; ++ky)
              for (int kx = 0; kx < cnt[0]; ++kx) {
                const auto c = static_cast<std::size_t>(g.index(im[0][kx], im[1][ky], im[2][kz]));
                if (lbm::reflects(mine_flags[c])) std::memcpy(dst + c * tb, src, tb);
              }
        }
      }
      return;
    }
    CellBox b;
    for (int a = 0; a < 3; ++a) {
      b.lo[a] = h.lo[a];
      b.ext[a] = h.ext[a];
    }
    if (h.q < 0 || h.q >= q_count || msg.size() != sizeof h + static_cast<std::size_t>(b.size()) * tb)
      throw Error("restart: a slab of the fluid state of the wrong size reached rank " + std::to_string(comm.rank()));
    const std::byte* v = msg.data() + sizeof h;
    std::byte* dst = pop.data() + static_cast<std::size_t>(h.q) * cells * tb;
    int ix[3], iy[3], iz[3];
    std::size_t k = 0;
    for (int z = 0; z < b.ext[2]; ++z) {
      const int nz = images(p, 2, b.lo[2] + z, iz);
      for (int y = 0; y < b.ext[1]; ++y) {
        const int ny = images(p, 1, b.lo[1] + y, iy);
        for (int x = 0; x < b.ext[0]; ++x, ++k) {
          if (nz == 0 || ny == 0) continue;
          const int nx = images(p, 0, b.lo[0] + x, ix);
          for (int kz = 0; kz < nz; ++kz)
            for (int ky = 0; ky < ny; ++ky)
              for (int kx = 0; kx < nx; ++kx) {
                const auto c = static_cast<std::size_t>(g.index(ix[kx], iy[ky], iz[kz]));
                const std::uint8_t f = mine_flags[c];
                if (lbm::reflects(f)) {
                  // A boundary cell (owned or a ghost copy): the slot its writer's piece holds.
                  const long gb[3] = {b.lo[0] + x, b.lo[1] + y, b.lo[2] + z};
                  if (!writer_in(h, gb, h.q)) continue;
                } else {
                  const bool owned = is_owned(0, ix[kx]) && is_owned(1, iy[ky]) && is_owned(2, iz[kz]);
                  if (!owned && f != lbm::kGhostFlag) continue;
                }
                std::memcpy(dst + c * tb, v + k * tb, tb);
              }
        }
      }
    }
  };
  if (comm.root()) {
    std::exception_ptr failed;
    try {
      ckpt::Reader& r = run.reader();
      const GridView gw = whole.view();
      // Flags of the cells of `box` (global), x fastest, against the case's.
      auto read_flags = [&](const CellBox& box) {
        std::vector<std::uint8_t> f;
        for (const CellBox& b : row_slabs(box, static_cast<Index>(kChunkBytes))) {
          f.resize(static_cast<std::size_t>(b.size()));
          r.read(f.data(), f.size());
          if (flags.empty()) continue;
          for (Index t = 0; t < b.size(); ++t) {
            int x, y, z;
            b.coords(t, x, y, z);
            const std::uint8_t want = flags[static_cast<std::size_t>(gw.index(x, y, z))];
            const std::uint8_t got = f[static_cast<std::size_t>(t)];
            if (got != want)
              r.mismatch("cell (" + std::to_string(x) + ", " + std::to_string(y) + ", " + std::to_string(z) + ") is " +
                         flag_name(got) + " in the checkpoint and " + flag_name(want) + " in this case (another geometry)");
          }
        }
      };
      // Slot q of the cells of `box` (global), x fastest: broadcast a slab at a time.
      const Index cap = std::max<Index>(1, static_cast<Index>(kChunkBytes / tb));
      auto read_slot = [&](int q, const CellBox& box, std::int64_t t) {
        for (const CellBox& b : row_slabs(box, cap)) {
          SlabHead h;
          h.q = q;
          h.t = t;
          for (int a = 0; a < 3; ++a) {
            h.lo[a] = b.lo[a];
            h.ext[a] = b.ext[a];
            h.src_lo[a] = box.lo[a];
            h.src_ext[a] = box.ext[a];
          }
          const std::size_t n = static_cast<std::size_t>(b.size()) * tb;
          std::vector<std::byte> msg(sizeof h + n);
          std::memcpy(msg.data(), &h, sizeof h);
          r.read(msg.data() + sizeof h, n);
          comm.broadcast(msg, 0);
          place(msg);
        }
      };
      auto skip = [&](std::uint64_t bytes) {
        std::vector<std::byte> tmp(static_cast<std::size_t>(std::min<std::uint64_t>(bytes, kChunkBytes)));
        while (bytes > 0) {
          const auto k = static_cast<std::size_t>(std::min<std::uint64_t>(bytes, tmp.size()));
          r.read(tmp.data(), k);
          bytes -= k;
        }
      };
      const int ranks = file_ranks(r);
      if (ranks == 1) {
        // A one-rank checkpoint: the raw section (LbmSolver::save_state) of the whole grid.
        r.section("lbm");
        r.expect<std::int32_t>(q_count, "the lattice's velocity count Q");
        r.expect<std::int32_t>(static_cast<std::int32_t>(tb), "the population precision (bytes)");
        r.expect<std::int32_t>(static_cast<std::int32_t>(s.streaming), "the streaming scheme");
        r.expect<std::int64_t>(gw.n, "the grid's cell count");
        const auto stride = r.get<std::int64_t>();
        const auto t = r.get<std::int64_t>();
        if (stride < gw.n || t < 0) r.mismatch("a population stride or step count out of range");
        CellBox all;
        for (int a = 0; a < 3; ++a) all.ext[a] = static_cast<int>(whole.global[static_cast<std::size_t>(a)]);
        r.expect<std::uint64_t>(static_cast<std::uint64_t>(gw.n), "the flag count");
        read_flags(all);
        r.expect<std::uint64_t>(static_cast<std::uint64_t>(stride) * static_cast<std::uint64_t>(q_count),
                                "the population count");
        for (int q = 0; q < q_count; ++q) {
          read_slot(q, all, t);  // the whole grid is one piece: every slot of it
          skip(static_cast<std::uint64_t>(stride - gw.n) * tb);
        }
        if (s.streaming == lbm::StreamKind::TwoLattice) {
          // The second array: rewritten by the next step before it is read.
          const auto n = r.get<std::uint64_t>();
          if (n != static_cast<std::uint64_t>(stride) * static_cast<std::uint64_t>(q_count))
            r.mismatch("a second population array of another size");
          skip(n * tb);
        }
        steps = t;
      } else {
        for (int k = 0; k < ranks; ++k) {
          r.section("lbm." + std::to_string(k));
          r.expect<std::uint32_t>(kTagPiece, "the fluid piece's layout tag");
          CellBox box;
          std::int64_t lo[3], ext[3];
          for (auto& v : lo) v = r.get<std::int64_t>();
          for (auto& v : ext) v = r.get<std::int64_t>();
          for (int a = 0; a < 3; ++a) {
            const long n = whole.global[static_cast<std::size_t>(a)];
            if (lo[a] < 0 || ext[a] < 1 || lo[a] + ext[a] > n) r.mismatch("a piece outside the grid");
            box.lo[a] = static_cast<int>(lo[a]);
            box.ext[a] = static_cast<int>(ext[a]);
          }
          r.expect<std::int32_t>(q_count, "the lattice's velocity count Q");
          r.expect<std::int32_t>(static_cast<std::int32_t>(tb), "the population precision (bytes)");
          r.expect<std::int32_t>(static_cast<std::int32_t>(s.streaming), "the streaming scheme");
          const auto t = r.get<std::int64_t>();
          if (t < 0 || (k > 0 && t != steps)) r.mismatch("pieces at different step counts");
          steps = t;
          read_flags(box);
          for (int q = 0; q < q_count; ++q) read_slot(q, box, t);
          // Its ghost copies of boundary cells, in slabs of whole records.
          const auto count = r.get<std::uint64_t>();
          const std::size_t rec = 3 * sizeof(std::int32_t) + static_cast<std::size_t>(q_count) * tb;
          if (count > static_cast<std::uint64_t>(gw.n) * 27) r.mismatch("a boundary-cell count out of range");
          SlabHead h;
          h.kind = 3;
          h.t = t;
          h.count = static_cast<std::int64_t>(count);
          for (int a = 0; a < 3; ++a) {
            h.src_lo[a] = box.lo[a];
            h.src_ext[a] = box.ext[a];
          }
          std::vector<std::byte> msg(sizeof h + static_cast<std::size_t>(count) * rec);
          std::memcpy(msg.data(), &h, sizeof h);
          if (count > 0) r.read(msg.data() + sizeof h, msg.size() - sizeof h);
          comm.broadcast(msg, 0);
          place(msg);
        }
      }
    } catch (...) {
      failed = std::current_exception();
    }
    SlabHead end;
    end.kind = failed ? 2 : 1;
    end.t = steps;
    std::vector<std::byte> msg(sizeof end);
    std::memcpy(msg.data(), &end, sizeof end);
    comm.broadcast(msg, 0);
    if (failed) std::rethrow_exception(failed);
  } else {
    for (;;) {
      std::vector<std::byte> msg;
      comm.broadcast(msg, 0);
      SlabHead h;
      if (msg.size() < sizeof h) throw Error("restart: a short message from rank 0");
      std::memcpy(&h, msg.data(), sizeof h);
      if (h.kind == 2) throw ConfigError("rank 0 could not read the checkpoint");
      if (h.kind == 1) {
        steps = h.t;
        break;
      }
      place(msg);
    }
  }
  for (int q = 0; q < q_count; ++q) fluid.write_slot(q, pop.data() + static_cast<std::size_t>(q) * cells * tb);
  fluid.set_steps_done(steps);
}

RunValues load_fluid(ckpt::Run& run, const halo::Comm& comm, lbm::LbmSolver& fluid, const Grid& whole,
                     const std::vector<std::uint8_t>& flags) {
  if (!comm.distributed() && file_ranks(run.reader()) == 1) return load_fluid(run.reader(), fluid);
  RunValues v = load_run_shared(run, comm);
  load_fluid_shared(run, comm, fluid, whole, flags);
  if (comm.root()) run.reader().finish();
  return v;
}

void save_dem(ckpt::Run& run, const halo::Comm& comm, long step, double time, const dem::DemSystem& dem,
              const RunValues& values) {
  if (!comm.distributed()) {
    run.write(step, time, [&](ckpt::Writer& w) { save_dem(w, dem, values); });
    return;
  }
  SharedWriter w(run, comm, step, time);
  w.root_section("run", [&](ckpt::Sink& out) { out.put_vector(values); });
  w.rank_sections("dem", [&](ckpt::Sink& out) { dem.save_state(out); }, true);
  w.commit();
}

void load_dem_shared(ckpt::Run& run, const halo::Comm& comm, dem::DemSystem& dem, const std::string& dims) {
  // The same rank count and cut: each rank its own section, raw.
  bool same = false;
  if (comm.root()) same = file_ranks(run.reader()) == comm.size() && run.reader().meta("decomposition") == dims;
  same = comm.any(same);
  if (same) {
    if (comm.root()) {
      // Rank 0's own section is loaded last, after the others have theirs:
      // a load rebinds the ghost refresh, which pairs each rank with its
      // neighbours (halo::Transport::bind).
      ckpt::Reader& r = run.reader();
      r.section("dem.0");
      std::vector<std::byte> own;
      for (;;) {
        const auto len = r.get<std::uint64_t>();
        if (len == 0) break;
        if (len > kChunkBytes) r.mismatch("a chunk of " + std::to_string(len) + " bytes");
        const std::size_t at = own.size();
        own.resize(at + static_cast<std::size_t>(len));
        r.read(own.data() + at, static_cast<std::size_t>(len));
      }
      for (int k = 1; k < comm.size(); ++k) {
        r.section("dem." + std::to_string(k));
        for (;;) {
          const auto len = r.get<std::uint64_t>();
          if (len > kChunkBytes) r.mismatch("a chunk of " + std::to_string(len) + " bytes");
          std::vector<std::byte> chunk(static_cast<std::size_t>(len));
          if (len > 0) r.read(chunk.data(), chunk.size());
          swap_chunk(comm, k, std::move(chunk));
          if (len == 0) break;
        }
      }
      BytesSource src(own);
      dem.load_state(src);
      if (!src.done()) r.mismatch("bytes left unread at the end of rank 0's DEM section");
    } else {
      // The whole section first (the load pairs this rank with its neighbours at its end).
      std::vector<std::byte> own;
      for (;;) {
        const auto chunk = swap_chunk(comm, 0, {});
        if (chunk.empty()) break;
        own.insert(own.end(), chunk.begin(), chunk.end());
      }
      BytesSource src(own);
      dem.load_state(src);
      if (!src.done()) src.mismatch("bytes left unread at the end of this rank's DEM section");
    }
    return;
  }
  // Another rank count or cut: the particles of every stored section,
  // broadcast a section at a time; each rank keeps those in its piece.
  std::vector<std::byte> mine;
  dem::DemSystem::SavedCounters counters;
  int ranks = 1;
  std::exception_ptr failed;
  if (comm.root()) {
    try {
      ranks = file_ranks(run.reader());
    } catch (...) {
      failed = std::current_exception();
    }
  }
  agree(comm, failed, "read the checkpoint");
  ranks = static_cast<int>(comm.max(static_cast<long>(ranks)));
  for (int k = 0; k < ranks; ++k) {
    std::vector<std::byte> msg;
    failed = nullptr;
    if (comm.root()) {
      try {
        ckpt::Reader& r = run.reader();
        std::vector<std::byte> recs;
        dem::DemSystem::SavedCounters c;
        if (ranks == 1) {
          r.section("dem");
          c = dem.saved_particles(r, recs);
        } else {
          r.section("dem." + std::to_string(k));
          ChunkSource cs(r);
          c = dem.saved_particles(cs, recs);
          cs.finish();
        }
        msg.resize(sizeof c + recs.size());
        std::memcpy(msg.data(), &c, sizeof c);
        if (!recs.empty()) std::memcpy(msg.data() + sizeof c, recs.data(), recs.size());
      } catch (...) {
        failed = std::current_exception();
      }
    }
    agree(comm, failed, "read the checkpoint");
    comm.broadcast(msg, 0);
    if (msg.size() < sizeof counters) throw Error("restart: a short message from rank 0");
    std::memcpy(&counters, msg.data(), sizeof counters);
    const std::vector<std::byte> recs(msg.begin() + static_cast<std::ptrdiff_t>(sizeof counters), msg.end());
    msg = {};
    const auto kept = dem.select_particles(recs);
    mine.insert(mine.end(), kept.begin(), kept.end());
  }
  const auto want = dem.global_size();
  dem.restore_particles(mine, counters);
  const auto got = dem.global_size();
  if (got != want)
    throw ConfigError("--restart: the checkpoint holds " + std::to_string(got) + " particles where this case has " +
                      std::to_string(want));
}

RunValues load_dem(ckpt::Run& run, const halo::Comm& comm, dem::DemSystem& dem, const std::string& dims) {
  if (!comm.distributed() && file_ranks(run.reader()) == 1) return load_dem(run.reader(), dem);
  RunValues v = load_run_shared(run, comm);
  load_dem_shared(run, comm, dem, dims);
  if (comm.root()) run.reader().finish();
  return v;
}

void save_coupled(ckpt::Run& run, const halo::Comm& comm, long step, double time, lbm::LbmSolver& fluid,
                  const dem::DemSystem& dem, const imb::CoupledSolver& cs, const RunValues& values) {
  if (!comm.distributed()) {
    run.write(step, time, [&](ckpt::Writer& w) { save_coupled(w, fluid, dem, cs, values); });
    return;
  }
  SharedWriter w(run, comm, step, time);
  w.root_section("run", [&](ckpt::Sink& out) { out.put_vector(values); });
  w.rank_sections("lbm", [&](ckpt::Sink& out) { save_fluid_piece(out, fluid); });
  w.rank_sections("dem", [&](ckpt::Sink& out) { dem.save_state(out); }, true);
  w.root_section("coupling", [&](ckpt::Sink& out) { cs.save_state(out); });
  w.commit();
}

RunValues load_coupled(ckpt::Run& run, const halo::Comm& comm, lbm::LbmSolver& fluid, const Grid& whole,
                       const std::vector<std::uint8_t>& flags, dem::DemSystem& dem, imb::CoupledSolver& cs,
                       const std::string& dims) {
  if (!comm.distributed() && file_ranks(run.reader()) == 1) return load_coupled(run.reader(), fluid, dem, cs);
  RunValues v = load_run_shared(run, comm);
  load_fluid_shared(run, comm, fluid, whole, flags);
  load_dem_shared(run, comm, dem, dims);
  // The coupling's step count (the same on every rank): rank 0 reads it.
  std::vector<std::byte> bytes;
  std::exception_ptr failed;
  if (comm.root()) {
    try {
      ckpt::Reader& r = run.reader();
      r.section("coupling");
      bytes.resize(sizeof(std::int64_t));
      r.read(bytes.data(), bytes.size());
      r.finish();
    } catch (...) {
      failed = std::current_exception();
    }
  }
  agree(comm, failed, "read the checkpoint");
  comm.broadcast(bytes, 0);
  BytesSource src(bytes);
  cs.load_state(src);
  return v;
}

}  // namespace lbdem::cases
