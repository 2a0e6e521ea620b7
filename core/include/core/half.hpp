#pragma once
// 16-bit floating-point storage formats and their conversions to and from
// float, for population storage (lbm/storage.hpp): values are stored in 16
// bits and every arithmetic operation happens in float.
//
// A format is 1 sign bit, E exponent bits and M = 15 - E mantissa bits with
// exponent bias `Bias`, laid out like IEEE 754 binary16:
//   exponent field 0               subnormal: (-1)^s  m / 2^M  2^(1 - Bias)
//   exponent field 1 .. 2^E - 2    normal:    (-1)^s (1 + m / 2^M) 2^(e - Bias)
//   exponent field 2^E - 1         m = 0: +-infinity, m != 0: NaN
// float -> 16 bits rounds to nearest, ties to even (IEEE 754 roundTiesToEven);
// finite values at or beyond the largest finite value plus half its spacing
// become +-infinity; a NaN becomes a NaN (payload unspecified); -0 stays -0.
// 16 bits -> float is exact (every code is a float).
//
// Two formats:
//  * Fp16s: IEEE binary16 (E = 5, M = 10, bias 15): largest finite 65504,
//    smallest normal 2^-14, unit roundoff 2^-11.
//  * Fp16c: E = 4, M = 11, bias 15: largest finite 2^-1 (2 - 2^-11) (just
//    below 1), smallest normal 2^-14 (as binary16), subnormal spacing 2^-25,
//    unit roundoff 2^-12. Populations stored shifted (f - w, lbm/collision.hpp)
//    lie in (-1/3, 1) for any physical state, so the exponents binary16
//    spends on values above 1 buy nothing there; Fp16c spends that bit on
//    the mantissa instead and halves the rounding error everywhere below 1.
//    A fixed per-direction scale would not help further: in the normal range
//    the relative rounding error does not depend on the magnitude.
//
// On the device Fp16s converts with the CUDA half intrinsics, on the host with
// F16C instructions where the compiler targets them, else in software; all
// three round alike (ties to even), so both backends store the same bits.
// Fp16c has no hardware conversion: Float16Format converts without branches,
// with a few integer operations on the float's bits around one float
// operation (encode: an addition that does the rounding; decode: a
// multiplication that rebiases the exponent), so a warp never diverges on a
// conversion and host loops over cells can be vectorised. Its
// encode_reference()/decode_reference() are the same conversions written case
// by case; the tests hold the two to the same bits for every code and every
// float.
#include <cstdint>
#include <cstring>

#include "core/hd.hpp"

#if defined(__CUDACC__)
#include <cuda_fp16.h>
#endif
#if defined(__F16C__) && !defined(__CUDA_ARCH__)
#include <immintrin.h>
#endif

namespace lbdem {

namespace half_detail {

LBDEM_HD LBDEM_FORCEINLINE std::uint32_t float_bits(float x) {
#if defined(__CUDA_ARCH__)
  return __float_as_uint(x);
#else
  std::uint32_t u;
  std::memcpy(&u, &x, sizeof u);
  return u;
#endif
}

LBDEM_HD LBDEM_FORCEINLINE float bits_float(std::uint32_t u) {
#if defined(__CUDA_ARCH__)
  return __uint_as_float(u);
#else
  float x;
  std::memcpy(&x, &u, sizeof x);
  return x;
#endif
}

}  // namespace half_detail

// Conversions of the 16-bit format with E exponent bits and exponent bias Bias
// (layout and rounding in the header comment).
template <int E, int Bias>
struct Float16Format {
  static constexpr int kExpBits = E;
  static constexpr int kManBits = 15 - E;
  static constexpr int kBias = Bias;
  static constexpr int kEmax = (1 << E) - 2 - Bias;  // exponent of the largest finite value
  static constexpr int kEmin = 1 - Bias;             // exponent of the smallest normal value
  static constexpr std::uint32_t kExpField = (1u << E) - 1;
  static constexpr std::uint16_t kInf = static_cast<std::uint16_t>(kExpField << kManBits);
  static constexpr std::uint16_t kNaN = static_cast<std::uint16_t>(kInf | (1u << (kManBits - 1)));
  static_assert(E >= 2 && E <= 8 && kManBits >= 7 && kManBits <= 13, "a 16-bit format a float holds exactly");
  static_assert(kEmin >= -126 + 1 && kEmax <= 127, "normal values of the format are normal floats");
  static_assert(kEmin - kManBits >= -126 && kEmax + 1 + (23 - kManBits) <= 127,
                "the powers of two encode() and decode_significand() build are normal floats");

