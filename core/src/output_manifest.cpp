// The output folder and its run manifest (core/output.hpp): which folders a run may write into, what
// --overwrite may remove (only what the manifest names), atomic text files, and the file helpers the HDF5 and
// CSV writers share (output_files.hpp).
#include <fcntl.h>
#include <sys/statvfs.h>
#ifdef __linux__
#include <sys/vfs.h>
#endif
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <system_error>

#include "core/error.hpp"
#include "core/output.hpp"
#include "hdf5_util.hpp"
#include "output_files.hpp"

namespace lbdem::io {

namespace fs = std::filesystem;
using namespace detail;

namespace detail {

// A write to `path` failed with errno `err`: one line, ResourceError when the disk or quota is full or the
// file passes a file-size limit (EFBIG: RLIMIT_FSIZE, the filesystem's largest file).
[[noreturn]] void io_fail(const std::string& path, const std::string& what, int err) {
  std::string msg = "cannot write '" + path + "': " + what;
  if (err != 0) msg += ": " + std::string(std::strerror(err)) + " (errno " + std::to_string(err) + ")";
  if (err == ENOSPC || err == EDQUOT || err == EFBIG)
    throw ResourceError(msg + "; free disk space or choose another output folder");
  throw Error(msg);
}

// Renames a complete temporary to its final name (same folder: atomic); on failure removes it.
void rename_into_place(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    const int err = ec.value();
    fs::remove(tmp, ec);
    io_fail(path, "renaming the complete temporary into place", err);
  }
}

// A plain file name (no folder part, not "." or ".."): the only names a manifest may list.
bool plain_name(const std::string& n) {
  return !n.empty() && n != "." && n != ".." && n.find('/') == std::string::npos && n.find('\0') == std::string::npos;
}

// Appends `name` to the manifest of `dir` before the file is created, so that
// even a run killed while writing it has it on record. O_NOFOLLOW: a symlink
// in place of the manifest is refused rather than written through.
void record_in_manifest(const fs::path& dir, const std::string& name) {
  const fs::path m = dir / kManifestName;
  const int fd = ::open(m.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) {
    const int err = errno;
    io_fail((dir / name).string(), "cannot record it in the run manifest '" + m.string() + "'", err);
  }
  const std::string line = name + "\n";
  const ssize_t w = ::write(fd, line.data(), line.size());
  const int err = errno;
  ::close(fd);
  if (w != static_cast<ssize_t>(line.size()))
    io_fail((dir / name).string(), "cannot record it in the run manifest '" + m.string() + "'", w < 0 ? err : ENOSPC);
}

// Writes `text` to `path` atomically: temporary file in the same folder, then rename.
void write_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = temp_name(path);
  errno = 0;
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) io_fail(path, "cannot create the temporary '" + tmp + "'", errno);
    out << text;
    out.flush();
    if (!out) {
      const int err = errno;
      out.close();
      std::error_code ec;
      fs::remove(tmp, ec);
      io_fail(path, "writing the temporary '" + tmp + "' failed", err);
    }
    out.close();
    if (!out) {
      const int err = errno;
      std::error_code ec;
      fs::remove(tmp, ec);
      io_fail(path, "closing the temporary '" + tmp + "' failed", err);
    }
  }
  rename_into_place(tmp, path);
}

}  // namespace detail

// ---------------------------------------------------------------------------
// write_text_atomically, read_manifest
// ---------------------------------------------------------------------------
void write_text_atomically(const std::string& path, const std::string& text) {
  const fs::path p(path);
  record_in_manifest(p.has_parent_path() ? p.parent_path() : fs::path("."), p.filename().string());
  write_atomically(path, text);
}

std::vector<std::string> read_manifest(const std::string& dir) {
  std::vector<std::string> names;
  std::ifstream in(fs::path(dir) / kManifestName);
  std::string line;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#' && plain_name(line) && line != kManifestName) names.push_back(line);
  return names;
}

