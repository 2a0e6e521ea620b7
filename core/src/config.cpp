#include "core/config.hpp"

#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/eventhandler.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unordered_map>
#include <cstdio>
#include <limits>
#include <map>
#include <sstream>

namespace lbdem {

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

namespace {
std::string fmt_num(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}
std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}
}  // namespace

Config Config::load_file(const std::string& path) {
  // Only a regular file of bounded size is read: a device (/dev/zero), a FIFO
  // or a huge file would otherwise be read to the end before any check.
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st))
    throw ConfigError(path + ": cannot open the case file (does it exist and is it readable?)");
  if (!fs::is_regular_file(st))
    throw ConfigError(path + ": the case file is not a regular file (it is a " +
                      (fs::is_directory(st) ? "folder" : fs::is_character_file(st) ? "character device"
                       : fs::is_block_file(st) ? "block device" : fs::is_fifo(st) ? "pipe" : "special file") +
                      "); give a YAML case file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path + ": cannot open the case file (does it exist and is it readable?)");
  // Read at most one byte past the limit (the size may change while reading).
  std::string text(kMaxFileBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(in.gcount()));
  if (in.bad()) throw ConfigError(path + ": cannot read the case file");
  return from_string(text, path);
}

std::string printable(const std::string& s, std::size_t max_chars) {
  std::string out;
  std::size_t shown = 0, i = 0;
  auto hex = [](unsigned long v, int digits) {
    char b[16];
    std::snprintf(b, sizeof b, "%0*lx", digits, v);
    return std::string(b);
  };
  while (i < s.size()) {
    if (max_chars > 0 && shown >= max_chars) return out.append("... (").append(std::to_string(s.size())).append(" bytes)");
    const auto c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
      ++i;
    } else if (c < 0x80) {
      if (c == '\n') out += "\\n";
      else if (c == '\t') out += "\\t";
      else if (c == '\r') out += "\\r";
      else out.append("\\x").append(hex(c, 2));
      ++i;
    } else {
      // A UTF-8 sequence: decoded and shown as \uXXXX (a key or value in an
      // error message must show characters a terminal would hide, such as
      // U+200B ZERO WIDTH SPACE or U+00A0 NO-BREAK SPACE).
      const int len = c >= 0xf0 ? 4 : c >= 0xe0 ? 3 : c >= 0xc0 ? 2 : 1;
      unsigned long cp = len == 4 ? c & 0x07u : len == 3 ? c & 0x0fu : len == 2 ? c & 0x1fu : c;
      bool ok = len > 1 && i + static_cast<std::size_t>(len) <= s.size();
      for (int k = 1; ok && k < len; ++k) {
        const auto cc = static_cast<unsigned char>(s[i + static_cast<std::size_t>(k)]);
        ok = (cc & 0xc0u) == 0x80u;
        cp = (cp << 6) | (cc & 0x3fu);
      }
      if (ok) {
        out.append(cp > 0xffff ? "\\U" : "\\u").append(hex(cp, cp > 0xffff ? 8 : 4));
        i += static_cast<std::size_t>(len);
      } else {
        out.append("\\x").append(hex(c, 2));
        ++i;
      }
    }
    ++shown;
  }
  return out;
}

