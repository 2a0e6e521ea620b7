#pragma once
// Atomics usable from one kernel body on both backends.
#include <atomic>

#include "core/hd.hpp"

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

}  // namespace lbdem::dem::detail
