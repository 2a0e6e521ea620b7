#pragma once
// Checkpoints: the complete state of a run in one file per run folder, from
// which `lbdem run CASE.yaml --restart RUN_DIR` continues the run bit for bit.
//
// File layout (all integers little-endian, as the machines we run on store them):
//   "LBDEMCKP"  u32 format version  u64 n  n bytes of header text ("key=value\n" lines)
//   sections, each: u32 n, n bytes of its name, then the section's data
//   "LBDEMEND"  u64 bytes before this trailer  u64 checksum of those bytes
// The header names what the checkpoint is of (build, scene, lattice,
// precision, grid, particle count, step); a restart compares it with the case
// and refuses a checkpoint of anything else, naming what differs. The data of
// a section is written and read by the module that owns the state (LbmSolver,
// DemSystem, the scene) through Sink and Source, device buffers streamed in
// slabs through a small host buffer (no second copy of the state in memory).
//
// Writing (Writer): a temporary "<file>.tmp<pid>" in the same folder, fsync'ed,
// renamed over the previous checkpoint, then the folder fsync'ed: until the
// rename the previous checkpoint is untouched, so a process killed in the
// middle of a write (kill -9, power loss) loses nothing. The checkpoint is
// named in the folder's run manifest (core/output.hpp), so --overwrite
// removes it (and a temporary left by a killed write) and nothing else.
//
// Reading (Reader): the whole file is checked (magic, version, length,
// checksum) before any state is read, so a truncated or corrupt file is
// refused with one line and nothing of the run is touched.
//
// Several ranks (halo/shared_checkpoint.hpp): one file all the same, written
// by rank 0; the other ranks stream their sections to it in rank order. The
// header's layout lines ("ranks", "decomposition"; not part of the identity)
// say how the run was cut; a run cut otherwise reads it all the same (rank 0
// reads and hands each rank what it owns).
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/buffer.hpp"
#include "core/config.hpp"

namespace lbdem::ckpt {

inline constexpr const char* kFileName = "checkpoint.lbdem";
inline constexpr std::uint32_t kFormatVersion = 1;

// The build a checkpoint came from: version, commit and build flags. State is
// restored byte for byte, so a checkpoint is read only by the build that wrote it.
std::string build_id();

// Byte sink of a checkpoint section.
class Sink {
 public:
  virtual ~Sink() = default;
  virtual void write(const void* data, std::size_t bytes) = 0;

  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    write(&v, sizeof(T));
  }
  void put_string(const std::string& s);
  template <class T>
  void put_vector(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    put<std::uint64_t>(v.size());
    if (!v.empty()) write(v.data(), v.size() * sizeof(T));
  }
  // The first `count` elements of a backend buffer (its size is written first),
  // copied to the host in slabs.
  template <class T>
  void put_buffer(const Buffer<T>& b, Index count) {
    static_assert(std::is_trivially_copyable_v<T>);
    put<std::uint64_t>(static_cast<std::uint64_t>(count));
    if (count <= 0) return;
    if (b.backend() == Backend::Host) {
      write(b.data(), static_cast<std::size_t>(count) * sizeof(T));
      return;
    }
    const Index slab = std::max<Index>(1, static_cast<Index>(kSlabBytes / sizeof(T)));
    std::vector<T> tmp(static_cast<std::size_t>(std::min(slab, count)));
    for (Index at = 0; at < count; at += slab) {
      const Index k = std::min(slab, count - at);
      b.copy_to_host(tmp.data(), k, at);
      write(tmp.data(), static_cast<std::size_t>(k) * sizeof(T));
    }
  }
  template <class T>
  void put_buffer(const Buffer<T>& b) { put_buffer(b, b.size()); }

  static constexpr std::size_t kSlabBytes = std::size_t{16} << 20;
};

// Byte source of a checkpoint section. A read past the end, or a size that
// does not match what the reader expects, throws ConfigError ("corrupt").
class Source {
 public:
  virtual ~Source() = default;
  virtual void read(void* data, std::size_t bytes) = 0;
  // Thrown with `what` for a value the state does not accept (the file's checksum held).
  [[noreturn]] virtual void mismatch(const std::string& what) const = 0;