namespace {

// Nesting deeper than this is refused by the case-file check below; the
// deepest shipped case file nests 3 levels (particles.list[i].position).
constexpr int kMaxDepth = 16;
// Keys longer than this get no did-you-mean suggestion (the edit distance
// costs their length times the known key's).
constexpr std::size_t kMaxKeyChars = 256;

std::string line_of(const YAML::Mark& m) {
  std::string s;  // appended piecewise: GCC 12 warns (-Wrestrict, a false positive) on ":" + std::string
  if (!m.is_null()) s.append(":").append(std::to_string(m.line + 1));
  return s;
}

// Structural checks yaml-cpp does not make: every key a plain name (a scalar),
// no key twice in one section (yaml-cpp keeps both and a lookup returns the
// first), at most kMaxDepth levels of nesting.
void check_tree(const YAML::Node& n, const std::string& src, const std::string& path, int depth) {
  if (depth > kMaxDepth)
    throw ConfigError(src + line_of(n.Mark()) + ": '" + path + "' nests sections or lists " + std::to_string(depth) +
                      " levels deep; a case file nests at most " + std::to_string(kMaxDepth));
  if (n.IsSequence()) {
    for (std::size_t i = 0; i < n.size(); ++i) check_tree(n[i], src, path + "[" + std::to_string(i) + "]", depth + 1);
    return;
  }
  if (!n.IsMap()) return;
  std::map<std::string, int> seen;  // key -> line (1-based)
  for (auto it = n.begin(); it != n.end(); ++it) {
    const YAML::Node k = it->first;  // a copy: the iterator hands out a temporary pair
    if (!k.IsScalar())
      throw ConfigError(src + line_of(k.Mark()) + ": a key in section '" + (path.empty() ? "(top level)" : path) +
                        "' is a " + (k.IsMap() ? "section" : k.IsSequence() ? "list" : "null value") +
                        "; keys must be plain names such as 'tau'");
    const std::string name = k.Scalar();
    const std::string full = path.empty() ? printable(name, Config::kMaxValueChars)
                                           : path + "." + printable(name, Config::kMaxValueChars);
    const int line = k.Mark().is_null() ? 0 : k.Mark().line + 1;
    if (auto [pos, fresh] = seen.emplace(name, line); !fresh)
      throw ConfigError(src + line_of(k.Mark()) + ": key '" + full + "' appears twice in one section (first at line " +
                        std::to_string(pos->second) + "); remove one of them");
    check_tree(it->second, src, full, depth + 1);
  }
}

// Counts the documents of a YAML stream, at most two (yaml-cpp 0.7's
// LoadAll() loops without end, allocating, on some malformed streams such as
// one starting with ','; this loop is bounded), and where the second starts.
//
// It also counts the nodes (scalars, nulls, lists, sections; keys included)
// each document expands to, an alias counting as every node of its anchor's
// value, and refuses a document past Config::kMaxNodes as soon as the count
// passes it. yaml-cpp shares an aliased node instead of copying it, so
// nested aliases ("a: &a [x, x], b: &b [*a, *a], ...") make a tree that is
// small in memory but exponential to walk; every later walk (the checks
// below, the key lookups, an error message's echo of a value) is bounded by
// this count. The count is linear in the file: each anchor's expanded size is
// kept when its node ends.
class DocumentCounter : public YAML::EventHandler {
 public:
  explicit DocumentCounter(std::string source) : source_(std::move(source)) {}
  YAML::Mark second;
  void OnDocumentStart(const YAML::Mark& m) override {
    if (++docs_ == 2) second = m;
    nodes_ = 0;
    anchors_.clear();
    open_.clear();
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& m, YAML::anchor_t a) override { leaf(m, a); }
  void OnAlias(const YAML::Mark& m, YAML::anchor_t a) override {
    const auto it = anchors_.find(a);
    add(m, it == anchors_.end() ? 1 : it->second);  // (an alias inside its own anchor: yaml-cpp refuses it)
  }
  void OnScalar(const YAML::Mark& m, const std::string&, YAML::anchor_t a, const std::string&) override { leaf(m, a); }
  void OnSequenceStart(const YAML::Mark& m, const std::string&, YAML::anchor_t a, YAML::EmitterStyle::value) override {
    open(m, a);
  }
  void OnSequenceEnd() override { close(); }
  void OnMapStart(const YAML::Mark& m, const std::string&, YAML::anchor_t a, YAML::EmitterStyle::value) override {
    open(m, a);
  }
  void OnMapEnd() override { close(); }