  // float -> code, round to nearest, ties to even, without branches, in one
  // float addition and a few integer operations. Let e be the exponent of
  // |x| clamped to [Emin, Emax + 1] and c = 2^(e + 23 - M). The float sum
  // |x| + c has the ulp 2^(e - M), which is the code spacing at |x| (the
  // subnormal spacing 2^(Emin - M) below 2^Emin), so the addition rounds |x|
  // to a code value, ties to even, in one step; a carry to the next binade
  // comes out right. bits(|x| + c) - bits(c) is then that value in units of
  // the spacing, 2^M + mantissa for a normal code and the code itself for a
  // subnormal one, and adding (e + Bias - 1) 2^M (read off c's exponent
  // bits) gives the code. Below 2^Emin the clamp makes that offset 0; a float
  // subnormal |x| (flushed to zero or not) gives code 0. At or above the
  // largest finite value plus half its spacing the result is kInf or more
  // (it grows with |x|), so min() clamps to infinity; a NaN input sets the
  // top mantissa bit on that. The float sum is used on every path, so a
  // compiler has no reason to branch around it (GCC keeps a trapping float
  // operation out of a vectorised loop when it sits on one side of a branch).
  // (Scaling |x| by 2^(Bias - 127) and rounding the bits would round values
  // below 2^Emin twice, first to the float subnormal spacing 2^-149: wrong
  // within 2^-150 of a tie between two subnormal codes.)
  LBDEM_HD static LBDEM_FORCEINLINE std::uint16_t encode(float x) {
    constexpr int M = kManBits;
    constexpr int kShift = 23 - M;
    const std::uint32_t u = half_detail::float_bits(x);
    const std::uint32_t a = u & 0x7fffffffu;
    // c's exponent field, e + kShift + 127, clamped as above.
    constexpr std::uint32_t kLo = static_cast<std::uint32_t>(kEmin + kShift + 127) << 23;
    constexpr std::uint32_t kHi = static_cast<std::uint32_t>(kEmax + 1 + kShift + 127) << 23;
    std::uint32_t c = (u & 0x7f800000u) + (static_cast<std::uint32_t>(kShift) << 23);
    c = c > kLo ? c : kLo;
    c = c < kHi ? c : kHi;
    const float r = half_detail::bits_float(a) + half_detail::bits_float(c);
    // (c >> kShift) - kBase = (e + Bias - 1) 2^M.
    constexpr std::uint32_t kBase = static_cast<std::uint32_t>(kShift + 128 - Bias) << M;
    std::uint32_t code = half_detail::float_bits(r) - c + ((c >> kShift) - kBase);
    code = code < kInf ? code : static_cast<std::uint32_t>(kInf);
    code |= a > 0x7f800000u ? (1u << (M - 1)) : 0u;  // kInf | this bit = kNaN
    return static_cast<std::uint16_t>(code | ((u >> 16) & 0x8000u));
  }

  // code -> float, exact, without branches. The 15 magnitude bits shifted
  // left by 23 - M put the code's exponent field in the low bits of the
  // float's exponent field and its mantissa at the top of the float's
  // mantissa: read as a float that is the value times 2^(Bias - 127), for
  // subnormal codes too (exponent field 0 reads as a float subnormal with the
  // same mantissa). Multiplying by 2^(127 - Bias) rebiases exactly. The
  // exponent field 2^E - 1 (infinity, NaN) is set to the float's 255 by a
  // select instead.
  //
  // That multiplication needs subnormal float operands kept, not flushed to
  // zero. The device uses it: lbdem's CUDA flags have neither -ftz=true nor
  // --use_fast_math (both flush), and tests/core/test_half_device.cu checks
  // every code on the GPU against the reference. The host converts with
  // decode_significand instead, which meets no subnormal float: an x86 core
  // may take a slow microcode path for a subnormal multiplication operand,
  // and a program built with -ffast-math reads subnormal operands as zero.
  // Both give the same bits (tests/core/test_half.cpp).
  LBDEM_HD static LBDEM_FORCEINLINE float decode(std::uint16_t h) {
#if defined(__CUDA_ARCH__)
    return decode_scaled(h);
#else
    return decode_significand(h);
#endif
  }

