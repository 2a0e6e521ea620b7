#pragma once
// A checkpoint written and read by every rank of a run (core/checkpoint.hpp
// holds the file format; this is its collective side, shared by every scene
// and by each module's save/load of its own state: lbm/checkpoint.hpp,
// dem/checkpoint.hpp, imb/checkpoint.hpp, cfd/checkpoint.hpp).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/checkpoint.hpp"
#include "core/error.hpp"
#include "core/output.hpp"
#include "halo/comm.hpp"

namespace lbdem::halo {

// A scene's own values a restart needs (reference values of its series, ...)
// travel in the "run" section beside the modules' state.
using RunValues = std::vector<double>;
// The "run" section of a one-rank checkpoint.
void save_run(ckpt::Writer& w, const RunValues& values);
RunValues load_run(ckpt::Reader& r);

// One module's state in a one-rank checkpoint: the section's name and the
// object whose save_state(ckpt::Sink&) writes it and load_state(ckpt::Source&)
// reads it back (lbm::LbmSolver, dem::DemSystem, imb::CoupledSolver,
// cfd::GasSolver).
template <class T>
struct Section {
  const char* name;
  T& state;
};
template <class T>
Section<T> section(const char* name, T& state) {
  return {name, state};
}
// A scene's one-rank checkpoint: "run", then each module's section in the
// order given; the load reads them back in that order and checks that
// nothing follows.
template <class... T>
void save_sections(ckpt::Writer& w, const RunValues& values, Section<T>... s) {
  save_run(w, values);
  ((w.section(s.name), s.state.save_state(w)), ...);
}
template <class... T>
RunValues load_sections(ckpt::Reader& r, Section<T>... s) {
  RunValues v = load_run(r);
  ((r.section(s.name), s.state.load_state(r)), ...);
  r.finish();
  return v;
}

// A CSV time series at `path` with these columns: a fresh run starts it; a
// restart keeps its rows up to the checkpoint (ckpt::Run::kept_rows, read
// before the file is rewritten) and goes on appending.
io::TimeSeries open_series(const ckpt::Run& run, const std::string& path, const std::vector<std::string>& columns,
                           long interval);

// ---------------------------------------------------------------------------
// Several ranks. One file all the same (core/checkpoint.hpp), written by rank
// 0; the other ranks stream their sections to it through MPI in rank order,
// a few MiB at a time. The header's layout lines name the rank count and the
// cut; a restart on any rank count and cut reads it (rank 0 reads the file).
//
// Each module writes and reads its own state this way (lbm/checkpoint.hpp:
// the fluid's canonical pieces, re-sliced on any cut; dem/checkpoint.hpp: the
// particles' sections).
//
// A one-rank run writes and reads the modules' one-rank sections unchanged.
// ---------------------------------------------------------------------------

// The layout lines of a checkpoint written on `ranks` ranks cut as `dims`.
ckpt::Identity rank_layout(int ranks, const std::string& dims);

// Opens the checkpoint side of a run on every rank (collective): rank 0
// reads and checks a restart's checkpoint (when it refuses, every rank
// throws ConfigError, rank 0 with the reason); the others follow its step.
ckpt::Run open_run(const std::string& outdir, const ckpt::Policy& policy, const ckpt::Identity& id,
                   const std::optional<std::string>& restart, const Comm& comm);

// One checkpoint written by every rank of `comm` (collective; every rank
// makes the same calls in the same order). Write errors on rank 0 are
// reported by commit() on every rank, after the others have sent their part.
class SharedWriter {
 public:
  SharedWriter(ckpt::Run& run, const Comm& comm, long step, double time);
  ~SharedWriter();
  SharedWriter(const SharedWriter&) = delete;
  SharedWriter& operator=(const SharedWriter&) = delete;
  // Section `name`, written by rank 0 alone (fill is called there only).
  template <class Fill>
  void root_section(const std::string& name, Fill&& fill) {
    if (!comm_.root()) return;
    begin(name);
    fill(sink());
  }
  // Sections "<name>.0", "<name>.1", ...: fill(sink) on every rank, for its
  // own. `chunked`: each section's data as chunks (u64 length, bytes) ended
  // by a zero length, so that a reader can pass a section on without
  // parsing it (ChunkSource reads it).
  template <class Fill>
  void rank_sections(const std::string& name, Fill&& fill, bool chunked = false) {
    if (comm_.root()) {
      begin(name + ".0");
      fill(chunked ? chunk_sink() : sink());
      if (chunked) close_chunks();
      for (int k = 1; k < comm_.size(); ++k) receive(name + "." + std::to_string(k), k, chunked);
    } else {
      ckpt::Sink& out = forward();
      fill(out);
      close_forward();
    }
  }
  void commit();

 private:
  void begin(const std::string& name);
  ckpt::Sink& sink();
  ckpt::Sink& chunk_sink();
  void close_chunks();
  void receive(const std::string& name, int rank, bool chunked);
  ckpt::Sink& forward();
  void close_forward();
  struct State;
  ckpt::Run& run_;
  const Comm& comm_;
  long step_;
  std::unique_ptr<State> st_;
};

// The "run" section (rank 0 reads it), on every rank. Collective.
RunValues load_run_shared(ckpt::Run& run, const Comm& comm);

// The writing rank prepares the output folder (ckpt::Run::prepare_output);
// every rank learns whether it failed and throws (the writer its own error).
// Collective.
void prepare_output_on_writer(ckpt::Run& run, bool writer, const Comm& comm, bool overwrite,
                              const std::string& outdir);

// ---------------------------------------------------------------------------
// Pieces for a module's collective loader (lbm/checkpoint.hpp, ...).
// ---------------------------------------------------------------------------
// Bytes a rank sends to rank 0, or rank 0 broadcasts, at a time.
constexpr std::size_t kCheckpointChunkBytes = std::size_t{4} << 20;

// Rank 0's part of a collective step that can fail: every rank learns
// whether it did; rank 0 rethrows its error, the others throw ConfigError
// (the CLI prints rank 0's line only).
void agree(const Comm& comm, const std::exception_ptr& failed, const std::string& what);

// The rank count a checkpoint was written on (1: a one-rank checkpoint, whose header has no layout lines).
int file_ranks(ckpt::Reader& r);

// Point-to-point between rank 0 and rank `peer`: one chunk each way (an empty one to the side that only receives).
std::vector<std::byte> swap_chunk(const Comm& comm, int peer, std::vector<std::byte> out);

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


}  // namespace lbdem::halo
