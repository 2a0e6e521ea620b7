#include "core/exec.hpp"

#include <spdlog/spdlog.h>

#include <cstdlib>
#include <mutex>
#include <string>

#include "core/buffer.hpp"

namespace lbdem {

const char* to_string(Backend b) { return b == Backend::Cuda ? "cuda" : "cpu"; }

void throw_cuda_error([[maybe_unused]] int code, const char* what, const char* file, int line) {
#if defined(LBDEM_HAVE_CUDA)
  const char* name = cudaGetErrorName(static_cast<cudaError_t>(code));
  const char* msg = cudaGetErrorString(static_cast<cudaError_t>(code));
#else
  const char* name = "?";
  const char* msg = "?";
#endif
  throw CudaError(std::string("CUDA call failed: ") + what + " -> " + name + " (" + msg + ") at " + file + ":" +
                  std::to_string(line));
}

void throw_not_compiled_for_cuda(const char* where) {
  throw Error(std::string(where) +
              ": asked to run on the CUDA backend from a translation unit not compiled by nvcc "
              "(kernel sources must end in .cu and be listed with lbdem_kernel_sources)");
}

#if defined(LBDEM_HAVE_CUDA)
namespace {
// LBDEM_CUDA_STACK_BYTES=N (a diagnostic for the sanitizer sweep): the current
// device's per-thread stack limit (cudaLimitStackSize), set once, when the
// first query finds a device. compute-sanitizer's memcheck gives its
// instrumented kernels larger frames than a CUDA-graph conditional body's
// kernels are given stack for (scripts/sanitizer_while_probe.cu); a larger
// limit lets it check the pressure solve's device loop itself.
void apply_stack_limit_once() {
  static std::once_flag once;
  std::call_once(once, [] {
    const char* v = std::getenv("LBDEM_CUDA_STACK_BYTES");
    if (!v) return;
    char* end = nullptr;
    const unsigned long bytes = std::strtoul(v, &end, 10);
    if (end == v || *end != '\0' || bytes == 0)
      throw ConfigError(std::string("LBDEM_CUDA_STACK_BYTES: '") + v + "' is not a positive number of bytes");
    LBDEM_CUDA_CHECK(cudaDeviceSetLimit(cudaLimitStackSize, bytes));
  });
}
}  // namespace
#endif

std::string cuda_unavailable_reason() {
#if defined(LBDEM_HAVE_CUDA)
  int n = 0;
  cudaError_t e = cudaGetDeviceCount(&n);
  if (e != cudaSuccess) {
    (void)cudaGetLastError();
    return std::string("no usable CUDA device (") + cudaGetErrorString(e) + ")";
  }
  if (n == 0) return "no CUDA device found";
  apply_stack_limit_once();
  return {};
#else
  return "this build has no CUDA backend (nvcc was not found at configure time)";
#endif
}

Backend resolve_backend(const std::string& request) {
  if (request == "cpu" || request == "host") return Backend::Host;
  if (request == "cuda" || request == "gpu") {
    std::string why = cuda_unavailable_reason();
    if (!why.empty()) throw ResourceError("--backend cuda: " + why + "; use --backend cpu or auto");
    return Backend::Cuda;
  }
  if (request == "auto") {
    std::string why = cuda_unavailable_reason();
    if (why.empty()) return Backend::Cuda;
    spdlog::info("backend auto: running on the CPU because {}", why);
    return Backend::Host;
  }
  throw ConfigError("--backend: '" + request + "' is not a backend; valid: cuda, cpu, auto");
}

void Exec::synchronize() const {
#if defined(LBDEM_HAVE_CUDA)
  if (on_device()) LBDEM_CUDA_CHECK(cudaStreamSynchronize(stream_));
#endif
}

void Lanes::make(const Exec& main) const {
  edge_ = Exec(main.backend());
  made_ = true;
#if defined(LBDEM_HAVE_CUDA)
  if (main.on_device()) {
    int least = 0, greatest = 0;
    LBDEM_CUDA_CHECK(cudaDeviceGetStreamPriorityRange(&least, &greatest));
    cudaStream_t s = nullptr;
    LBDEM_CUDA_CHECK(cudaStreamCreateWithPriority(&s, cudaStreamNonBlocking, greatest));
    edge_.set_stream(s);
    edge_.set_overlap_launches(main.overlap_launches());
    cudaEvent_t a = nullptr, b = nullptr;
    LBDEM_CUDA_CHECK(cudaEventCreateWithFlags(&a, cudaEventDisableTiming));
    LBDEM_CUDA_CHECK(cudaEventCreateWithFlags(&b, cudaEventDisableTiming));
    fork_event_ = a;
    join_event_ = b;
  }
#endif
}

const Exec& Lanes::edge(const Exec& main) const {
  if (!main.on_device()) return main;
  if (!made_) make(main);
  return edge_;
}

void Lanes::fork(const Exec& main) const {
  if (!main.on_device()) return;
  if (!made_) make(main);
#if defined(LBDEM_HAVE_CUDA)
  auto e = static_cast<cudaEvent_t>(fork_event_);
  LBDEM_CUDA_CHECK(cudaEventRecord(e, main.stream()));
  LBDEM_CUDA_CHECK(cudaStreamWaitEvent(edge_.stream(), e, 0));
#endif
}

void Lanes::join(const Exec& main) const {
  if (!main.on_device()) return;
  if (!made_) make(main);
#if defined(LBDEM_HAVE_CUDA)
  auto e = static_cast<cudaEvent_t>(join_event_);
  LBDEM_CUDA_CHECK(cudaEventRecord(e, edge_.stream()));
  LBDEM_CUDA_CHECK(cudaStreamWaitEvent(main.stream(), e, 0));
#endif
}

Lanes::~Lanes() {
#if defined(LBDEM_HAVE_CUDA)
  // Destructors do not throw: a failure here has nothing left to protect.
  if (fork_event_) cudaEventDestroy(static_cast<cudaEvent_t>(fork_event_));
  if (join_event_) cudaEventDestroy(static_cast<cudaEvent_t>(join_event_));
  if (made_ && edge_.on_device() && edge_.stream()) cudaStreamDestroy(edge_.stream());
#endif
}

}  // namespace lbdem

namespace lbdem {
std::vector<std::string> cuda_device_descriptions() {
  std::vector<std::string> out;
#if defined(LBDEM_HAVE_CUDA)
  if (!cuda_unavailable_reason().empty()) return out;
  int n = 0;
  LBDEM_CUDA_CHECK(cudaGetDeviceCount(&n));
  for (int i = 0; i < n; ++i) {
    cudaDeviceProp p{};
    LBDEM_CUDA_CHECK(cudaGetDeviceProperties(&p, i));
    out.push_back(std::to_string(i) + ": " + p.name + ", " + std::to_string(p.totalGlobalMem >> 20) + " MiB, " +
                  std::to_string(p.multiProcessorCount) + " SMs, compute capability " + std::to_string(p.major) +
                  "." + std::to_string(p.minor));
  }
#endif
  return out;
}
}  // namespace lbdem