  // decode() by the rebiasing multiplication, for every code.
  LBDEM_HD static LBDEM_FORCEINLINE float decode_scaled(std::uint16_t h) {
    constexpr int kShift = 23 - kManBits;
    const std::uint32_t mag = h & 0x7fffu;
    const std::uint32_t b = (static_cast<std::uint32_t>(h & 0x8000u) << 16) | (mag << kShift);
    const float v = half_detail::bits_float(b) * half_detail::bits_float(static_cast<std::uint32_t>(127 - Bias + 127) << 23);
    return mag >= kInf ? half_detail::bits_float(b | 0x7f800000u) : v;
  }

  // decode() without subnormal floats anywhere: the significand as an
  // integer (2^M + mantissa for a normal code, the mantissa for a subnormal
  // one; below 2^24, so converted to float exactly) times 2^(e - Bias - M)
  // with e the exponent field raised to 1 for subnormal codes, a normal
  // float built from bits; the product is exact and normal or zero. The
  // exponent field 2^E - 1 (infinity, NaN) is set to 255 afterwards. Only
  // min/max and selects of integers, so GCC vectorises a loop of these.
  LBDEM_HD static LBDEM_FORCEINLINE float decode_significand(std::uint16_t h) {
    constexpr int M = kManBits;
    const std::uint32_t mag = h & 0x7fffu;
    const std::uint32_t e = mag >> M;
    const std::uint32_t sig = (mag & ((1u << M) - 1u)) | ((e < 1u ? e : 1u) << M);
    const std::uint32_t e1 = e > 1u ? e : 1u;
    const float scale = half_detail::bits_float((e1 + static_cast<std::uint32_t>(127 - Bias - M)) << 23);
    const float v = static_cast<float>(static_cast<std::int32_t>(sig)) * scale;
    const std::uint32_t b = half_detail::float_bits(v) | (mag >= kInf ? 0x7f800000u : 0u);
    return half_detail::bits_float(b | (static_cast<std::uint32_t>(h & 0x8000u) << 16));
  }

  // The conversions written case by case with early returns: the definition
  // encode() and decode() are tested against, bit for bit, over every float
  // and every code (tests/core/test_half.cpp).
  LBDEM_HD static std::uint16_t encode_reference(float x) {
    constexpr int M = kManBits;
    const std::uint32_t u = half_detail::float_bits(x);
    const std::uint32_t sign = (u >> 16) & 0x8000u;
    const std::uint32_t a = u & 0x7fffffffu;
    if (a > 0x7f800000u) return static_cast<std::uint16_t>(sign | kNaN);
    // The largest finite value plus half its spacing, 2^Emax (2 - 2^-(M+1)):
    // a tie there rounds to the even neighbour, which is infinity (the largest
    // finite value has an odd mantissa).
    constexpr std::uint32_t kOverflow =
        (static_cast<std::uint32_t>(kEmax + 127) << 23) | (((1u << (M + 1)) - 1u) << (22 - M));
    if (a >= kOverflow) return static_cast<std::uint16_t>(sign | kInf);
    constexpr std::uint32_t kMinNormal = static_cast<std::uint32_t>(kEmin + 127) << 23;
    if (a >= kMinNormal) {
      // Normal result: drop 23 - M mantissa bits rounding to nearest-even (a
      // carry out of the mantissa moves into the exponent), then rebias.
      constexpr int kShift = 23 - M;
      const std::uint32_t r = a + ((1u << (kShift - 1)) - 1u) + ((a >> kShift) & 1u);
      return static_cast<std::uint16_t>(sign | ((r >> kShift) - (static_cast<std::uint32_t>(127 - Bias) << M)));
    }
    // Subnormal result or zero: the value in units of the subnormal spacing
    // 2^(Emin - M), rounded to an integer (2^M, the carry, is the smallest normal code).
    const std::uint32_t e = a >> 23;
    if (e == 0) return static_cast<std::uint16_t>(sign);  // float zero or subnormal: below 2^-126
    const std::uint32_t mant = (a & 0x7fffffu) | 0x800000u;  // value = mant 2^(e - 150)
    const std::uint32_t shift = static_cast<std::uint32_t>(150 + kEmin - M) - e;
    if (shift > 24) return static_cast<std::uint16_t>(sign);  // below half the smallest subnormal
    const std::uint32_t q = mant >> shift, rem = mant & ((1u << shift) - 1u), half = 1u << (shift - 1);
    const std::uint32_t up = (rem > half || (rem == half && (q & 1u))) ? 1u : 0u;
    return static_cast<std::uint16_t>(sign | (q + up));
  }

