#pragma once
// A small JSON value: null, booleans, integers (exact 64-bit), numbers
// (doubles written in their shortest form that reads back to the same bits),
// strings (escaped on output, UTF-8 passed through), arrays and objects that
// keep their keys in insertion order (a summary reads in the order a scene
// wrote it). dump() writes it, parse() reads it back (for tests and for a
// tool that reads a summary). No external library: the machines we run on
// may have none.
//
// JSON has no NaN or infinity: a non-finite number is written as null.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/error.hpp"

namespace lbdem::json {

class Value {
 public:
  enum class Kind { Null, Bool, Integer, Number, String, Array, Object };

  Value() = default;
  Value(std::nullptr_t) {}
  Value(bool b) : kind_(Kind::Bool), b_(b) {}
  Value(int v) : kind_(Kind::Integer), i_(v) {}
  Value(long v) : kind_(Kind::Integer), i_(v) {}
  Value(long long v) : kind_(Kind::Integer), i_(v) {}
  Value(unsigned v) : kind_(Kind::Integer), i_(v) {}
  // Above 2^63 - 1 an unsigned value is kept as a number (a double).
  Value(unsigned long v) { set_unsigned(v); }
  Value(unsigned long long v) { set_unsigned(v); }
  Value(double v) : kind_(Kind::Number), d_(v) {}
  Value(float v) : kind_(Kind::Number), d_(v) {}
  Value(const char* s) : kind_(Kind::String), s_(s) {}
  Value(std::string s) : kind_(Kind::String), s_(std::move(s)) {}

  static Value array() {
    Value v;
    v.kind_ = Kind::Array;
    return v;
  }
  static Value object() {
    Value v;
    v.kind_ = Kind::Object;
    return v;
  }
  // An array of numbers (a profile, a vector).
  template <class T>
  static Value array_of(const std::vector<T>& xs) {
    Value v = array();
    for (const auto& x : xs) v.push(Value(x));
    return v;
  }

  Kind kind() const { return kind_; }
  bool is_null() const { return kind_ == Kind::Null; }
  bool is_object() const { return kind_ == Kind::Object; }
  bool is_array() const { return kind_ == Kind::Array; }

  // Object: the value of `key`, inserted as null at the end when absent (a
  // null value becomes an empty object first). Error on other kinds.
  Value& operator[](const std::string& key);
  // Object: sets `key` (replacing its value, keeping its place); returns *this
  // so that calls chain.
  Value& set(const std::string& key, Value v);
  // Array: appends (a null value becomes an empty array first).
  Value& push(Value v);

  // Reading (Error naming the key or index when absent or of another kind).
  bool has(const std::string& key) const;
  const Value& at(const std::string& key) const;
  const Value& at(std::size_t i) const;
  std::size_t size() const;  // elements of an array, members of an object
  const std::vector<std::pair<std::string, Value>>& members() const;
  bool as_bool() const;
  double as_number() const;       // integers too
  std::int64_t as_integer() const;  // integers only
  const std::string& as_string() const;

  // Text: each member of the top-level object (or element of the top-level
  // array) on its own line, indented by `indent` spaces; the values below it
  // each on one line (a summary reads one key a line). indent < 0: all on
  // one line.
  std::string dump(int indent = 2) const;
  // Reads one JSON document (whitespace around it allowed); Error with the
  // offset of the first character it cannot read.
  static Value parse(const std::string& text);

  friend bool operator==(const Value& a, const Value& b);

 private:
  template <class U>
  void set_unsigned(U v) {
    if (v <= static_cast<U>(INT64_MAX)) {
      kind_ = Kind::Integer;
      i_ = static_cast<std::int64_t>(v);
    } else {
      kind_ = Kind::Number;
      d_ = static_cast<double>(v);
    }
  }
  void write(std::string& out, int indent, int depth) const;

  Kind kind_ = Kind::Null;
  bool b_ = false;
  std::int64_t i_ = 0;
  double d_ = 0;
  std::string s_;
  std::vector<Value> items_;
  std::vector<std::pair<std::string, Value>> members_;
};

// The shortest text of `v` that reads back to the same double ("1e-05",
// "0.1", "3"); non-finite values give "null".
std::string number_text(double v);
// `s` as a JSON string literal (quotes, escapes of ", \ and control characters).
std::string quoted(const std::string& s);

}  // namespace lbdem::json
