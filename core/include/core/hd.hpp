#pragma once
// Host/device annotations. A physics function marked LBDEM_HD is compiled for
// both the CUDA backend (when nvcc compiles the translation unit) and the host
// (OpenMP) backend from the same source.
#if defined(__CUDACC__)
#define LBDEM_HD __host__ __device__
#define LBDEM_DEVICE __device__
#define LBDEM_FORCEINLINE __forceinline__
// nvcc compiles a .cu file twice: for the device (__CUDA_ARCH__ defined) and
// for the host, where the loop must be unrolled by the host compiler so that
// lattice constants fold exactly as in a plain C++ build.
#if defined(__CUDA_ARCH__)
#define LBDEM_UNROLL _Pragma("unroll")
#else
#define LBDEM_UNROLL _Pragma("GCC unroll 32")
#endif
#else
#define LBDEM_HD
#define LBDEM_DEVICE
#define LBDEM_FORCEINLINE inline __attribute__((always_inline))
#define LBDEM_UNROLL _Pragma("GCC unroll 32")
#endif

#include <cstdint>
#include <cstddef>

namespace lbdem {
using Index = std::int64_t;  // cell and particle indices: 512^3 x 19 overflows 32 bits
}