  LBDEM_HD static float decode_reference(std::uint16_t h) {
    constexpr int M = kManBits;
    const std::uint32_t sign = static_cast<std::uint32_t>(h & 0x8000u) << 16;
    const std::uint32_t e = (h >> M) & kExpField;
    const std::uint32_t m = h & ((1u << M) - 1u);
    if (e == kExpField) return half_detail::bits_float(sign | 0x7f800000u | (m << (23 - M)));
    if (e == 0) {
      // m 2^(Emin - M): an integer below 2^M times a power of two, exact in float.
      const float v = static_cast<float>(m) * half_detail::bits_float(static_cast<std::uint32_t>(kEmin - M + 127) << 23);
      return half_detail::bits_float(sign | half_detail::float_bits(v));
    }
    return half_detail::bits_float(sign | ((e + static_cast<std::uint32_t>(127 - Bias)) << 23) | (m << (23 - M)));
  }

};

using Binary16Format = Float16Format<5, 15>;  // IEEE 754 binary16
using Fp16cFormat = Float16Format<4, 15>;     // 1-4-11, values below 1

// IEEE half storage. Trivially copyable, all-zero bits are +0; conversions are
// explicit so that each one is visible in a kernel (static_cast).
struct Fp16s {
  using Format = Binary16Format;
  std::uint16_t bits;
  Fp16s() = default;
  LBDEM_HD LBDEM_FORCEINLINE explicit Fp16s(float x) : bits(encode(x)) {}
  // Through float: a double lands on a 16-bit tie only after rounding to float
  // in cases far below the 16-bit spacing (set-up values only).
  LBDEM_HD LBDEM_FORCEINLINE explicit Fp16s(double x) : bits(encode(static_cast<float>(x))) {}
  LBDEM_HD LBDEM_FORCEINLINE explicit operator float() const { return decode(bits); }
  LBDEM_HD LBDEM_FORCEINLINE explicit operator double() const { return static_cast<double>(decode(bits)); }

  LBDEM_HD static LBDEM_FORCEINLINE std::uint16_t encode(float x) {
#if defined(__CUDA_ARCH__)
    return __half_as_ushort(__float2half_rn(x));
#elif defined(__F16C__)
    return static_cast<std::uint16_t>(_cvtss_sh(x, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC));
#else
    return Format::encode(x);
#endif
  }
  LBDEM_HD static LBDEM_FORCEINLINE float decode(std::uint16_t h) {
#if defined(__CUDA_ARCH__)
    return __half2float(__ushort_as_half(h));
#elif defined(__F16C__)
    return _cvtsh_ss(h);
#else
    return Format::decode(h);
#endif
  }
};

// The 1-4-11 format (header comment), same interface as Fp16s.
struct Fp16c {
  using Format = Fp16cFormat;
  std::uint16_t bits;
  Fp16c() = default;
  LBDEM_HD LBDEM_FORCEINLINE explicit Fp16c(float x) : bits(Format::encode(x)) {}
  LBDEM_HD LBDEM_FORCEINLINE explicit Fp16c(double x) : bits(Format::encode(static_cast<float>(x))) {}
  LBDEM_HD LBDEM_FORCEINLINE explicit operator float() const { return Format::decode(bits); }
  LBDEM_HD LBDEM_FORCEINLINE explicit operator double() const { return static_cast<double>(Format::decode(bits)); }
  LBDEM_HD static LBDEM_FORCEINLINE std::uint16_t encode(float x) { return Format::encode(x); }
  LBDEM_HD static LBDEM_FORCEINLINE float decode(std::uint16_t h) { return Format::decode(h); }
};

static_assert(sizeof(Fp16s) == 2 && sizeof(Fp16c) == 2, "16-bit storage");

}  // namespace lbdem
