#pragma once
// Execution backends behind one interface.
//
// A kernel body is a small trivially-copyable functor with an
// `LBDEM_HD void operator()(Index i) const`. for_each(exec, n, f) launches it
// as a CUDA kernel (one thread per index) or runs it as an OpenMP loop. Never
// capture `this` in a functor: pass views (pointer + extents) by value.
#include <string>
#include <vector>
#include "core/error.hpp"
#include "core/grid.hpp"
#include "core/hd.hpp"

namespace lbdem {

enum class Backend { Host, Cuda };

const char* to_string(Backend b);

// True when this binary was built with the CUDA backend.
constexpr bool cuda_compiled() {
#if defined(LBDEM_HAVE_CUDA)
  return true;
#else
  return false;
#endif
}

// Empty when a CUDA device is usable; otherwise a sentence saying why not.
std::string cuda_unavailable_reason();

// Resolves "cuda", "cpu" (alias "host") or "auto". "auto" picks the GPU when
// one is usable and otherwise logs once why it runs on the CPU. Asking for
// "cuda" where none is usable throws ResourceError with the reason.
Backend resolve_backend(const std::string& request);

// Where and on which stream work runs.
class Exec {
 public:
  explicit Exec(Backend b = Backend::Host) : backend_(b) {}
  Backend backend() const { return backend_; }
  bool on_device() const { return backend_ == Backend::Cuda; }
#if defined(LBDEM_HAVE_CUDA)
  cudaStream_t stream() const { return stream_; }
  void set_stream(cudaStream_t s) { stream_ = s; }
#endif
  // Waits for all work queued on this Exec (no-op on the host).
  void synchronize() const;
  // Overlapped launches (programmatic dependent launch, sm_90): a for_each
  // kernel queued on this Exec is launched while the kernel before it in the
  // stream is still running, and its threads wait for that kernel's end and
  // its memory (griddepcontrol.wait) before they do anything. The same order
  // of effects, a shorter gap between small kernels. Off by default.
  bool overlap_launches() const { return overlap_; }
  void set_overlap_launches(bool on) { overlap_ = on; }

 private:
  Backend backend_;
  bool overlap_ = false;
#if defined(LBDEM_HAVE_CUDA)
  cudaStream_t stream_ = nullptr;
#endif
};

// A second queue beside an Exec, for work that must overlap the main queue's
// (the halo's edge cells and packing): on the device a non-blocking stream
// of the highest priority and two events to order the queues; on the host
// the main queue itself (work runs in the order it is issued). Made on first
// use; no allocation afterwards.
class Lanes {
 public:
  Lanes() = default;
  Lanes(const Lanes&) = delete;
  Lanes& operator=(const Lanes&) = delete;
  ~Lanes();
  const Exec& edge(const Exec& main) const;
  void fork(const Exec& main) const;  // edge work queued next waits for main's work so far
  void join(const Exec& main) const;  // main work queued next waits for edge's work so far

 private:
  void make(const Exec& main) const;
  mutable Exec edge_;
  mutable bool made_ = false;
  mutable void* fork_event_ = nullptr;
  mutable void* join_event_ = nullptr;
};

[[noreturn]] void throw_not_compiled_for_cuda(const char* where);

#if defined(__CUDACC__)
// Waits for the kernel before this one in the stream (its end and its
// memory) where this one was launched overlapped (no-op otherwise), then lets
// an overlapped kernel after this one start launching.
__device__ __forceinline__ void wait_previous_kernel() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  asm volatile("griddepcontrol.wait;" ::: "memory");
  asm volatile("griddepcontrol.launch_dependents;" :::);
#endif
}

template <class F>
__global__ void for_each_kernel(Index n, F f) {
  wait_previous_kernel();
  const Index i = static_cast<Index>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

// Launches for_each_kernel with the programmatic-serialisation attribute.
template <class F>
void launch_overlapped(unsigned grid, int block, cudaStream_t stream, Index n, const F& f) {
  cudaLaunchConfig_t cfg{};
  cfg.gridDim = dim3(grid);
  cfg.blockDim = dim3(static_cast<unsigned>(block));
  cfg.stream = stream;
  cudaLaunchAttribute at[1];
  at[0].id = cudaLaunchAttributeProgrammaticStreamSerialization;
  at[0].val.programmaticStreamSerializationAllowed = 1;
  cfg.attrs = at;
  cfg.numAttrs = 1;
  LBDEM_CUDA_CHECK(cudaLaunchKernelEx(&cfg, for_each_kernel<F>, n, f));
}
#endif

// Runs f(i) for i in [0, n). Asynchronous on the CUDA backend.
template <class F>
void for_each(const Exec& ex, Index n, const F& f, int block_size = 256) {
  if (n <= 0) return;
  if (ex.on_device()) {
#if defined(__CUDACC__)
    const Index grid = (n + block_size - 1) / block_size;
    if (ex.overlap_launches()) {
      launch_overlapped(static_cast<unsigned>(grid), block_size, ex.stream(), n, f);
      return;
    }
    for_each_kernel<<<static_cast<unsigned>(grid), block_size, 0, ex.stream()>>>(n, f);
    LBDEM_CUDA_CHECK(cudaGetLastError());
    return;
#else
    (void)block_size;
    throw_not_compiled_for_cuda("for_each");
#endif
  }
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i) f(i);
}

