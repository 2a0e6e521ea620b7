#pragma once
// File helpers shared by core's output writers (output_manifest.cpp, output_hdf5.cpp, output_csv.cpp): the
// run manifest, atomic writes, one-line write failures. Internal to core: not included from outside core/src.
#include <filesystem>
#include <string>

namespace lbdem::io::detail {

// A write to `path` failed with errno `err`: one line, ResourceError when the disk or quota is full or the
// file passes a file-size limit (EFBIG: RLIMIT_FSIZE, the filesystem's largest file).
[[noreturn]] void io_fail(const std::string& path, const std::string& what, int err);
// Renames a complete temporary to its final name (same folder: atomic); on failure removes it.
void rename_into_place(const std::string& tmp, const std::string& path);
// A plain file name (no folder part, not "." or ".."): the only names a manifest may list.
bool plain_name(const std::string& n);
// Appends `name` to the manifest of `dir` before the file is created, so that even a run killed while writing
// it has it on record. A symlink in place of the manifest is refused rather than written through.
void record_in_manifest(const std::filesystem::path& dir, const std::string& name);
// Writes `text` to `path` atomically: temporary file in the same folder, then rename.
void write_atomically(const std::string& path, const std::string& text);

}  // namespace lbdem::io::detail
