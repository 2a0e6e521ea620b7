// Checkpoint files (core/checkpoint.hpp).
#include "core/checkpoint.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "core/error.hpp"
#include "core/output.hpp"

#ifndef LBDEM_BUILD_ID
#define LBDEM_BUILD_ID "unknown"
#endif

namespace lbdem::ckpt {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'L', 'B', 'D', 'E', 'M', 'C', 'K', 'P'};
constexpr char kEnd[8] = {'L', 'B', 'D', 'E', 'M', 'E', 'N', 'D'};
constexpr std::size_t kTrailerBytes = 8 + 8 + 8;

// FNV-1a (64 bit) over the bytes: detects truncation, bit flips and a file
// pieced together from two writes (it is not a defence against tampering).
constexpr std::uint64_t kFnvOffset = 1469598103934665603ull;
constexpr std::uint64_t kFnvPrime = 1099511628211ull;
std::uint64_t fnv(std::uint64_t h, const void* data, std::size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= kFnvPrime;
  }
  return h;
}

std::string num(double v) {
  std::ostringstream os;
  os.precision(std::numeric_limits<double>::max_digits10);
  os << v;
  return os.str();
}

// Names `name` in the run manifest of `dir` (core/output.hpp) unless listed.
void record_in_manifest(const fs::path& dir, const std::string& name) {
  for (const auto& n : io::read_manifest(dir.string()))
    if (n == name) return;
  const fs::path m = dir / io::kManifestName;
  const int fd = ::open(m.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
  const std::string line = name + "\n";
  const bool ok = fd >= 0 && ::write(fd, line.data(), line.size()) == static_cast<ssize_t>(line.size());
  const int err = errno;
  if (fd >= 0) ::close(fd);
  if (!ok) {
    const std::string msg = "cannot record the checkpoint '" + (dir / name).string() + "' in the run manifest '" +
                            m.string() + "': " + std::strerror(err);
    if (err == ENOSPC || err == EDQUOT || err == EFBIG) throw ResourceError(msg + "; free disk space");
    throw Error(msg);
  }
}

// "<prefix>_<8 digits>.h5" -> the step; -1 for any other name.
long output_step(const std::string& full) {
  if (full.size() < 12 || full.compare(full.size() - 3, 3, ".h5") != 0) return -1;
  // A rank's piece (core/piece_output.hpp), "<prefix>_<step>_r<rank>.h5": the step before the rank.
  std::string name = full;
  if (const std::size_t r = name.rfind("_r"); r != std::string::npos && r + 2 < name.size() - 3 &&
                                              name.find_first_not_of("0123456789", r + 2) == name.size() - 3)
    name = name.substr(0, r) + ".h5";
  const std::size_t us = name.rfind('_');
  if (us == std::string::npos || name.size() - 3 - (us + 1) < 8) return -1;
  long v = 0;
  for (std::size_t i = us + 1; i < name.size() - 3; ++i) {
    if (name[i] < '0' || name[i] > '9') return -1;
    v = v * 10 + (name[i] - '0');
  }
  return v;
}

}  // namespace

std::string build_id() {
  return std::string("lbdem ") + LBDEM_VERSION + " " + LBDEM_BUILD_ID +
#if defined(LBDEM_HAVE_CUDA)
         " cuda"
#else
         " host-only"
#endif
      ;
}

// ---------------------------------------------------------------------------
// Sink / Source
// ---------------------------------------------------------------------------
void Sink::put_string(const std::string& s) {
  put<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
  if (!s.empty()) write(s.data(), s.size());
}

std::string Source::get_string() {
  const auto n = get<std::uint32_t>();
  if (n > (1u << 20)) mismatch("a stored name of " + std::to_string(n) + " bytes");
  std::string s(n, '\0');
  if (n > 0) read(s.data(), n);
  return s;
}

// ---------------------------------------------------------------------------
// Writer
// ---------------------------------------------------------------------------
Writer::Writer(std::string path, const Identity& id, long step, double time, const Identity& layout)
    : path_(std::move(path)), tmp_(path_ + ".tmp" + std::to_string(static_cast<long>(::getpid()))), hash_(kFnvOffset) {
  const fs::path p(path_);
  record_in_manifest(p.has_parent_path() ? p.parent_path() : fs::path("."), p.filename().string());
  errno = 0;
  f_ = std::fopen(tmp_.c_str(), "wb");
  if (!f_) fail("cannot create the temporary '" + tmp_ + "'", errno);
  std::ostringstream h;
  h << "build=" << build_id() << "\n";
  for (const auto& [k, v] : id.items) h << k << "=" << v << "\n";
  for (const auto& [k, v] : layout.items) h << k << "=" << v << "\n";
  h << "step=" << step << "\ntime=" << num(time) << "\n";
  const std::string text = h.str();
  raw(kMagic, sizeof kMagic);
  const std::uint32_t version = kFormatVersion;
  raw(&version, sizeof version);
  const std::uint64_t n = text.size();
  raw(&n, sizeof n);
  raw(text.data(), text.size());
}