#if defined(__CUDACC__)
template <int MinBlocks, class F>
__global__ void __launch_bounds__(256, MinBlocks) for_each_bounded_kernel(Index n, F f) {
  const Index i = static_cast<Index>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}
#endif

// for_each with blocks of 256 and the register budget that lets MinBlocks
// blocks share a multiprocessor (__launch_bounds__): for heavy kernels whose
// unconstrained register count would leave too few warps to hide memory latency.
template <int MinBlocks, class F>
void for_each_bounded(const Exec& ex, Index n, const F& f) {
  if (n <= 0) return;
  if (ex.on_device()) {
#if defined(__CUDACC__)
    const Index grid = (n + 255) / 256;
    for_each_bounded_kernel<MinBlocks><<<static_cast<unsigned>(grid), 256, 0, ex.stream()>>>(n, f);
    LBDEM_CUDA_CHECK(cudaGetLastError());
    return;
#else
    throw_not_compiled_for_cuda("for_each_bounded");
#endif
  }
#pragma omp parallel for schedule(static)
  for (Index i = 0; i < n; ++i) f(i);
}

// A per-cell functor f(cell, x, y, z) over the cells of a box of storage
// (core/grid.hpp): thread t takes the box's t-th cell, so one kernel body
// serves the owned cells, the inner cells and each outer slab alike. Returns
// f's value (transform_reduce_cells in core/algorithms.hpp reduces it).
template <class F>
struct BoxCells {
  CellBox box;
  GridView g;
  F f;
  LBDEM_HD LBDEM_FORCEINLINE auto operator()(Index t) const {
    int x, y, z;
    box.coords(t, x, y, z);
    return f(g.index(x, y, z), x, y, z);
  }
};

// The host side of for_each_cell: the box's rows along x, the (y, z) rows
// split over the threads in order (each thread a contiguous stretch of
// storage, where a parallel first touch placed its pages), no division per
// cell. Each thread runs a private copy of the functor: its pointers and
// constants are then locals that no store through a field pointer can alias.
// Simd: the cells of a row have no dependence between them (each writes only
// slots no other cell of the step reads or writes), so the compiler may
// vectorise across x. The cells off the storage's x ends get their x as
// InnerX (core/grid.hpp): a kernel that takes it finds its x neighbours at
// fixed offsets, the loads and stores of the row are then unit stride, and the
// row vectorises; the (at most two) end cells run one by one.
template <bool Simd, class F>
void for_each_cell_host(const GridView& g, const CellBox& box, const F& f) {
  if (box.empty()) return;
  const Index rows = static_cast<Index>(box.ext[1]) * box.ext[2];
  const int x0 = box.lo[0], x1 = box.lo[0] + box.ext[0];
  const int xa = x0 > 1 ? x0 : 1, xb = x1 < g.nx - 1 ? x1 : g.nx - 1;  // the row's inner cells [xa, xb)
#pragma omp parallel
  {
    const F k = f;
#pragma omp for schedule(static)
    for (Index r = 0; r < rows; ++r) {
      const int y = box.lo[1] + static_cast<int>(r % box.ext[1]);
      const int z = box.lo[2] + static_cast<int>(r / box.ext[1]);
      const Index base = g.index(0, y, z);  // the row's cell at x = 0
      if constexpr (Simd) {
        if (xa < xb) {
          for (int x = x0; x < xa; ++x) k(base + x, x, y, z);
#pragma omp simd
          for (int x = xa; x < xb; ++x) k(base + x, InnerX{x}, y, z);
          for (int x = xb; x < x1; ++x) k(base + x, x, y, z);
          continue;
        }
      }
      for (int x = x0; x < x1; ++x) k(base + x, x, y, z);
    }
  }
}

template <class F>
void for_each_cell(const Exec& ex, const GridView& g, const CellBox& box, const F& f) {
  if (!ex.on_device()) return for_each_cell_host<false>(g, box, f);
  for_each(ex, box.size(), BoxCells<F>{box, g, f});
}

// for_each_cell for kernels whose cells are independent within a launch
// (for_each_cell_host<true>); the same launch on the device.
template <class F>
void for_each_cell_independent(const Exec& ex, const GridView& g, const CellBox& box, const F& f) {
  if (!ex.on_device()) return for_each_cell_host<true>(g, box, f);
  for_each(ex, box.size(), BoxCells<F>{box, g, f});
}

template <int MinBlocks, class F>
void for_each_cell_bounded(const Exec& ex, const GridView& g, const CellBox& box, const F& f) {
  if (!ex.on_device()) return for_each_cell_host<false>(g, box, f);
  for_each_bounded<MinBlocks>(ex, box.size(), BoxCells<F>{box, g, f});
}

}  // namespace lbdem

namespace lbdem {
// One line per CUDA device (name, memory, multiprocessors, compute capability);
// empty without a usable device.
std::vector<std::string> cuda_device_descriptions();
}  // namespace lbdem
