// The 16-bit storage formats (core/half.hpp), checked over all 65536 codes:
// decode is exact and encode inverts it; every rounding boundary (the midpoint
// of two neighbouring codes and the floats either side of it) rounds as
// roundTiesToEven says; random floats round to the nearest code found by a
// brute-force search over the decoded table; overflow, infinities, NaN, signed
// zero and float subnormals behave as documented. The branch-free encode and
// decode give the same bits as the case-by-case encode_reference and
// decode_reference for every code and (long test) every float.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "core/half.hpp"

namespace lbdem {
namespace {

template <class F>
bool is_nan_code(std::uint16_t c) {
  return (c & 0x7fffu) > F::kInf;
}

// Positive finite codes 0 .. kInf - 1 decode to increasing values.
template <class F>
std::vector<double> positive_values() {
  std::vector<double> v;
  for (std::uint32_t c = 0; c < F::kInf; ++c) v.push_back(static_cast<double>(F::decode(static_cast<std::uint16_t>(c))));
  return v;
}

// Reference rounding by search: the nearest positive code to |x| (ties to the
// even code), infinity at or beyond the largest value plus half its spacing.
template <class F>
std::uint16_t reference_encode(float x, const std::vector<double>& pos) {
  const std::uint16_t sign = std::signbit(x) ? 0x8000 : 0;
  const double a = std::fabs(static_cast<double>(x));
  const double top = pos.back() + 0.5 * (pos.back() - pos[pos.size() - 2]);
  if (a >= top) return static_cast<std::uint16_t>(sign | F::kInf);
  const auto it = std::lower_bound(pos.begin(), pos.end(), a);
  std::size_t hi = static_cast<std::size_t>(it - pos.begin());
  if (hi == pos.size()) return static_cast<std::uint16_t>(sign | (pos.size() - 1));
  if (pos[hi] == a || hi == 0) return static_cast<std::uint16_t>(sign | hi);
  const std::size_t lo = hi - 1;
  const double dl = a - pos[lo], dh = pos[hi] - a;
  std::size_t best = dl < dh ? lo : (dh < dl ? hi : ((lo & 1) == 0 ? lo : hi));
  return static_cast<std::uint16_t>(sign | best);
}

template <class F>
void check_all_codes() {
  for (std::uint32_t c = 0; c < 65536; ++c) {
    const auto h = static_cast<std::uint16_t>(c);
    const float v = F::decode(h);
    if (is_nan_code<F>(h)) {
      ASSERT_TRUE(std::isnan(v)) << std::hex << c;
      ASSERT_TRUE(is_nan_code<F>(F::encode(v))) << std::hex << c;
      continue;
    }
    ASSERT_EQ(F::encode(v), h) << "code 0x" << std::hex << c << " decodes to " << v;
    ASSERT_EQ(std::signbit(v), (c & 0x8000u) != 0) << std::hex << c;
  }
}

template <class F>
void check_rounding_boundaries() {
  const auto pos = positive_values<F>();
  for (std::size_t c = 0; c + 1 < pos.size(); ++c) {
    ASSERT_LT(pos[c], pos[c + 1]) << c;
    // The midpoint needs one bit more than a code: exact in float.
    const float mid = static_cast<float>(0.5 * (pos[c] + pos[c + 1]));
    ASSERT_EQ(static_cast<double>(mid), 0.5 * (pos[c] + pos[c + 1]));
    const std::uint16_t even = static_cast<std::uint16_t>((c & 1) == 0 ? c : c + 1);
    for (float sgn : {1.0f, -1.0f}) {
      const std::uint16_t s = sgn < 0 ? 0x8000 : 0;
      const float m = sgn * mid;
      ASSERT_EQ(F::encode(m), s | even) << "tie between codes " << c << " and " << c + 1;
      ASSERT_EQ(F::encode(std::nextafter(m, 0.0f)), s | c) << "just below the midpoint of " << c;
      ASSERT_EQ(F::encode(std::nextafter(m, sgn * 1e30f)), s | (c + 1)) << "just above the midpoint of " << c;
    }
  }
  // Overflow: the largest finite value plus half its spacing is a tie that
  // goes to infinity; the float below it rounds to the largest finite value.
  const double top = pos.back() + 0.5 * (pos.back() - pos[pos.size() - 2]);
  const float t = static_cast<float>(top);
  ASSERT_EQ(static_cast<double>(t), top);
  EXPECT_EQ(F::encode(t), F::kInf);
  EXPECT_EQ(F::encode(-t), 0x8000 | F::kInf);
  EXPECT_EQ(F::encode(std::nextafter(t, 0.0f)), F::kInf - 1);
  EXPECT_EQ(F::encode(std::numeric_limits<float>::infinity()), F::kInf);
  EXPECT_EQ(F::encode(-std::numeric_limits<float>::infinity()), 0x8000 | F::kInf);
  EXPECT_EQ(F::encode(std::numeric_limits<float>::max()), F::kInf);
  EXPECT_TRUE(std::isinf(F::decode(F::kInf)));
  EXPECT_TRUE(is_nan_code<F>(F::encode(std::numeric_limits<float>::quiet_NaN())));
  EXPECT_TRUE(is_nan_code<F>(F::encode(-std::numeric_limits<float>::quiet_NaN())));
  // Zeros and float subnormals: sign kept, magnitude zero.
  EXPECT_EQ(F::encode(0.0f), 0);
  EXPECT_EQ(F::encode(-0.0f), 0x8000);
  EXPECT_EQ(F::encode(std::numeric_limits<float>::denorm_min()), 0);
  EXPECT_EQ(F::encode(-std::numeric_limits<float>::min()), 0x8000);
  // Half the smallest subnormal is a tie to zero (even); just above rounds up.
  const float half_sub = static_cast<float>(0.5 * pos[1]);
  EXPECT_EQ(F::encode(half_sub), 0);
  EXPECT_EQ(F::encode(std::nextafter(half_sub, 1.0f)), 1);
}

template <class F>
void check_random_against_search() {
  const auto pos = positive_values<F>();
  std::mt19937 gen(19);
  // Exponents from well below the smallest subnormal to beyond the largest value.
  std::uniform_int_distribution<int> ex(F::kEmin - F::kManBits - 4, F::kEmax + 3);
  std::uniform_real_distribution<float> mant(1.0f, 2.0f);
  for (int i = 0; i < 400000; ++i) {
    float x = std::ldexp(mant(gen), ex(gen));
    if (i & 1) x = -x;
    ASSERT_EQ(F::encode(x), reference_encode<F>(x, pos)) << "x = " << x;
  }
}

TEST(Half, Binary16AllCodesRoundTrip) { check_all_codes<Binary16Format>(); }
TEST(Half, Fp16cAllCodesRoundTrip) { check_all_codes<Fp16cFormat>(); }
TEST(Half, Binary16RoundingBoundaries) { check_rounding_boundaries<Binary16Format>(); }
TEST(Half, Fp16cRoundingBoundaries) { check_rounding_boundaries<Fp16cFormat>(); }
TEST(Half, Binary16RandomAgainstSearch) { check_random_against_search<Binary16Format>(); }
TEST(Half, Fp16cRandomAgainstSearch) { check_random_against_search<Fp16cFormat>(); }

std::uint32_t bits_of(float x) { return half_detail::float_bits(x); }

// Every code decodes to the same float bits (NaN payloads and -0 included)
// by each branch-free decode as by the reference, and encoding it back gives
// the reference's code.
template <class F>
void check_codes_against_reference() {
  for (std::uint32_t c = 0; c < 65536; ++c) {
    const auto h = static_cast<std::uint16_t>(c);
    const float r = F::decode_reference(h);
    ASSERT_EQ(bits_of(F::decode(h)), bits_of(r)) << "code 0x" << std::hex << c;
    ASSERT_EQ(bits_of(F::decode_scaled(h)), bits_of(r)) << "code 0x" << std::hex << c;
    ASSERT_EQ(bits_of(F::decode_significand(h)), bits_of(r)) << "code 0x" << std::hex << c;
    ASSERT_EQ(F::encode(F::decode(h)), F::encode_reference(r)) << "code 0x" << std::hex << c;
  }
}

// encode against encode_reference on the float bit patterns first, first +
// stride, ... below 2^32, in parallel; returns the number that differ and
// sets `example` to the largest pattern that differs (for the message).
template <class F>
std::uint64_t count_encode_mismatches(std::uint64_t first, std::uint64_t stride, std::uint32_t& example) {
  const std::int64_t n = static_cast<std::int64_t>(((std::uint64_t{1} << 32) - first + stride - 1) / stride);
  std::uint64_t bad = 0;
  std::uint32_t ex = 0;
#pragma omp parallel for schedule(static) reduction(+ : bad) reduction(max : ex)
  for (std::int64_t i = 0; i < n; ++i) {
    const auto u = static_cast<std::uint32_t>(first + static_cast<std::uint64_t>(i) * stride);
    const float x = half_detail::bits_float(u);
    if (F::encode(x) != F::encode_reference(x)) {
      ++bad;
      ex = std::max(ex, u);
    }
  }
  example = ex;
  return bad;
}

// Every bit pattern in the format's range of exponents (from below half the
// smallest subnormal to beyond the overflow threshold), both signs, is
// encoded as the reference does; so are 2^32 / 4099 patterns spread over
// the rest (all exponents, all low mantissa bits).
template <class F>
void check_encode_against_reference_quick() {
  std::uint32_t example = 0;
  EXPECT_EQ(count_encode_mismatches<F>(0, 4099, example), 0u) << "e.g. float bits 0x" << std::hex << example;
  // Every float with an exponent where the rounding changes its kind: below
  // half the smallest subnormal, the binade holding that tie, one in the
  // middle of the subnormal codes, the last subnormal and first normal
  // binades, and the largest finite binade and the one above (overflow);
  // every mantissa, both signs.
  for (int e : {F::kEmin - F::kManBits - 2, F::kEmin - F::kManBits - 1, F::kEmin - F::kManBits / 2, F::kEmin - 1,
                F::kEmin, F::kEmax, F::kEmax + 1}) {
    for (std::uint32_t sign : {0u, 0x80000000u}) {
      const std::uint32_t base = sign | (static_cast<std::uint32_t>(e + 127) << 23);
      std::uint64_t bad = 0;
      std::uint32_t example = 0;
#pragma omp parallel for schedule(static) reduction(+ : bad) reduction(max : example)
      for (std::int64_t m = 0; m < (std::int64_t{1} << 23); ++m) {
        const std::uint32_t u = base | static_cast<std::uint32_t>(m);
        const float x = half_detail::bits_float(u);
        if (F::encode(x) != F::encode_reference(x)) {
          ++bad;
          example = std::max(example, u);
        }
      }
      EXPECT_EQ(bad, 0u) << "exponent " << e << ", e.g. float bits 0x" << std::hex << example;
    }
  }
}

TEST(Half, Binary16CodesMatchReference) { check_codes_against_reference<Binary16Format>(); }
TEST(Half, Fp16cCodesMatchReference) { check_codes_against_reference<Fp16cFormat>(); }
TEST(Half, Binary16EncodeMatchesReferenceSampled) { check_encode_against_reference_quick<Binary16Format>(); }
TEST(Half, Fp16cEncodeMatchesReferenceSampled) { check_encode_against_reference_quick<Fp16cFormat>(); }

// All 2^32 float bit patterns (long: several seconds of CPU per format).
TEST(HalfExhaustive, Fp16cEncodeMatchesReferenceAllFloats) {
  std::uint32_t example = 0;
  EXPECT_EQ(count_encode_mismatches<Fp16cFormat>(0, 1, example), 0u) << "e.g. float bits 0x" << std::hex << example;
}
TEST(HalfExhaustive, Binary16EncodeMatchesReferenceAllFloats) {
  std::uint32_t example = 0;
  EXPECT_EQ(count_encode_mismatches<Binary16Format>(0, 1, example), 0u) << "e.g. float bits 0x" << std::hex << example;
}

// The layouts: known codes of IEEE binary16 and the ranges of the 1-4-11 format.
TEST(Half, KnownCodes) {
  EXPECT_EQ(Binary16Format::encode(1.0f), 0x3c00);
  EXPECT_EQ(Binary16Format::encode(-2.0f), 0xc000);
  EXPECT_EQ(Binary16Format::encode(65504.0f), 0x7bff);
  EXPECT_EQ(Binary16Format::encode(std::ldexp(1.0f, -24)), 0x0001);
  EXPECT_EQ(Binary16Format::encode(std::ldexp(1.0f, -14)), 0x0400);
  EXPECT_EQ(Binary16Format::encode(1.0f / 3.0f), 0x3555);
  EXPECT_EQ(Fp16cFormat::encode(0.5f), 14 << 11);
  EXPECT_EQ(Fp16cFormat::decode(0x77ff), 0.5f * (2.0f - std::ldexp(1.0f, -11)));
  EXPECT_EQ(Fp16cFormat::decode(0x0001), std::ldexp(1.0f, -25));
  EXPECT_EQ(Fp16cFormat::decode(0x0800), std::ldexp(1.0f, -14));
  EXPECT_EQ(Fp16cFormat::encode(1.0f), Fp16cFormat::kInf);  // beyond the largest finite value
  // Unit roundoff: the spacing just above 1/4 is 2^-2 2^-M.
  EXPECT_EQ(Binary16Format::decode(Binary16Format::encode(0.25f) + 1) - 0.25f, std::ldexp(1.0f, -12));
  EXPECT_EQ(Fp16cFormat::decode(Fp16cFormat::encode(0.25f) + 1) - 0.25f, std::ldexp(1.0f, -13));
}

// The storage types convert as their formats (Fp16s may use F16C on the host).
TEST(Half, StorageTypesMatchFormats) {
  for (std::uint32_t c = 0; c < 65536; ++c) {
    const auto h = static_cast<std::uint16_t>(c);
    if (is_nan_code<Binary16Format>(h)) continue;
    const float v = Binary16Format::decode(h);
    ASSERT_EQ(static_cast<float>(Fp16s{v}), v);
    ASSERT_EQ(Fp16s{v}.bits, h);
    ASSERT_EQ(Fp16s{static_cast<double>(v)}.bits, h);
    ASSERT_EQ(static_cast<double>(Fp16s{v}), static_cast<double>(v));
    if (is_nan_code<Fp16cFormat>(h)) continue;
    const float w = Fp16cFormat::decode(h);
    ASSERT_EQ(Fp16c{w}.bits, h);
    ASSERT_EQ(static_cast<float>(Fp16c{w}), w);
  }
  std::mt19937 gen(7);
  std::uniform_real_distribution<float> d(-1.0f, 1.0f);
  for (int i = 0; i < 100000; ++i) {
    const float x = d(gen) * std::ldexp(1.0f, -(i % 20));
    ASSERT_EQ(Fp16s{x}.bits, Binary16Format::encode(x)) << x;
  }
}

}  // namespace
}  // namespace lbdem