Writer::~Writer() {
  if (f_) std::fclose(f_);
  if (!committed_) {
    std::error_code ec;
    fs::remove(tmp_, ec);
  }
}

void Writer::fail(const std::string& what, int err) {
  if (f_) std::fclose(f_);
  f_ = nullptr;
  std::error_code ec;
  fs::remove(tmp_, ec);
  std::string msg = "cannot write the checkpoint '" + path_ + "': " + what;
  if (err != 0) msg += ": " + std::string(std::strerror(err)) + " (errno " + std::to_string(err) + ")";
  msg += "; the previous checkpoint (if any) is kept";
  if (err == ENOSPC || err == EDQUOT || err == EFBIG) throw ResourceError(msg + "; free disk space");
  throw Error(msg);
}

void Writer::raw(const void* data, std::size_t bytes) {
  if (bytes == 0) return;
  errno = 0;
  if (std::fwrite(data, 1, bytes, f_) != bytes) fail("writing '" + tmp_ + "' failed", errno ? errno : EIO);
  hash_ = fnv(hash_, data, bytes);
  bytes_ += bytes;
}

void Writer::section(const std::string& name) {
  const auto n = static_cast<std::uint32_t>(name.size());
  raw(&n, sizeof n);
  raw(name.data(), name.size());
}

void Writer::write(const void* data, std::size_t bytes) { raw(data, bytes); }

void Writer::commit() {
  const std::uint64_t bytes = bytes_, hash = hash_;
  errno = 0;
  if (std::fwrite(kEnd, 1, sizeof kEnd, f_) != sizeof kEnd || std::fwrite(&bytes, 1, 8, f_) != 8 ||
      std::fwrite(&hash, 1, 8, f_) != 8 || std::fflush(f_) != 0)
    fail("writing '" + tmp_ + "' failed", errno ? errno : EIO);
  // The data on disk before the name: a crash after the rename finds a complete file.
  if (::fsync(::fileno(f_)) != 0) fail("fsync of '" + tmp_ + "' failed", errno);
  const int rc = std::fclose(f_);
  f_ = nullptr;
  if (rc != 0) fail("closing '" + tmp_ + "' failed", errno);
  std::error_code ec;
  fs::rename(tmp_, path_, ec);
  if (ec) fail("renaming '" + tmp_ + "' into place failed", ec.value());
  committed_ = true;
  // The rename itself on disk.
  const fs::path dir = fs::path(path_).has_parent_path() ? fs::path(path_).parent_path() : fs::path(".");
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

// ---------------------------------------------------------------------------
// Reader
// ---------------------------------------------------------------------------
Reader::Reader(std::string path) : path_(std::move(path)) {
  auto bad = [&](const std::string& what) {
    throw ConfigError("checkpoint '" + path_ + "' " + what + "; nothing was changed");
  };
  std::error_code ec;
  if (!fs::is_regular_file(path_, ec)) bad("does not exist or is not a file");
  const std::uintmax_t size = fs::file_size(path_, ec);
  if (ec) bad("cannot be read: " + ec.message());
  f_ = std::fopen(path_.c_str(), "rb");
  if (!f_) bad(std::string("cannot be opened: ") + std::strerror(errno));
  char magic[8];
  if (size < sizeof kMagic || std::fread(magic, 1, 8, f_) != 8 || std::memcmp(magic, kMagic, 8) != 0)
    bad("is not an lbdem checkpoint (no 'LBDEMCKP' at its start)");
  if (size < 8 + 4 + 8 + kTrailerBytes) bad("is truncated (" + std::to_string(size) + " bytes)");
  // Trailer: the length of what precedes it and the checksum of that.
  char end[8];
  std::uint64_t bytes = 0, hash = 0;
  if (std::fseek(f_, static_cast<long>(size - kTrailerBytes), SEEK_SET) != 0 || std::fread(end, 1, 8, f_) != 8 ||
      std::fread(&bytes, 1, 8, f_) != 8 || std::fread(&hash, 1, 8, f_) != 8)
    bad("cannot be read to its end");
  if (std::memcmp(end, kEnd, 8) != 0 || bytes != size - kTrailerBytes)
    bad("is truncated or incomplete (no valid end record; a write was interrupted?)");
  std::rewind(f_);
  std::vector<unsigned char> buf(std::size_t{4} << 20);
  std::uint64_t h = kFnvOffset, left = bytes;
  while (left > 0) {
    const std::size_t k = static_cast<std::size_t>(std::min<std::uint64_t>(left, buf.size()));
    if (std::fread(buf.data(), 1, k, f_) != k) bad("cannot be read");
    h = fnv(h, buf.data(), k);
    left -= k;
  }
  if (h != hash) bad("is corrupt (checksum mismatch)");
  // Header.
  std::rewind(f_);
  payload_end_ = bytes;
  std::uint32_t version = 0;
  std::uint64_t n = 0;
  std::fread(magic, 1, 8, f_);
  if (std::fread(&version, 1, 4, f_) != 4 || std::fread(&n, 1, 8, f_) != 8) bad("is truncated");
  if (version != kFormatVersion)
    bad("has format version " + std::to_string(version) + "; this build reads version " +
        std::to_string(kFormatVersion));
  if (n > bytes - 20) bad("has a header longer than the file");
  std::string text(static_cast<std::size_t>(n), '\0');
  if (n > 0 && std::fread(text.data(), 1, text.size(), f_) != text.size()) bad("is truncated");
  pos_ = 20 + n;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const auto eq = line.find('=');
    if (eq != std::string::npos) meta_.emplace_back(line.substr(0, eq), line.substr(eq + 1));
  }
  try {
    step_ = std::stol(meta("step"));
    time_ = std::stod(meta("time"));
  } catch (const std::exception&) {
    bad("has no valid step and time in its header");
  }
}