 private:
  void add(const YAML::Mark& m, std::size_t n) {
    nodes_ += std::min(n, Config::kMaxNodes + 1);
    if (nodes_ > Config::kMaxNodes)
      throw ConfigError(source_ + line_of(m) + ": the document expands to more than " +
                        std::to_string(Config::kMaxNodes) +
                        " values, keys and sections (aliases '*name' count as a copy of their anchor's value); a "
                        "case file holds settings, not data: list large particle sets in a file (particles.init: "
                        "csv or hdf5)");
  }
  void leaf(const YAML::Mark& m, YAML::anchor_t a) {
    add(m, 1);
    if (a != YAML::NullAnchor) anchors_[a] = 1;
  }
  void open(const YAML::Mark& m, YAML::anchor_t a) {
    open_.push_back({a, nodes_});
    add(m, 1);
  }
  void close() {
    if (open_.empty()) return;
    const auto [a, start] = open_.back();
    open_.pop_back();
    if (a != YAML::NullAnchor) anchors_[a] = nodes_ - start;
  }
  std::string source_;
  int docs_ = 0;
  std::size_t nodes_ = 0;
  std::unordered_map<YAML::anchor_t, std::size_t> anchors_;  // anchor -> nodes its value expands to
  std::vector<std::pair<YAML::anchor_t, std::size_t>> open_;  // open lists/sections: anchor, count at start
};

// yaml-cpp's exception as one line: file, line (and column where short enough
// to help), what.
[[noreturn]] void syntax_error(const std::string& source_name, const YAML::Exception& e) {
  std::string where = "line " + std::to_string(e.mark.line + 1);
  if (e.mark.column >= 0 && e.mark.column < 200) where += ", column " + std::to_string(e.mark.column + 1);
  throw ConfigError(source_name + ": YAML syntax error at " + where + ": " + printable(e.msg, 120));
}

}  // namespace

Config Config::from_string(const std::string& yaml, const std::string& source_name) {
  if (yaml.size() > kMaxFileBytes)
    throw ConfigError(source_name + ": the case file is larger than " + std::to_string(kMaxFileBytes >> 20) +
                      " MiB, the limit of a case file (it holds settings, not data: list large particle sets in a "
                      "file, particles.init: csv or hdf5)");
  YAML::Node n;
  int docs = 0;
  DocumentCounter counter(source_name);
  try {
    // The event pass first: it refuses a document that expands past
    // kMaxNodes before anything walks the tree.
    std::istringstream is(yaml);
    YAML::Parser parser(is);
    while (docs < 2 && parser.HandleNextDocument(counter)) ++docs;
    n = YAML::Load(yaml);
  } catch (const YAML::DeepRecursion& e) {
    throw ConfigError(source_name + ":" + std::to_string(e.mark.line + 1) +
                      ": brackets or indentation nest more than " + std::to_string(e.depth()) +
                      " levels deep; a case file nests at most " + std::to_string(kMaxDepth));
  } catch (const YAML::Exception& e) {
    syntax_error(source_name, e);
  }
  if (!n.IsMap()) {
    // Name the first line that is not blank, a comment or a document marker.
    std::istringstream is(yaml);
    std::string l, where;
    for (int no = 1; std::getline(is, l); ++no) {
      const auto p = l.find_first_not_of(" \t\r");
      if (p == std::string::npos || l[p] == '#' || l.rfind("---", 0) == 0) continue;
      where = ":" + std::to_string(no) + ": '" + printable(l, kMaxValueChars) + "' is not a 'key: value' line";
      break;
    }
    throw ConfigError(source_name + (where.empty() ? ": the file is empty" : where) +
                      "; the case file must be a YAML mapping of keys (e.g. 'scene: channel')");
  }
  if (docs > 1)
    throw ConfigError(source_name + line_of(counter.second) +
                      ": the file holds more than one YAML document (separated by '---'); a case file is one "
                      "document: remove the '---' line and merge the sections, or split the file");
  check_tree(n, source_name, "", 0);
  return Config(n, std::make_shared<std::string>(source_name), "", std::make_shared<std::set<std::string>>());
}

std::string Config::full_key(const std::string& key) const {
  return path_.empty() ? printable(key) : path_ + "." + printable(key);
}

std::string Config::value_text(const std::string& key) const {
  YAML::Node v = node_[key];
  if (!v) return "<missing>";
  if (v.IsScalar()) return printable(v.Scalar(), kMaxValueChars);
  YAML::Emitter e;
  e << YAML::Flow << v;
  return printable(e.c_str(), kMaxValueChars);
}

std::string Config::where(const std::string& key) const {
  for (auto it = node_.begin(); it != node_.end(); ++it)
    if (it->first.IsScalar() && it->first.Scalar() == key) return *source_ + line_of(it->first.Mark());
  return *source_ + line_of(node_.Mark());
}

void Config::fail(const std::string& key, const std::string& what) const {
  std::string msg = where(key) + ": key '" + full_key(key) + "'";
  if (node_[key]) msg += " = " + value_text(key);
  throw ConfigError(msg + ": " + what);
}

