#pragma once
// Storage type of the populations and the type the kernels compute in.
// fp32 and fp64 storage compute in their own precision; the 16-bit formats
// (core/half.hpp) are converted to float on load and rounded back on store,
// so only the stored populations are 16-bit and every sum is a float sum.
#include "core/half.hpp"

namespace lbdem::lbm {

template <class T>
struct StorageTraits {
  using Compute = T;
};
template <>
struct StorageTraits<Fp16s> {
  using Compute = float;
};
template <>
struct StorageTraits<Fp16c> {
  using Compute = float;
};

// The compute type of storage type T.
template <class T>
using compute_t = typename StorageTraits<T>::Compute;

}  // namespace lbdem::lbm
