// The particles' checkpoint (dem/checkpoint.hpp).
#include "dem/checkpoint.hpp"

#include <cstring>
#include <exception>

#include "core/error.hpp"
#include "dem/system.hpp"

namespace lbdem::dem {

using halo::agree;
using halo::BytesSource;
using halo::ChunkSource;
using halo::file_ranks;
using halo::load_run_shared;
using halo::SharedWriter;
using halo::swap_chunk;

namespace {
constexpr std::size_t kChunkBytes = halo::kCheckpointChunkBytes;
}  // namespace

void save_dem(ckpt::Writer& w, const DemSystem& dem, const RunValues& values) {
  halo::save_sections(w, values, halo::section("dem", dem));
}

RunValues load_dem(ckpt::Reader& r, DemSystem& dem) { return halo::load_sections(r, halo::section("dem", dem)); }

void save_dem(ckpt::Run& run, const halo::Comm& comm, long step, double time, const DemSystem& dem,
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

void load_dem_shared(ckpt::Run& run, const halo::Comm& comm, DemSystem& dem, const std::string& dims) {
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
  DemSystem::SavedCounters counters;
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
        DemSystem::SavedCounters c;
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

RunValues load_dem(ckpt::Run& run, const halo::Comm& comm, DemSystem& dem, const std::string& dims) {
  if (!comm.distributed() && file_ranks(run.reader()) == 1) return load_dem(run.reader(), dem);
  RunValues v = load_run_shared(run, comm);
  load_dem_shared(run, comm, dem, dims);
  if (comm.root()) run.reader().finish();
  return v;
}

}  // namespace lbdem::dem