bool Config::has(const std::string& key) const {
  read_->insert(full_key(key));  // a key a scene asks about is one it knows (keys_read), though not read yet
  return static_cast<bool>(node_[key]);
}

YAML::Node Config::get_node(const std::string& key) const {
  mark(key);
  YAML::Node v = node_[key];
  if (!v || v.IsNull()) {
    // A key written with a typo or a character a terminal hides (U+200B,
    // U+00A0) is named with that character shown.
    std::string near;
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      const std::string k = it->first.Scalar();
      std::string ascii;
      for (char ch : k)
        if (static_cast<unsigned char>(ch) >= 0x20 && static_cast<unsigned char>(ch) < 0x7f) ascii += ch;
      if (k != key && k.size() <= kMaxKeyChars &&
          (ascii == key || edit_distance(k, key) <= std::max<std::size_t>(2, key.size() / 4))) {
        near = " (the section has '" + full_key(k) + "' at line " + std::to_string(it->first.Mark().line + 1) +
               (printable(k) != k ? ", with a non-printing character shown escaped: retype it" : ": a typo?") + ")";
        break;
      }
    }
    throw ConfigError(where(key) + ": missing required key '" + full_key(key) + "'" + near);
  }
  return v;
}

void Config::accept(const std::string& key) const { mark(key); }

void Config::mark(const std::string& key) const {
  used_->insert(key);
  read_->insert(full_key(key));
}

std::vector<std::string> Config::keys_read() const { return {read_->begin(), read_->end()}; }

Config Config::section(const std::string& key) const {
  YAML::Node v = get_node(key);
  if (!v.IsMap()) fail(key, "must be a section (a mapping of keys)");
  return Config(v, source_, full_key(key), read_);
}

std::optional<Config> Config::optional_section(const std::string& key) const {
  mark(key);
  if (!has(key)) return std::nullopt;
  return section(key);
}

std::vector<Config> Config::sequence(const std::string& key) const {
  YAML::Node v = get_node(key);
  if (!v.IsSequence()) fail(key, "must be a list of sections");
  std::vector<Config> out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!v[i].IsMap()) fail(key, "entry " + std::to_string(i) + " must be a section (a mapping of keys)");
    out.push_back(Config(v[i], source_, full_key(key) + "[" + std::to_string(i) + "]", read_));
  }
  return out;
}

double Config::number(const std::string& key) const {
  YAML::Node v = get_node(key);
  if (!v.IsScalar()) fail(key, "must be a number");
  double d;
  try {
    d = v.as<double>();
  } catch (const YAML::Exception&) {
    fail(key, "must be a number");
  }
  if (!std::isfinite(d)) fail(key, "must be a finite number");
  return d;
}
double Config::number(const std::string& key, double def) const {
  mark(key);
  return has(key) ? number(key) : def;
}

double Config::number_in(const std::string& key, double lo, double hi, const std::string& why) const {
  const double d = number(key);
  if (d < lo || d > hi)
    fail(key, "must be in [" + fmt_num(lo) + ", " + fmt_num(hi) + "]" + (why.empty() ? "" : " (" + why + ")"));
  return d;
}
double Config::number_in(const std::string& key, double def, double lo, double hi, const std::string& why) const {
  mark(key);
  return has(key) ? number_in(key, lo, hi, why) : def;
}
double Config::positive(const std::string& key) const {
  const double d = number(key);
  if (!(d > 0)) fail(key, "must be greater than 0");
  return d;
}
double Config::positive(const std::string& key, double def) const {
  mark(key);
  return has(key) ? positive(key) : def;
}

