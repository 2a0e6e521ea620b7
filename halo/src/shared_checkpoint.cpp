// The collective side of checkpoints (halo/shared_checkpoint.hpp).
#include "halo/shared_checkpoint.hpp"

#include <span>

namespace lbdem::halo {

namespace {

// Tag of the messages that carry a rank's sections to rank 0 and back (Comm::exchange).
constexpr int kSectionTag = 7001;
constexpr std::size_t kChunkBytes = kCheckpointChunkBytes;

}  // namespace

void save_run(ckpt::Writer& w, const RunValues& values) {
  w.section("run");
  w.put_vector(values);
}

RunValues load_run(ckpt::Reader& r) {
  r.section("run");
  return r.get_vector<double>(1 << 16);
}

io::TimeSeries open_series(const ckpt::Run& run, const std::string& path, const std::vector<std::string>& columns,
                           long interval) {
  const auto rows = run.kept_rows(path, columns, interval);
  io::TimeSeries ts(path, columns);
  for (const auto& row : rows) ts.append(row);
  return ts;
}

void prepare_output_on_writer(ckpt::Run& run, bool writer, const Comm& comm, bool overwrite,
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

void agree(const Comm& comm, const std::exception_ptr& failed, const std::string& what) {
  if (!comm.any(failed != nullptr)) return;
  if (failed) std::rethrow_exception(failed);
  throw ConfigError("rank 0 could not " + what);
}

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

std::vector<std::byte> swap_chunk(const Comm& comm, int peer, std::vector<std::byte> out) {
  const int tag = kSectionTag;
  std::vector<std::vector<std::byte>> send(1);
  send[0] = std::move(out);
  auto got = comm.exchange(std::span<const int>(&peer, 1), std::span<const int>(&tag, 1), send,
                           std::span<const int>(&tag, 1));
  return std::move(got[0]);
}

ckpt::Identity rank_layout(int ranks, const std::string& dims) {
  ckpt::Identity l;
  l.add("ranks", std::to_string(ranks)).add("decomposition", dims);
  return l;
}

ckpt::Run open_run(const std::string& outdir, const ckpt::Policy& policy, const ckpt::Identity& id,
                   const std::optional<std::string>& restart, const Comm& comm) {
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
    const Comm* comm = nullptr;
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

SharedWriter::SharedWriter(ckpt::Run& run, const Comm& comm, long step, double time)
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

RunValues load_run_shared(ckpt::Run& run, const Comm& comm) {
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

}  // namespace lbdem::halo
