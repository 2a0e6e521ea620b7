// The fluid's checkpoint (lbm/checkpoint.hpp).
#include "lbm/checkpoint.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <exception>

#include "core/error.hpp"
#include "lbm/boundary.hpp"
#include "lbm/lattice.hpp"

namespace lbdem::lbm {

using halo::agree;
using halo::file_ranks;
using halo::load_run_shared;
using halo::SharedWriter;

namespace {

constexpr std::size_t kChunkBytes = halo::kCheckpointChunkBytes;
constexpr std::uint32_t kTagPiece = 0x4c425031;  // "LBP1": the layout of a fluid piece

int lattice_q(const LbmSetup& s) { return s.lattice == LatticeKind::D2Q9 ? 9 : 19; }

// Lattice velocities c_q of the set-up's lattice.
std::vector<std::array<int, 3>> lattice_c(const LbmSetup& s) {
  std::vector<std::array<int, 3>> c;
  auto fill = [&](auto lat) {
    using L = decltype(lat);
    for (int q = 0; q < L::Q; ++q) c.push_back({L::c(q, 0), L::c(q, 1), L::c(q, 2)});
  };
  if (s.lattice == LatticeKind::D2Q9) fill(D2Q9{});
  else fill(D3Q19{});
  return c;
}

// Rank 0's part of a collective step that can fail: every rank learns
// whether it did; rank 0 rethrows its error, the others throw ConfigError

}  // namespace

ckpt::Identity fluid_identity(const std::string& scene, const LbmSetup& s) {
  const auto& g = s.domain.global;
  const auto& p = s.domain.periodic;
  ckpt::Identity id;
  id.add("scene", scene)
      .add("lattice", to_string(s.lattice))
      .add("precision", to_string(s.precision))
      .add("streaming", to_string(s.streaming))
      .add("collision", to_string(s.collision))
      .add("grid", std::to_string(g[0]) + "x" + std::to_string(g[1]) + "x" + std::to_string(g[2]))
      .add("periodic", std::string(p[0] ? "1" : "0") + (p[1] ? "1" : "0") + (p[2] ? "1" : "0"));
  return id;
}

void save_fluid(ckpt::Writer& w, LbmSolver& fluid, const RunValues& values) {
  halo::save_sections(w, values, halo::section("lbm", fluid));
}

RunValues load_fluid(ckpt::Reader& r, LbmSolver& fluid) { return halo::load_sections(r, halo::section("lbm", fluid)); }

void save_fluid_piece(ckpt::Sink& out, LbmSolver& fluid) {
  const LbmSetup& s = fluid.setup();
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
        if (owned || !reflects(flags[i])) continue;
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

void save_fluid(ckpt::Run& run, const halo::Comm& comm, long step, double time, LbmSolver& fluid,
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

void load_fluid_shared(ckpt::Run& run, const halo::Comm& comm, LbmSolver& fluid, const Grid& whole,
                       const std::vector<std::uint8_t>& flags) {
  const LbmSetup& s = fluid.setup();
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
  const int sigma = s.streaming == StreamKind::TwoLattice ? 1 : -1;
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
                if (reflects(mine_flags[c])) std::memcpy(dst + c * tb, src, tb);
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
                if (reflects(f)) {
                  // A boundary cell (owned or a ghost copy): the slot its writer's piece holds.
                  const long gb[3] = {b.lo[0] + x, b.lo[1] + y, b.lo[2] + z};
                  if (!writer_in(h, gb, h.q)) continue;
                } else {
                  const bool owned = is_owned(0, ix[kx]) && is_owned(1, iy[ky]) && is_owned(2, iz[kz]);
                  if (!owned && f != kGhostFlag) continue;
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
        if (s.streaming == StreamKind::TwoLattice) {
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

RunValues load_fluid(ckpt::Run& run, const halo::Comm& comm, LbmSolver& fluid, const Grid& whole,
                     const std::vector<std::uint8_t>& flags) {
  if (!comm.distributed() && file_ranks(run.reader()) == 1) return load_fluid(run.reader(), fluid);
  RunValues v = load_run_shared(run, comm);
  load_fluid_shared(run, comm, fluid, whole, flags);
  if (comm.root()) run.reader().finish();
  return v;
}

}  // namespace lbdem::lbm
