// The 16-bit conversions (core/half.hpp) on the CUDA backend: every code
// decodes on the GPU to the same float bits as decode_reference on the host,
// encoding it back gives the host's code, and every one of the 2^32 float bit
// patterns encodes on the GPU as encode_reference does. The device decode
// multiplies float subnormals (Float16Format::decode), so this also fails if
// the CUDA flags ever flush subnormals to zero (-ftz=true, --use_fast_math).
// Skipped where no GPU is usable; the host conversions are checked in
// test_half.cpp.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "core/algorithms.hpp"
#include "core/buffer.hpp"
#include "core/exec.hpp"
#include "core/half.hpp"

namespace lbdem {
namespace {

// Each code's decoded bits and the code its value encodes back to.
template <class F>
struct DecodeAll {
  View<std::uint32_t> value_bits;
  View<std::uint16_t> recoded;
  LBDEM_HD void operator()(Index i) const {
    const float v = F::decode(static_cast<std::uint16_t>(i));
    value_bits[i] = half_detail::float_bits(v);
    recoded[i] = F::encode(v);
  }
};

// 1 where encode and encode_reference differ on float bit pattern i.
template <class F>
struct EncodeMismatch {
  LBDEM_HD std::uint64_t operator()(Index i) const {
    const float x = half_detail::bits_float(static_cast<std::uint32_t>(i));
    return F::encode(x) != F::encode_reference(x) ? 1u : 0u;
  }
};

template <class F>
void check_on_device() {
  if (!cuda_compiled() || !cuda_unavailable_reason().empty())
    GTEST_SKIP() << "no usable GPU: " << (cuda_compiled() ? cuda_unavailable_reason() : "built without CUDA");
  const Exec ex(Backend::Cuda);
  Buffer<std::uint32_t> bits(Backend::Cuda, 65536);
  Buffer<std::uint16_t> recoded(Backend::Cuda, 65536);
  for_each(ex, 65536, DecodeAll<F>{bits.view(), recoded.view()});
  ex.synchronize();
  const std::vector<std::uint32_t> b = bits.to_vector();
  const std::vector<std::uint16_t> r = recoded.to_vector();
  for (std::uint32_t c = 0; c < 65536; ++c) {
    const auto h = static_cast<std::uint16_t>(c);
    const float ref = F::decode_reference(h);
    ASSERT_EQ(b[c], half_detail::float_bits(ref)) << "decode of code 0x" << std::hex << c << " on the GPU";
    ASSERT_EQ(r[c], F::encode_reference(ref)) << "encode of the value of code 0x" << std::hex << c << " on the GPU";
  }
  Scratch scratch;
  const std::uint64_t bad =
      transform_reduce(ex, Index{1} << 32, std::uint64_t{0}, SumOp{}, EncodeMismatch<F>{}, scratch);
  EXPECT_EQ(bad, 0u) << "float bit patterns encoded on the GPU unlike encode_reference";
}

TEST(HalfDevice, Fp16cMatchesReference) { check_on_device<Fp16cFormat>(); }
TEST(HalfDevice, Binary16MatchesReference) { check_on_device<Binary16Format>(); }

}  // namespace
}  // namespace lbdem