long Config::integer_in(const std::string& key, long lo, long hi) const {
  YAML::Node v = get_node(key);
  long x;
  try {
    if (!v.IsScalar()) throw YAML::Exception(YAML::Mark(), "");
    x = v.as<long>();
  } catch (const YAML::Exception&) {
    fail(key, "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  }
  if (x < lo || x > hi) fail(key, "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return x;
}
long Config::integer_in(const std::string& key, long def, long lo, long hi) const {
  mark(key);
  return has(key) ? integer_in(key, lo, hi) : def;
}

bool Config::boolean(const std::string& key, bool def) const {
  mark(key);
  if (!has(key)) return def;
  YAML::Node v = get_node(key);
  try {
    if (!v.IsScalar()) throw YAML::Exception(YAML::Mark(), "");
    return v.as<bool>();
  } catch (const YAML::Exception&) {
    fail(key, "must be true or false");
  }
}

std::string Config::text(const std::string& key) const {
  YAML::Node v = get_node(key);
  if (!v.IsScalar()) fail(key, "must be a string");
  return v.as<std::string>();
}
std::string Config::text(const std::string& key, const std::string& def) const {
  mark(key);
  return has(key) ? text(key) : def;
}

std::string Config::choice(const std::string& key, const std::vector<std::string>& valid) const {
  const std::string s = text(key);
  if (std::find(valid.begin(), valid.end(), s) != valid.end()) return s;
  std::string best;
  std::size_t bd = std::numeric_limits<std::size_t>::max();
  for (auto& v : valid)
    if (auto d = edit_distance(s, v); d < bd) { bd = d; best = v; }
  std::string hint = (bd <= std::max<std::size_t>(2, s.size() / 3)) ? " (did you mean '" + best + "'?)" : "";
  fail(key, "is not one of: " + join(valid) + hint);
}
std::string Config::choice(const std::string& key, const std::string& def, const std::vector<std::string>& valid) const {
  mark(key);
  return has(key) ? choice(key, valid) : def;
}

std::vector<double> Config::numbers(const std::string& key, std::size_t min_len, std::size_t max_len) const {
  YAML::Node v = get_node(key);
  const std::string want = min_len == max_len ? "a list of " + std::to_string(min_len) + " numbers"
                                              : "a list of " + std::to_string(min_len) + " to " +
                                                    std::to_string(max_len) + " numbers";
  if (!v.IsSequence() || v.size() < min_len || v.size() > max_len) fail(key, "must be " + want);
  std::vector<double> out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    try {
      if (!v[i].IsScalar()) throw YAML::Exception(YAML::Mark(), "");
      out.push_back(v[i].as<double>());
    } catch (const YAML::Exception&) {
      fail(key, "must be " + want);
    }
    if (!std::isfinite(out.back())) fail(key, "must contain finite numbers");
  }
  return out;
}
std::vector<double> Config::numbers(const std::string& key, const std::vector<double>& def, std::size_t min_len,
                                    std::size_t max_len) const {
  mark(key);
  return has(key) ? numbers(key, min_len, max_len) : def;
}

std::vector<long> Config::integers(const std::string& key, std::size_t min_len, std::size_t max_len, long lo,
                                   long hi) const {
  YAML::Node v = get_node(key);
  const std::string want = (min_len == max_len ? "a list of " + std::to_string(min_len)
                                               : "a list of " + std::to_string(min_len) + " to " +
                                                     std::to_string(max_len)) +
                           " integers in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (!v.IsSequence() || v.size() < min_len || v.size() > max_len) fail(key, "must be " + want);
  std::vector<long> out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    long x = 0;
    try {
      if (!v[i].IsScalar()) throw YAML::Exception(YAML::Mark(), "");
      x = v[i].as<long>();
    } catch (const YAML::Exception&) {
      fail(key, "must be " + want);
    }
    if (x < lo || x > hi) fail(key, "must be " + want);
    out.push_back(x);
  }
  return out;
}

void Config::finish() const {
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    const std::string k = it->first.Scalar();  // keys are scalars (check_tree)
    if (used_->count(k)) continue;
    std::string best;
    std::size_t bd = std::numeric_limits<std::size_t>::max();
    if (k.size() <= kMaxKeyChars)  // a suggestion for a name, not for a pasted paragraph
      for (auto& u : *used_)
        if (auto d = edit_distance(k, u); d < bd) { bd = d; best = u; }
    std::string msg = *source_ + line_of(it->first.Mark()) + ": unknown key '" +
                      (path_.empty() ? "" : path_ + ".") + printable(k, kMaxValueChars) + "'";
    if (!best.empty() && bd <= std::max<std::size_t>(2, k.size() / 3)) msg += " (did you mean '" + full_key(best) + "'?)";
    std::vector<std::string> known(used_->begin(), used_->end());
    msg += "; known keys here: " + join(known);
    throw ConfigError(msg);
  }
}

}  // namespace lbdem