Reader::~Reader() {
  if (f_) std::fclose(f_);
}

std::string Reader::meta(const std::string& key) const {
  for (const auto& [k, v] : meta_)
    if (k == key) return v;
  return "";
}

void Reader::check_identity(const Identity& id) const {
  std::string diff;
  auto differs = [&](const std::string& key, const std::string& mine, const std::string& theirs) {
    diff += (diff.empty() ? "" : "; ") + key + " '" + theirs + "' (this run: '" + mine + "')";
  };
  if (meta("build") != build_id()) differs("build", build_id(), meta("build"));
  for (const auto& [k, v] : id.items)
    if (meta(k) != v) differs(k, v, meta(k));
  if (!diff.empty())
    throw ConfigError("checkpoint '" + path_ + "' is of another run: " + diff +
                      ". A checkpoint restarts only the case, build and settings that wrote it; nothing was changed");
}

void Reader::read(void* data, std::size_t bytes) {
  if (bytes == 0) return;
  if (pos_ + bytes > payload_end_ || std::fread(data, 1, bytes, f_) != bytes)
    mismatch("its data end early" + (section_.empty() ? std::string() : " in section '" + section_ + "'"));
  pos_ += bytes;
}

void Reader::mismatch(const std::string& what) const {
  throw ConfigError("checkpoint '" + path_ + "' does not fit this run: " + what +
                    (section_.empty() ? std::string() : " (section '" + section_ + "')") +
                    "; was it written by another case file?");
}

void Reader::section(const std::string& name) {
  section_.clear();
  const std::string got = get_string();
  if (got != name) mismatch("section '" + got + "' where '" + name + "' was expected");
  section_ = name;
}

void Reader::finish() {
  if (pos_ != payload_end_) {
    section_.clear();
    mismatch(std::to_string(payload_end_ - pos_) + " bytes left unread after the last section");
  }
}

// ---------------------------------------------------------------------------
// Policy, resolve
// ---------------------------------------------------------------------------
Policy read_policy(const Config& root) {
  Policy p;
  if (auto c = root.optional_section("checkpoint")) {
    p.interval = c->integer_in("interval", 0, 0, std::numeric_limits<long>::max());
    p.minutes = c->number_in("minutes", 0.0, 0.0, 1e7, "wall-clock minutes between checkpoints (0: none)");
    p.on_signal = c->boolean("on_signal", true);
    c->finish();
  }
  return p;
}