  template <class T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    T v;
    read(&v, sizeof(T));
    return v;
  }
  // A value that must equal `expected` (a size, a flag of the set-up).
  template <class T>
  void expect(const T& expected, const char* what) {
    const T v = get<T>();
    if (!(v == expected)) mismatch(std::string(what) + " differs from this run's");
  }
  std::string get_string();
  // A vector written by put_vector, of at most `max` elements.
  template <class T>
  std::vector<T> get_vector(std::uint64_t max) {
    const auto n = get<std::uint64_t>();
    if (n > max) mismatch("a stored array of " + std::to_string(n) + " elements (at most " + std::to_string(max) +
                          " expected)");
    std::vector<T> v(static_cast<std::size_t>(n));
    if (n > 0) read(v.data(), v.size() * sizeof(T));
    return v;
  }
  // A buffer written by put_buffer: `count` elements expected; read into b
  // (which must hold them) in slabs.
  template <class T>
  void get_buffer(Buffer<T>& b, Index count) {
    const auto n = get<std::uint64_t>();
    if (n != static_cast<std::uint64_t>(count) || count > b.size())
      mismatch("a stored array of " + std::to_string(n) + " elements where this run holds " + std::to_string(count));
    if (count <= 0) return;
    if (b.backend() == Backend::Host) {
      read(b.data(), static_cast<std::size_t>(count) * sizeof(T));
      return;
    }
    const Index slab = std::max<Index>(1, static_cast<Index>(Sink::kSlabBytes / sizeof(T)));
    std::vector<T> tmp(static_cast<std::size_t>(std::min(slab, count)));
    for (Index at = 0; at < count; at += slab) {
      const Index k = std::min(slab, count - at);
      read(tmp.data(), static_cast<std::size_t>(k) * sizeof(T));
      b.copy_from_host(tmp.data(), k, at);
    }
  }
  template <class T>
  void get_buffer(Buffer<T>& b) { get_buffer(b, b.size()); }
};

// What a checkpoint is of: ordered key = value pairs (scene, lattice,
// precision, grid, particles, ...), compared one by one at restart.
struct Identity {
  std::vector<std::pair<std::string, std::string>> items;
  Identity& add(const std::string& key, const std::string& value) {
    items.emplace_back(key, value);
    return *this;
  }
};

// Writes one checkpoint (see the file comment). Nothing is visible under
// `path` until commit(); the destructor of an uncommitted writer removes the
// temporary.
class Writer final : public Sink {
 public:
  // `path`: the final file; `id`: what the checkpoint is of; `step`, `time`:
  // where the run stands (also in the header, for `lbdem` messages and users).
  // `layout`: header lines that describe how the state is stored (the rank
  // count, ...) and are not compared at restart.
  Writer(std::string path, const Identity& id, long step, double time, const Identity& layout = {});
  ~Writer() override;
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;
  // Starts the next section.
  void section(const std::string& name);
  void write(const void* data, std::size_t bytes) override;
  // Trailer, fsync, rename over the previous checkpoint, fsync of the folder.
  void commit();

 private:
  void raw(const void* data, std::size_t bytes);
  [[noreturn]] void fail(const std::string& what, int err);
  std::string path_, tmp_;
  std::FILE* f_ = nullptr;
  std::uint64_t bytes_ = 0, hash_ = 0;
  bool committed_ = false;
};

// Reads a checkpoint written by Writer: the constructor checks the whole file
// (ConfigError naming the file and what is wrong: missing, not a checkpoint,
// another format version, truncated, checksum).
class Reader final : public Source {
 public:
  explicit Reader(std::string path);
  ~Reader() override;
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  const std::string& path() const { return path_; }
  // A header value ("" when absent).
  std::string meta(const std::string& key) const;
  long step() const { return step_; }
  double time() const { return time_; }
  // Throws ConfigError naming every item of `id` (and the build) that differs
  // from the checkpoint's header.
  void check_identity(const Identity& id) const;
  // Moves to the next section, which must be `name`.
  void section(const std::string& name);
  void read(void* data, std::size_t bytes) override;
  [[noreturn]] void mismatch(const std::string& what) const override;
  // Every section read to its end.
  void finish();

