#pragma once
// Validated case files (YAML).
//
// Loading refuses what yaml-cpp accepts but a case file must not hold: a
// second YAML document, a key given twice in one section (yaml-cpp would let
// the first win), a key that is not a plain name, nesting deeper than a case
// file needs. Every message starts with "file:line".
//
// Every read names its key; a missing key, a wrong type or an out-of-range
// value throws ConfigError naming the file, the full key path, the value and
// what would be valid. After a section has been read, finish() rejects keys
// that were never asked for, suggesting the closest known key.
#include <yaml-cpp/yaml.h>

#include <array>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace lbdem {

class Config {
 public:
  // Loads a YAML file; throws ConfigError (unreadable file, syntax error with line).
  static Config load_file(const std::string& path);
  static Config from_string(const std::string& yaml, const std::string& source_name = "<string>");

  const std::string& source() const { return *source_; }
  const std::string& path() const { return path_; }  // dotted key path of this node ("" for root)
  bool has(const std::string& key) const;

  // Sections.
  Config section(const std::string& key) const;                       // required
  std::optional<Config> optional_section(const std::string& key) const;

  // Scalars. Ranges are inclusive unless stated; `why` explains the limit.
  double number(const std::string& key) const;
  double number(const std::string& key, double def) const;
  double number_in(const std::string& key, double lo, double hi, const std::string& why = "") const;
  double number_in(const std::string& key, double def, double lo, double hi, const std::string& why = "") const;
  double positive(const std::string& key) const;  // > 0
  double positive(const std::string& key, double def) const;
  long integer_in(const std::string& key, long lo, long hi) const;
  long integer_in(const std::string& key, long def, long lo, long hi) const;
  bool boolean(const std::string& key, bool def) const;
  std::string text(const std::string& key) const;
  std::string text(const std::string& key, const std::string& def) const;
  std::string choice(const std::string& key, const std::vector<std::string>& valid) const;
  std::string choice(const std::string& key, const std::string& def, const std::vector<std::string>& valid) const;
  // Fixed-length number lists, e.g. [nx, ny, nz].
  std::vector<double> numbers(const std::string& key, std::size_t min_len, std::size_t max_len) const;
  std::vector<double> numbers(const std::string& key, const std::vector<double>& def, std::size_t min_len,
                              std::size_t max_len) const;
  std::vector<long> integers(const std::string& key, std::size_t min_len, std::size_t max_len, long lo,
                             long hi) const;
  // Sequence of sections (e.g. a list of walls).
  std::vector<Config> sequence(const std::string& key) const;

  // Throws if this node has keys never read (with a did-you-mean suggestion).
  void finish() const;
  // Marks a key as known without reading it (handled elsewhere).
  void accept(const std::string& key) const;

  // An error about key `key` of this node with the offending value shown.
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;
  std::string full_key(const std::string& key) const;  // dotted path, non-printing characters shown as \uXXXX
  // The value as written (flow style), clipped to kMaxValueChars characters.
  std::string value_text(const std::string& key) const;
  // "file:line" of `key` in this section (of the section itself when the key is absent).
  std::string where(const std::string& key) const;
  static constexpr std::size_t kMaxValueChars = 60;
  // Limits on a case file, so that any input is read and refused in well
  // under a second: its size (the shipped cases are a few kB; an explicit
  // particle list of ~50,000 spheres fits, larger sets belong in a csv or
  // hdf5 file) and the nodes (values, keys, lists, sections) its document
  // expands to with every alias counted as a copy of its anchor's value.
  static constexpr std::size_t kMaxFileBytes = std::size_t{4} << 20;
  static constexpr std::size_t kMaxNodes = 1'000'000;

  // Every key path any Config of this file has asked for so far (sections,
  // list entries as path[i]), whether present or defaulted: the keys a scene
  // accepts, for the tests of the error messages.
  std::vector<std::string> keys_read() const;

 private:
  Config(YAML::Node n, std::shared_ptr<std::string> src, std::string path,
         std::shared_ptr<std::set<std::string>> read)
      : node_(std::move(n)), source_(std::move(src)), path_(std::move(path)),
        used_(std::make_shared<std::set<std::string>>()), read_(std::move(read)) {}
  YAML::Node get_node(const std::string& key) const;  // marks used, throws if missing
  void mark(const std::string& key) const;            // `key` is known here
  YAML::Node node_;
  std::shared_ptr<std::string> source_;
  std::string path_;
  std::shared_ptr<std::set<std::string>> used_;
  std::shared_ptr<std::set<std::string>> read_;  // shared by every Config of one file
};

// `s` for an error message: printable ASCII as is; control characters, and
// every non-ASCII character, as escapes (\n, \x01, \u200b), so that a
// character a terminal would not show can be seen; with max_chars > 0, cut
// after that many characters with "... (N bytes)".
std::string printable(const std::string& s, std::size_t max_chars = 0);

// Levenshtein distance, for suggestions.
std::size_t edit_distance(const std::string& a, const std::string& b);

}  // namespace lbdem
