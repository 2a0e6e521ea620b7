#include "core/json.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace lbdem::json {

namespace {
const char* kind_name(Value::Kind k) {
  switch (k) {
    case Value::Kind::Null: return "null";
    case Value::Kind::Bool: return "a boolean";
    case Value::Kind::Integer: return "an integer";
    case Value::Kind::Number: return "a number";
    case Value::Kind::String: return "a string";
    case Value::Kind::Array: return "an array";
    case Value::Kind::Object: return "an object";
  }
  return "?";
}
[[noreturn]] void wrong_kind(const char* want, Value::Kind have) {
  throw Error(std::string("json: expected ") + want + ", found " + kind_name(have));
}
}  // namespace

Value& Value::operator[](const std::string& key) {
  if (kind_ == Kind::Null) kind_ = Kind::Object;
  if (kind_ != Kind::Object) wrong_kind("an object", kind_);
  for (auto& [k, v] : members_)
    if (k == key) return v;
  members_.emplace_back(key, Value());
  return members_.back().second;
}

Value& Value::set(const std::string& key, Value v) {
  (*this)[key] = std::move(v);
  return *this;
}

Value& Value::push(Value v) {
  if (kind_ == Kind::Null) kind_ = Kind::Array;
  if (kind_ != Kind::Array) wrong_kind("an array", kind_);
  items_.push_back(std::move(v));
  return *this;
}

bool Value::has(const std::string& key) const {
  if (kind_ != Kind::Object) return false;
  for (const auto& m : members_)
    if (m.first == key) return true;
  return false;
}

const Value& Value::at(const std::string& key) const {
  if (kind_ != Kind::Object) wrong_kind("an object", kind_);
  for (const auto& [k, v] : members_)
    if (k == key) return v;
  throw Error("json: no key '" + key + "'");
}

const Value& Value::at(std::size_t i) const {
  if (kind_ != Kind::Array) wrong_kind("an array", kind_);
  if (i >= items_.size())
    throw Error("json: index " + std::to_string(i) + " past the end (" + std::to_string(items_.size()) + " elements)");
  return items_[i];
}

std::size_t Value::size() const {
  if (kind_ == Kind::Array) return items_.size();
  if (kind_ == Kind::Object) return members_.size();
  return 0;
}

const std::vector<std::pair<std::string, Value>>& Value::members() const {
  if (kind_ != Kind::Object) wrong_kind("an object", kind_);
  return members_;
}

bool Value::as_bool() const {
  if (kind_ != Kind::Bool) wrong_kind("a boolean", kind_);
  return b_;
}
double Value::as_number() const {
  if (kind_ == Kind::Integer) return static_cast<double>(i_);
  if (kind_ != Kind::Number) wrong_kind("a number", kind_);
  return d_;
}
std::int64_t Value::as_integer() const {
  if (kind_ != Kind::Integer) wrong_kind("an integer", kind_);
  return i_;
}
const std::string& Value::as_string() const {
  if (kind_ != Kind::String) wrong_kind("a string", kind_);
  return s_;
}

bool operator==(const Value& a, const Value& b) {
  using K = Value::Kind;
  const bool an = a.kind_ == K::Integer || a.kind_ == K::Number, bn = b.kind_ == K::Integer || b.kind_ == K::Number;
  if (an && bn) {
    if (a.kind_ == K::Integer && b.kind_ == K::Integer) return a.i_ == b.i_;
    return a.as_number() == b.as_number();
  }
  if (a.kind_ != b.kind_) return false;
  switch (a.kind_) {
    case K::Null: return true;
    case K::Bool: return a.b_ == b.b_;
    case K::String: return a.s_ == b.s_;
    case K::Array: return a.items_ == b.items_;
    case K::Object: return a.members_ == b.members_;
    default: return false;
  }
}

std::string number_text(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  // std::to_chars without a precision: the shortest text that reads back to v.
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    switch (ch) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      default:
        if (c < 0x20) {
          char u[8];
          std::snprintf(u, sizeof u, "\\u%04x", c);
          out += u;
        } else {
          out += ch;
        }
    }
  }
  return out + "\"";
}

void Value::write(std::string& out, int indent, int depth) const {
  // Below the top level everything goes on one line.
  if (depth > 0) indent = -1;
  auto newline = [&](int d) {
    if (indent < 0) return;
    out += '\n';
    out.append(static_cast<std::size_t>(indent * d), ' ');
  };
  switch (kind_) {
    case Kind::Null: out += "null"; return;
    case Kind::Bool: out += b_ ? "true" : "false"; return;
    case Kind::Integer: out += std::to_string(i_); return;
    case Kind::Number: out += number_text(d_); return;
    case Kind::String: out += quoted(s_); return;
    case Kind::Array: {
      bool flat = true;
      for (const auto& v : items_) flat = flat && v.kind_ != Kind::Array && v.kind_ != Kind::Object;
      out += '[';
      for (std::size_t i = 0; i < items_.size(); ++i) {
        if (i) out += flat || indent < 0 ? ", " : ",";
        if (!flat) newline(depth + 1);
        items_[i].write(out, indent, depth + 1);
      }
      if (!flat && !items_.empty()) newline(depth);
      out += ']';
      return;
    }
    case Kind::Object: {
      out += '{';
      for (std::size_t i = 0; i < members_.size(); ++i) {
        if (i) out += indent < 0 ? ", " : ",";
        newline(depth + 1);
        out += quoted(members_[i].first);
        out += ": ";
        members_[i].second.write(out, indent, depth + 1);
      }
      if (!members_.empty()) newline(depth);
      out += '}';
      return;
    }
  }
}

