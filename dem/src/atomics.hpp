#pragma once
// Atomics usable from one kernel body on both backends.
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/hd.hpp"
#if defined(__CUDACC__)
#include <cooperative_groups.h>
#include <cooperative_groups/reduce.h>
#endif

namespace lbdem::dem::detail {

LBDEM_HD LBDEM_FORCEINLINE void atomic_add(double* a, double v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(a, v);
#else
  std::atomic_ref<double>(*a).fetch_add(v, std::memory_order_relaxed);
#endif
}
LBDEM_HD LBDEM_FORCEINLINE void atomic_max(int* a, int v) {
#if defined(__CUDA_ARCH__)
  atomicMax(a, v);
#else
  std::atomic_ref<int> r(*a);
  int cur = r.load(std::memory_order_relaxed);
  while (cur < v && !r.compare_exchange_weak(cur, v, std::memory_order_relaxed)) {
  }
#endif
}
LBDEM_HD LBDEM_FORCEINLINE void atomic_set(int* a, int v) {
#if defined(__CUDA_ARCH__)
  *reinterpret_cast<volatile int*>(a) = v;
#else
  std::atomic_ref<int>(*a).store(v, std::memory_order_relaxed);
#endif
}

// Bits of the smallest float >= x, for x >= 0: the order of the bits is the
// order of the values, so an integer max over them is a max over the values,
// rounded up (conservative for a bound). Same bits on both backends.
LBDEM_HD LBDEM_FORCEINLINE std::uint32_t float_bits_up(double x) {
#if defined(__CUDA_ARCH__)
  return __float_as_uint(__double2float_ru(x));
#else
  float f = static_cast<float>(x);
  if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return std::bit_cast<std::uint32_t>(f);
#endif
}
inline double from_float_bits(std::uint32_t b) { return static_cast<double>(std::bit_cast<float>(b)); }

// *a = max(*a, v). On the GPU the lanes of a warp that arrive together reduce
// first and one of them does the atomic (called by every particle of a report
// step: one atomic per warp instead of 32 on a single address).
LBDEM_HD LBDEM_FORCEINLINE void atomic_max_u32(std::uint32_t* a, std::uint32_t v) {
#if defined(__CUDA_ARCH__)
  namespace cg = cooperative_groups;
  const cg::coalesced_group g = cg::coalesced_threads();
  const std::uint32_t mx = cg::reduce(g, v, cg::greater<std::uint32_t>());
  if (g.thread_rank() == 0 && mx > *reinterpret_cast<volatile std::uint32_t*>(a)) atomicMax(a, mx);
#else
  std::atomic_ref<std::uint32_t> r(*a);
  std::uint32_t cur = r.load(std::memory_order_relaxed);
  while (cur < v && !r.compare_exchange_weak(cur, v, std::memory_order_relaxed)) {
  }
#endif
}

}  // namespace lbdem::dem::detail