 private:
  std::string path_;
  std::FILE* f_ = nullptr;
  std::uint64_t payload_end_ = 0, pos_ = 0;
  std::vector<std::pair<std::string, std::string>> meta_;
  std::string section_;
  long step_ = 0;
  double time_ = 0;
};

// When a run writes checkpoints: every `interval` steps, every `minutes` of
// wall time, and at a stop signal (the case file's `checkpoint:` section).
struct Policy {
  long interval = 0;     // steps; 0: never by step count
  double minutes = 0;    // wall time; 0: never by time
  bool on_signal = true; // at SIGINT/SIGTERM
  bool any() const { return interval > 0 || minutes > 0 || on_signal; }
};
// Reads the optional `checkpoint:` section (interval, minutes, on_signal).
Policy read_policy(const Config& root);

// Resolves the --restart argument: a run folder (its checkpoint file) or a
// checkpoint file. ConfigError naming the argument when there is none.
std::string resolve(const std::string& arg);

// The checkpoint side of one run: where and when to write, and for a
// restart the checkpoint it continues from.
class Run {
 public:
  // `outdir`: the run folder; `restart`: the --restart argument (empty: a
  // fresh run). A restart opens and checks the checkpoint file here (its
  // folder must be the run's output folder), before anything is written.
  Run(std::string outdir, Policy policy, Identity id, const std::optional<std::string>& restart);
  bool restarting() const { return reader_ != nullptr || following_; }
  // The checkpoint read from (a restart on the rank that reads it).
  bool has_reader() const { return reader_ != nullptr; }
  Reader& reader() { return *reader_; }
  long restart_step() const { return reader_ ? reader_->step() : (following_ ? follow_step_ : 0); }
  // A restart on a rank that does not read the file (several ranks: rank 0
  // reads and hands the others their state): the run restarts from `step`.
  void follow(long step) {
    following_ = true;
    follow_step_ = step;
    last_step_ = step;
  }
  // Header lines of the checkpoints this run writes that describe the layout
  // (Writer's `layout`).
  void set_layout(Identity layout) { layout_ = std::move(layout); }
  // The output folder: a fresh run goes through io::prepare_output_dir; a
  // restart keeps the folder and removes the output files of steps after
  // the checkpoint (named in the run manifest: "<prefix>_<step>.h5").
  void prepare_output(bool overwrite);
  // Whether a checkpoint is due after `step`: interval or wall time; a stop
  // request when `stopping`; the end of the run when `finished` (with an
  // interval or minutes set, so that a longer run can go on from it). Reads
  // the clock only: no device work.
  bool due(long step, bool stopping, bool finished = false) const;
  // Writes a checkpoint of `step`: fill(writer) writes the sections.
  template <class Fill>
  void write(long step, double time, Fill&& fill) {
    Writer w(path_, id_, step, time, layout_);
    fill(w);
    w.commit();
    written(step);
  }
  // Rows of a CSV time series to keep on restart: those before the
  // checkpoint's step, and the row of that step when it lies on the
  // `interval` grid (the rows a straight run has there). Empty on a fresh run.
  // The file's header must be `columns` (else ConfigError).
  std::vector<std::vector<double>> kept_rows(const std::string& csv, const std::vector<std::string>& columns,
                                             long interval) const;
  const std::string& path() const { return path_; }
  const Policy& policy() const { return policy_; }
  long checkpoints_written() const { return written_; }
  // The two halves of write() for a writer filled by several ranks
  // (halo/shared_checkpoint.hpp): the writer of `step` (one rank), and
  // the bookkeeping of a committed checkpoint (every rank).
  std::unique_ptr<Writer> open_writer(long step, double time) const {
    return std::make_unique<Writer>(path_, id_, step, time, layout_);
  }
  void written(long step);

 private:
  std::string outdir_, path_;
  Policy policy_;
  Identity id_, layout_;
  std::unique_ptr<Reader> reader_;
  bool following_ = false;
  long follow_step_ = 0;
  std::chrono::steady_clock::time_point last_;
  long last_step_ = -1, written_ = 0;
};

}  // namespace lbdem::ckpt
