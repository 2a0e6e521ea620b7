#pragma once
// Typed errors. Every message names what was wrong, the value, and what would
// be valid; the CLI prints it and exits non-zero without touching output.
#include <stdexcept>
#include <string>

namespace lbdem {

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// Invalid case file or command-line input.
struct ConfigError : Error {
  using Error::Error;
};
// A CUDA runtime call failed.
struct CudaError : Error {
  using Error::Error;
};
// The simulation left its valid range (NaN, Mach limit, ...).
struct DivergenceError : Error {
  using Error::Error;
};
// Request that cannot be met by this machine (memory, backend).
struct ResourceError : Error {
  using Error::Error;
};

[[noreturn]] void throw_cuda_error(int code, const char* what, const char* file, int line);

}  // namespace lbdem

#if defined(LBDEM_HAVE_CUDA)
#include <cuda_runtime.h>
#define LBDEM_CUDA_CHECK(call)                                                   \
  do {                                                                           \
    cudaError_t lbdem_err_ = (call);                                             \
    if (lbdem_err_ != cudaSuccess)                                               \
      ::lbdem::throw_cuda_error(static_cast<int>(lbdem_err_), #call, __FILE__, __LINE__); \
  } while (0)
#endif