// ---------------------------------------------------------------------------
// prepare_output_dir
// ---------------------------------------------------------------------------
namespace {

const std::string kProbePrefix = ".lbdem_write_probe_";  // write probes (prepare_output_dir)

// "<name>.tmp<digits>" with <name> in `ours`, or "<prefix><digits>": a
// temporary of one of our files, or a write probe, left by a killed run.
bool leftover_of(const std::string& n, const std::set<std::string>& ours, const std::string& probe_prefix) {
  auto digits_from = [&](std::size_t k) {
    return k < n.size() && std::all_of(n.begin() + static_cast<std::ptrdiff_t>(k), n.end(),
                                       [](char ch) { return ch >= '0' && ch <= '9'; });
  };
  if (n.rfind(probe_prefix, 0) == 0 && digits_from(probe_prefix.size())) return true;
  const auto t = n.rfind(".tmp");
  return t != std::string::npos && t > 0 && digits_from(t + 4) && ours.count(n.substr(0, t)) > 0;
}

std::string name_list(const std::vector<std::string>& names) {
  std::string s;
  const std::size_t shown = std::min<std::size_t>(names.size(), 10);
  for (std::size_t i = 0; i < shown; ++i) s += (i ? ", '" : "'") + names[i] + "'";
  if (names.size() > shown) s += " and " + std::to_string(names.size() - shown) + " more";
  return s;
}

// A kernel file system (proc, sysfs, cgroup, ...) that holds `p`: its
// entries are not files, and a run's output cannot go there. Empty: none.
std::string pseudo_file_system(const fs::path& p) {
#ifdef __linux__
  struct statfs sf {};
  if (::statfs(p.c_str(), &sf) != 0) return {};
  switch (static_cast<unsigned long>(sf.f_type)) {
    case 0x9fa0UL: return "proc";
    case 0x62656572UL: return "sysfs";
    case 0x27e0ebUL: case 0x63677270UL: return "cgroup";
    case 0x64626720UL: return "debugfs";
    case 0x74726163UL: return "tracefs";
    case 0x73636673UL: return "securityfs";
    case 0x1cd1UL: return "devpts";
    case 0xcafe4a11UL: return "bpf";
    default: return {};
  }
#else
  (void)p;
  return {};
#endif
}

// Why a folder cannot take new entries, judged without writing (empty: it
// can, as far as one can tell without trying; prepare_output_dir then tries).
std::string unwritable_reason(const fs::path& p) {
  if (const std::string k = pseudo_file_system(p); !k.empty()) return "it is on the kernel's " + k + " file system";
  struct statvfs sv {};
  if (::statvfs(p.c_str(), &sv) == 0 && (sv.f_flag & ST_RDONLY)) return "it is on a read-only file system";
  if (::access(p.c_str(), W_OK | X_OK) != 0) return "no permission to write there";
  return {};
}

}  // namespace