std::string resolve(const std::string& arg) {
  if (arg.empty()) throw ConfigError("--restart was given an empty name; give a run folder or a checkpoint file");
  std::error_code ec;
  if (fs::is_directory(arg, ec)) {
    const fs::path f = fs::path(arg) / kFileName;
    if (!fs::exists(f, ec))
      throw ConfigError("--restart '" + arg + "': the folder holds no checkpoint '" + std::string(kFileName) +
                        "' (a run writes one with checkpoint.interval or checkpoint.minutes, or when stopped by "
                        "SIGINT/SIGTERM); nothing was changed");
    return f.string();
  }
  if (!fs::exists(arg, ec))
    throw ConfigError("--restart '" + arg + "': no such run folder or checkpoint file; nothing was changed");
  return arg;
}

// ---------------------------------------------------------------------------
// Run
// ---------------------------------------------------------------------------
Run::Run(std::string outdir, Policy policy, Identity id, const std::optional<std::string>& restart)
    : outdir_(std::move(outdir)), policy_(policy), id_(std::move(id)), last_(std::chrono::steady_clock::now()) {
  path_ = (fs::path(outdir_) / kFileName).string();
  if (!restart) return;
  const std::string file = resolve(*restart);
  std::error_code ec;
  const fs::path folder = fs::path(file).has_parent_path() ? fs::path(file).parent_path() : fs::path(".");
  if (!fs::equivalent(folder, fs::path(outdir_), ec))
    throw ConfigError("--restart '" + *restart + "': the checkpoint lies in '" + folder.string() +
                      "' but the run writes to '" + outdir_ +
                      "'; a restart continues the run in its own folder: pass --output " + folder.string() +
                      " (nothing was changed)");
  reader_ = std::make_unique<Reader>(file);
  reader_->check_identity(id_);
  last_step_ = reader_->step();
}

void Run::prepare_output(bool overwrite) {
  if (!reader_) {
    io::prepare_output_dir(outdir_, overwrite);
    return;
  }
  // Output of steps after the checkpoint is recomputed by the restarted run;
  // temporaries left by a killed write ("<name>.tmp<pid>" of a file the
  // manifest names) are dropped.
  const long s = reader_->step();
  std::error_code ec;
  const auto ours = io::read_manifest(outdir_);
  const std::set<std::string> names(ours.begin(), ours.end());
  for (const auto& name : ours) {
    const long k = output_step(name);
    if (k > s) fs::remove(fs::path(outdir_) / name, ec);
  }
  for (fs::directory_iterator it(outdir_, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    const auto t = n.rfind(".tmp");
    if (t == std::string::npos || t + 4 >= n.size() || !names.count(n.substr(0, t))) continue;
    if (n.find_first_not_of("0123456789", t + 4) != std::string::npos) continue;
    if (it->is_regular_file(ec) && !it->is_symlink(ec)) fs::remove(it->path(), ec);
  }
}

bool Run::due(long step, bool stopping, bool finished) const {
  if (step == last_step_) return false;
  if (stopping) return policy_.on_signal;
  if (finished) return policy_.interval > 0 || policy_.minutes > 0;
  if (policy_.interval > 0 && step % policy_.interval == 0) return true;
  if (policy_.minutes > 0 &&
      std::chrono::duration<double>(std::chrono::steady_clock::now() - last_).count() >= 60.0 * policy_.minutes)
    return true;
  return false;
}

void Run::written(long step) {
  last_step_ = step;
  last_ = std::chrono::steady_clock::now();
  ++written_;
}

std::vector<std::vector<double>> Run::kept_rows(const std::string& csv, const std::vector<std::string>& columns,
                                                long interval) const {
  std::vector<std::vector<double>> rows;
  if (!reader_) return rows;
  const long s = reader_->step();
  std::ifstream in(csv);
  if (!in) return rows;  // no series yet: the restarted run starts it
  std::string line;
  std::getline(in, line);
  std::string want;
  for (std::size_t i = 0; i < columns.size(); ++i) want += (i ? "," : "") + columns[i];
  if (line != want)
    throw ConfigError("--restart: the time series '" + csv + "' has the columns '" + line + "', this run writes '" +
                      want + "'; nothing was changed");
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::istringstream ls(line);
    std::string cell;
    bool ok = true;
    while (std::getline(ls, cell, ',')) {
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      if (end == cell.c_str()) ok = false;
      row.push_back(v);
    }
    if (!ok || row.size() != columns.size()) break;  // a row cut by a kill: dropped, recomputed
    const long k = static_cast<long>(row[0]);
    if (k < s || (k == s && interval > 0 && k % interval == 0)) rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace lbdem::ckpt
