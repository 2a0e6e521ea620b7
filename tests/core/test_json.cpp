// The JSON value and writer (core/json.hpp): every double reads back to the
// same bits, strings survive escaping, nesting and key order are kept, and
// bad text is refused with its offset.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "core/json.hpp"

using lbdem::json::Value;

namespace {
std::uint64_t bits(double d) {
  std::uint64_t b;
  std::memcpy(&b, &d, sizeof b);
  return b;
}
}  // namespace

TEST(Json, NumbersRoundTripBitwise) {
  // Random bit patterns over the whole finite range, plus the edges.
  std::mt19937_64 rng(42);
  std::vector<double> xs{0.0, -0.0, 0.1, 1.0 / 3.0, 1e-300, 5e-324, std::numeric_limits<double>::max(),
                         std::numeric_limits<double>::min(), 2.5e-5, 123456789.0, -7.0};
  for (int k = 0; k < 20000; ++k) {
    const std::uint64_t b = rng();
    double d;
    std::memcpy(&d, &b, sizeof d);
    if (std::isfinite(d)) xs.push_back(d);
  }
  for (double x : xs) {
    const Value back = Value::parse(Value(x).dump());
    EXPECT_EQ(bits(back.as_number()), bits(x)) << lbdem::json::number_text(x);
  }
}

TEST(Json, IntegersExactAndNonFiniteIsNull) {
  const long long big = 9007199254740993LL;  // 2^53 + 1: not a double
  EXPECT_EQ(Value::parse(Value(big).dump()).as_integer(), big);
  EXPECT_EQ(Value(std::numeric_limits<std::size_t>::max()).kind(), Value::Kind::Number);
  EXPECT_EQ(Value(NAN).dump(-1), "null");
  EXPECT_EQ(Value(-INFINITY).dump(-1), "null");
  EXPECT_EQ(Value(3.0).dump(-1), "3");
  EXPECT_EQ(Value(1e-5).dump(-1), "1e-05");
}

TEST(Json, StringsEscapedAndRead) {
  const std::string s = std::string("quote \" backslash \\ tab \t newline \n bell \x07 nul ") + '\0' + " é";
  const std::string text = Value(s).dump(-1);
  EXPECT_EQ(text.find('\n'), std::string::npos);
  EXPECT_NE(text.find("\\u0007"), std::string::npos);
  EXPECT_EQ(Value::parse(text).as_string(), s);
  EXPECT_EQ(Value::parse(R"("\u00e9\ud83d\ude00\/")").as_string(), "é\xF0\x9F\x98\x80/");
}

TEST(Json, NestingAndOrderRoundTrip) {
  Value v = Value::object();
  v.set("scene", "taylor_green").set("steps", 200).set("interrupted", false);
  v["phases_s"].set("lbm", 1.25).set("output", 0.5);
  v["verification"]["error"] = 1.5e-7;
  v["profile"] = Value::array_of(std::vector<double>{1, 2.5, -3});
  Value list = Value::array();
  list.push(Value::object().set("a", 1)).push(Value()).push(Value::array());
  v.set("list", list);
  v.set("steps", 300);  // replaced in place
  const std::string text = v.dump();
  const Value back = Value::parse(text);
  EXPECT_EQ(back, v);
  ASSERT_EQ(back.members().size(), 7u);
  EXPECT_EQ(back.members()[0].first, "scene");
  EXPECT_EQ(back.members()[1].first, "steps");
  EXPECT_EQ(back.at("steps").as_integer(), 300);
  EXPECT_EQ(back.at("list").at(0).at("a").as_integer(), 1);
  // The form scripts and tests search for: "key": value.
  EXPECT_NE(text.find("\"steps\": 300"), std::string::npos) << text;
  EXPECT_NE(text.find("\"interrupted\": false"), std::string::npos) << text;
  EXPECT_NE(text.find("\"profile\": [1, 2.5, -3]"), std::string::npos) << text;
  // A top-level member a line; what lies below it on that line.
  EXPECT_NE(text.find("\n  \"phases_s\": {\"lbm\": 1.25, \"output\": 0.5},\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\"list\": [{\"a\": 1}, null, []]"), std::string::npos) << text;
  EXPECT_EQ(Value::parse(v.dump(-1)), v);
}

TEST(Json, BadTextRefusedWithOffset) {
  for (const char* bad : {"{", "[1,]", "{\"a\" 1}", "tru", "\"abc", "1 2", "{\"a\":01x}", "-", "\"\\q\""}) {
    try {
      Value::parse(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const lbdem::Error& e) {
      EXPECT_NE(std::string(e.what()).find("offset"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(Value(1).at("x"), lbdem::Error);
  EXPECT_THROW(Value::object().at("x"), lbdem::Error);
}