std::vector<std::string> check_output_dir(const std::string& dir, bool overwrite) {
  if (dir.empty()) throw ConfigError("output folder is empty: give a folder name");
  std::error_code ec;
  const fs::path p(dir);
  if (fs::exists(p, ec) && !fs::is_directory(p, ec))
    throw ConfigError("output folder '" + dir + "' exists and is not a folder; choose another output folder");
  if (!fs::exists(p, ec)) {
    // To be created: the nearest folder above it that exists must take it.
    fs::path a = p.parent_path();
    while (!a.empty() && !fs::exists(a, ec) && a.has_relative_path()) a = a.parent_path();
    if (a.empty()) a = ".";
    if (!fs::is_directory(a, ec))
      throw ConfigError("cannot create output folder '" + dir + "': '" + a.string() +
                        "' is not a folder; choose a writable output folder");
    if (const std::string why = unwritable_reason(a); !why.empty())
      throw ConfigError("cannot create output folder '" + dir + "' in '" + a.string() + "': " + why +
                        "; choose a writable output folder");
    return {};
  }
  if (const std::string k = pseudo_file_system(p); !k.empty())
    throw ConfigError("output folder '" + dir + "' is on the kernel's " + k +
                      " file system; choose a writable output folder");

  // The folder's entries, not following symlinks (a symlink is listed, never entered).
  std::vector<std::pair<std::string, fs::file_status>> entries;
  bool have_manifest = false, manifest_ok = false;
  for (fs::directory_iterator it(p, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const fs::file_status st = it->symlink_status(ec);
    if (ec) break;
    if (name == kManifestName) {
      have_manifest = true;
      manifest_ok = fs::is_regular_file(st);
      if (manifest_ok) continue;
    }
    entries.emplace_back(name, st);
  }
  if (ec) throw ConfigError("cannot list output folder '" + dir + "': " + ec.message());
  if (!entries.empty() && !overwrite)
    throw ConfigError("output folder '" + dir + "' is not empty (" + std::to_string(entries.size()) +
                      " entries); pass --overwrite to replace its results, or choose another folder");

  // With --overwrite: our files are the regular files the manifest names (and
  // temporaries of them); anything else stops the run before a file is removed.
  std::vector<std::string> remove, foreign;
  if (!entries.empty()) {
    std::set<std::string> ours;
    if (manifest_ok)
      for (auto& n : read_manifest(dir)) ours.insert(n);
    std::set<std::string> with_manifest = ours;  // the manifest's own temporaries are ours too
    with_manifest.insert(kManifestName);
    for (const auto& [name, st] : entries) {
      const bool mine = fs::is_regular_file(st) && (ours.count(name) > 0 || leftover_of(name, with_manifest, kProbePrefix));
      (mine ? remove : foreign).push_back(name);
    }
    std::sort(foreign.begin(), foreign.end());
    if (!foreign.empty() && !manifest_ok)
      throw ConfigError("output folder '" + dir + "' has " +
                        (have_manifest ? std::string("a run manifest '") + kManifestName + "' that is not a regular file"
                                       : std::string("no run manifest '") + kManifestName + "'") +
                        ", so --overwrite cannot tell lbdem's files from others: " + name_list(foreign) +
                        " (files like these may be results of an older lbdem version); nothing was deleted. Remove "
                        "them yourself or choose another output folder");
    if (!foreign.empty())
      throw ConfigError("output folder '" + dir + "' holds " + std::to_string(foreign.size()) +
                        " entries that no lbdem run wrote there: " + name_list(foreign) +
                        "; --overwrite removes only the files named in '" + kManifestName +
                        "', so nothing was deleted. Move those entries away or choose another output folder");
  }
  if (const std::string why = unwritable_reason(p); !why.empty())
    throw ConfigError("output folder '" + dir + "' is not writable (" + why + "); choose a writable output folder");
  return remove;
}

void prepare_output_dir(const std::string& dir, bool overwrite) {
  const std::vector<std::string> remove = check_output_dir(dir, overwrite);
  std::error_code ec;
  const fs::path p(dir);
  fs::create_directories(p, ec);
  if (ec || !fs::is_directory(p))
    throw ConfigError("cannot create output folder '" + dir + "': " + (ec ? ec.message() : "not a folder") +
                      "; choose a writable output folder");

  // Writability: create and remove a probe file (permission bits lie for root
  // and on some network file systems; trying is the only reliable test).
  const fs::path probe = p / (kProbePrefix + std::to_string(static_cast<long>(::getpid())));
  {
    std::ofstream out(probe);
    bool ok = static_cast<bool>(out);
    if (ok) {
      out << "probe\n";
      out.flush();
      ok = static_cast<bool>(out);
    }
    if (!ok) {
      out.close();
      fs::remove(probe, ec);
      throw ConfigError("output folder '" + dir + "' is not writable; choose a writable output folder");
    }
  }
  fs::remove(probe, ec);
  if (ec) throw ConfigError("cannot remove probe file in output folder '" + dir + "': " + ec.message());

  for (const auto& name : remove) {
    fs::remove(p / name, ec);
    if (ec) throw ConfigError("cannot remove '" + (p / name).string() + "' in output folder '" + dir + "': " + ec.message());
  }
  // A fresh manifest: this run records its files as it writes them.
  try {
    write_atomically((p / kManifestName).string(),
                     "# lbdem run manifest: every file lbdem wrote in this folder; --overwrite removes only these\n");
  } catch (const Error& e) {
    throw ConfigError(std::string("output folder '") + dir + "': " + e.what());
  }
}

void record_output_file(const std::string& dir, const std::string& name) {
  if (!plain_name(name)) throw Error("output file name '" + name + "' is not a plain file name");
  record_in_manifest(fs::path(dir), name);
}

void replace_file_atomically(const std::string& path, const std::string& text) { write_atomically(path, text); }

}  // namespace lbdem::io
