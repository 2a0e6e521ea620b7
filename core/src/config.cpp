#include "core/config.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
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
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the case file (does it exist and is it readable?)");
  std::stringstream ss;
  ss << in.rdbuf();
  return from_string(ss.str(), path);
}

Config Config::from_string(const std::string& yaml, const std::string& source_name) {
  YAML::Node n;
  try {
    n = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    throw ConfigError(source_name + ": YAML syntax error at line " + std::to_string(e.mark.line + 1) +
                      ", column " + std::to_string(e.mark.column + 1) + ": " + e.msg);
  }
  if (!n.IsMap())
    throw ConfigError(source_name + ": the case file must be a YAML mapping of keys (e.g. 'scene: channel')");
  return Config(n, std::make_shared<std::string>(source_name), "");
}

std::string Config::full_key(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

std::string Config::value_text(const std::string& key) const {
  YAML::Node v = node_[key];
  if (!v) return "<missing>";
  YAML::Emitter e;
  e << YAML::Flow << v;
  return e.c_str();
}

void Config::fail(const std::string& key, const std::string& what) const {
  std::string msg = *source_ + ": key '" + full_key(key) + "'";
  if (node_[key]) msg += " = " + value_text(key);
  throw ConfigError(msg + ": " + what);
}

bool Config::has(const std::string& key) const { return static_cast<bool>(node_[key]); }

YAML::Node Config::get_node(const std::string& key) const {
  used_->insert(key);
  YAML::Node v = node_[key];
  if (!v || v.IsNull())
    throw ConfigError(*source_ + ": missing required key '" + full_key(key) + "'");
  return v;
}

void Config::accept(const std::string& key) const { used_->insert(key); }

Config Config::section(const std::string& key) const {
  YAML::Node v = get_node(key);
  if (!v.IsMap()) fail(key, "must be a section (a mapping of keys)");
  return Config(v, source_, full_key(key));
}

std::optional<Config> Config::optional_section(const std::string& key) const {
  used_->insert(key);
  if (!has(key)) return std::nullopt;
  return section(key);
}

std::vector<Config> Config::sequence(const std::string& key) const {
  YAML::Node v = get_node(key);
  if (!v.IsSequence()) fail(key, "must be a list of sections");
  std::vector<Config> out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!v[i].IsMap()) fail(key, "entry " + std::to_string(i) + " must be a section (a mapping of keys)");
    out.push_back(Config(v[i], source_, full_key(key) + "[" + std::to_string(i) + "]"));
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
  used_->insert(key);
  return has(key) ? number(key) : def;
}

double Config::number_in(const std::string& key, double lo, double hi, const std::string& why) const {
  const double d = number(key);
  if (d < lo || d > hi)
    fail(key, "must be in [" + fmt_num(lo) + ", " + fmt_num(hi) + "]" + (why.empty() ? "" : " (" + why + ")"));
  return d;
}
double Config::number_in(const std::string& key, double def, double lo, double hi, const std::string& why) const {
  used_->insert(key);
  return has(key) ? number_in(key, lo, hi, why) : def;
}
double Config::positive(const std::string& key) const {
  const double d = number(key);
  if (!(d > 0)) fail(key, "must be greater than 0");
  return d;
}
double Config::positive(const std::string& key, double def) const {
  used_->insert(key);
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
  used_->insert(key);
  return has(key) ? integer_in(key, lo, hi) : def;
}

bool Config::boolean(const std::string& key, bool def) const {
  used_->insert(key);
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
  used_->insert(key);
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
  used_->insert(key);
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
  used_->insert(key);
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
    const std::string k = it->first.as<std::string>();
    if (used_->count(k)) continue;
    std::string best;
    std::size_t bd = std::numeric_limits<std::size_t>::max();
    for (auto& u : *used_)
      if (auto d = edit_distance(k, u); d < bd) { bd = d; best = u; }
    std::string msg = *source_ + ": unknown key '" + full_key(k) + "'";
    if (!best.empty() && bd <= std::max<std::size_t>(2, k.size() / 3)) msg += " (did you mean '" + full_key(best) + "'?)";
    std::vector<std::string> known(used_->begin(), used_->end());
    msg += "; known keys here: " + join(known);
    throw ConfigError(msg);
  }
}

}  // namespace lbdem