std::string Value::dump(int indent) const {
  std::string out;
  write(out, indent, 0);
  if (indent >= 0) out += '\n';
  return out;
}

namespace {
// Recursive-descent reader of RFC 8259 JSON.
struct Reader {
  const std::string& t;
  std::size_t p = 0;
  int depth = 0;

  [[noreturn]] void fail(const std::string& what) const {
    throw Error("json: " + what + " at offset " + std::to_string(p));
  }
  void ws() {
    while (p < t.size() && (t[p] == ' ' || t[p] == '\t' || t[p] == '\n' || t[p] == '\r')) ++p;
  }
  bool eat(char c) {
    ws();
    if (p < t.size() && t[p] == c) {
      ++p;
      return true;
    }
    return false;
  }
  void expect(char c) {
    if (!eat(c)) fail(std::string("expected '") + c + "'");
  }
  bool word(const char* w) {
    const std::string s(w);
    if (t.compare(p, s.size(), s) == 0) {
      p += s.size();
      return true;
    }
    return false;
  }
  static void utf8(std::string& out, unsigned cp) {
    if (cp < 0x80) {
      out += static_cast<char>(cp);
    } else if (cp < 0x800) {
      out += static_cast<char>(0xC0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
      out += static_cast<char>(0xE0 | (cp >> 12));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (cp >> 18));
      out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    }
  }
  unsigned hex4() {
    if (p + 4 > t.size()) fail("short \\u escape");
    unsigned v = 0;
    for (int k = 0; k < 4; ++k) {
      const char c = t[p++];
      v <<= 4;
      if (c >= '0' && c <= '9') v |= static_cast<unsigned>(c - '0');
      else if (c >= 'a' && c <= 'f') v |= static_cast<unsigned>(c - 'a' + 10);
      else if (c >= 'A' && c <= 'F') v |= static_cast<unsigned>(c - 'A' + 10);
      else fail("bad \\u escape");
    }
    return v;
  }
  std::string string() {
    expect('"');
    std::string out;
    while (true) {
      if (p >= t.size()) fail("unterminated string");
      const char c = t[p++];
      if (c == '"') return out;
      if (static_cast<unsigned char>(c) < 0x20) fail("control character in a string");
      if (c != '\\') {
        out += c;
        continue;
      }
      if (p >= t.size()) fail("unterminated escape");
      switch (t[p++]) {
        case '"': out += '"'; break;
        case '\\': out += '\\'; break;
        case '/': out += '/'; break;
        case 'b': out += '\b'; break;
        case 'f': out += '\f'; break;
        case 'n': out += '\n'; break;
        case 'r': out += '\r'; break;
        case 't': out += '\t'; break;
        case 'u': {
          unsigned cp = hex4();
          if (cp >= 0xD800 && cp < 0xDC00 && t.compare(p, 2, "\\u") == 0) {  // surrogate pair
            p += 2;
            const unsigned lo = hex4();
            if (lo < 0xDC00 || lo >= 0xE000) fail("bad surrogate pair");
            cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
          }
          utf8(out, cp);
          break;
        }
        default: fail("unknown escape");
      }
    }
  }
  Value number() {
    const std::size_t s = p;
    if (p < t.size() && t[p] == '-') ++p;
    bool integral = true;
    auto digits = [&] {
      const std::size_t d = p;
      while (p < t.size() && t[p] >= '0' && t[p] <= '9') ++p;
      if (p == d) fail("expected a digit");
    };
    digits();
    if (p < t.size() && t[p] == '.') {
      ++p;
      integral = false;
      digits();
    }
    if (p < t.size() && (t[p] == 'e' || t[p] == 'E')) {
      ++p;
      integral = false;
      if (p < t.size() && (t[p] == '+' || t[p] == '-')) ++p;
      digits();
    }
    const char* b = t.data() + s;
    const char* e = t.data() + p;
    if (integral) {
      std::int64_t i = 0;
      const auto r = std::from_chars(b, e, i);
      // "-0" is the double -0 (its sign is kept), not the integer 0.
      if (r.ec == std::errc() && r.ptr == e && !(i == 0 && *b == '-')) return Value(static_cast<long long>(i));
    }
    double d = 0;
    const auto r = std::from_chars(b, e, d);
    if (r.ptr != e) fail("bad number");
    return Value(d);
  }
  Value value() {
    ws();
    if (p >= t.size()) fail("unexpected end");
    if (++depth > 512) fail("nested too deeply");
    Value v;
    const char c = t[p];
    if (c == '{') {
      ++p;
      v = Value::object();
      if (!eat('}')) {
        do {
          ws();
          const std::string k = string();
          expect(':');
          v.set(k, value());
        } while (eat(','));
        expect('}');
      }
    } else if (c == '[') {
      ++p;
      v = Value::array();
      if (!eat(']')) {
        do v.push(value());
        while (eat(','));
        expect(']');
      }
    } else if (c == '"') {
      v = Value(string());
    } else if (word("true")) {
      v = Value(true);
    } else if (word("false")) {
      v = Value(false);
    } else if (word("null")) {
      v = Value();
    } else {
      v = number();
    }
    --depth;
    return v;
  }
};
}  // namespace

Value Value::parse(const std::string& text) {
  Reader r{text};
  Value v = r.value();
  r.ws();
  if (r.p != text.size()) r.fail("text after the value");
  return v;
}

}  // namespace lbdem::json
