#pragma once
// The few parallel algorithms the engine needs: transform-reduce, exclusive
// scan, radix sort by key. CUB on the GPU, std/OpenMP on the host.
//
// Include this header only from kernel translation units (*.cu), so that the
// CUDA path is compiled where the backend exists. Temporary storage lives in a
// Scratch owned by the caller and grows only when a larger problem arrives, so
// a time loop that calls these allocates nothing after its first step.
#include <algorithm>
#include <numeric>
#include <vector>
#include <omp.h>
#include "core/buffer.hpp"
#if defined(__CUDACC__)
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/block/block_reduce.cuh>
#endif

namespace lbdem {

struct Scratch {
  Buffer<unsigned char> bytes;
  Buffer<unsigned char> partials;  // per-block reduction results
  std::vector<unsigned char> host_partials;
  void* get(Backend b, std::size_t n) {
    bytes.reserve_discard(b, static_cast<Index>(n));
    return bytes.data();
  }
};

#if defined(__CUDACC__)
template <int Block, class T, class Op, class F>
__global__ void transform_reduce_kernel(Index n, T init, Op op, F f, T* partials) {
  using BR = cub::BlockReduce<T, Block>;
  __shared__ typename BR::TempStorage tmp;
  T acc = init;
  for (Index i = static_cast<Index>(blockIdx.x) * Block + threadIdx.x; i < n;
       i += static_cast<Index>(gridDim.x) * Block)
    acc = op(acc, f(i));
  T r = BR(tmp).Reduce(acc, op);
  if (threadIdx.x == 0) partials[blockIdx.x] = r;
}
#endif

// Returns op-reduction of f(i) over [0, n), starting from init. op must be
// associative and commutative; the result is deterministic for a given
// backend and thread count (fixed partition, fixed combination order).
// Synchronous: the value comes back to the host.
template <class T, class Op, class F>
T transform_reduce(const Exec& ex, Index n, T init, Op op, F f, Scratch& s) {
  if (ex.on_device()) {
#if defined(__CUDACC__)
    constexpr int kBlock = 256;
    constexpr int kMaxBlocks = 1024;
    const int blocks = static_cast<int>(std::max<Index>(1, std::min<Index>(kMaxBlocks, (n + kBlock - 1) / kBlock)));
    s.partials.reserve_discard(Backend::Cuda, static_cast<Index>(sizeof(T)) * kMaxBlocks);
    T* parts = reinterpret_cast<T*>(s.partials.data());
    transform_reduce_kernel<kBlock><<<blocks, kBlock, 0, ex.stream()>>>(n, init, op, f, parts);
    LBDEM_CUDA_CHECK(cudaGetLastError());
    std::vector<T> host(static_cast<std::size_t>(blocks));
    LBDEM_CUDA_CHECK(cudaMemcpyAsync(host.data(), parts, sizeof(T) * blocks, cudaMemcpyDeviceToHost, ex.stream()));
    LBDEM_CUDA_CHECK(cudaStreamSynchronize(ex.stream()));
    T acc = init;
    for (const T& v : host) acc = op(acc, v);
    return acc;
#else
    throw_not_compiled_for_cuda("transform_reduce");
#endif
  }
  (void)s;
  // Fixed static partition per thread, combined in thread order: reproducible
  // for a given thread count.
  std::vector<T> part(static_cast<std::size_t>(omp_get_max_threads()), init);
#pragma omp parallel
  {
    T local = init;
#pragma omp for schedule(static) nowait
    for (Index i = 0; i < n; ++i) local = op(local, f(i));
    part[static_cast<std::size_t>(omp_get_thread_num())] = local;
  }
  T acc = init;
  for (const T& v : part) acc = op(acc, v);
  return acc;
}

// transform_reduce of f(cell, x, y, z) over the cells of a box of storage
// (core/grid.hpp), in the box's x-fastest order.
template <class T, class Op, class F>
T transform_reduce_cells(const Exec& ex, const GridView& g, const CellBox& box, T init, Op op, F f, Scratch& s) {
  return transform_reduce(ex, box.size(), init, op, BoxCells<F>{box, g, f}, s);
}

// out[i] = sum of in[0..i). out may alias in. Asynchronous on the device.
template <class T>
void exclusive_scan(const Exec& ex, const T* in, T* out, Index n, Scratch& s) {
  if (n <= 0) return;
  if (ex.on_device()) {
#if defined(__CUDACC__)
    std::size_t tmp = 0;
    LBDEM_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(nullptr, tmp, in, out, n, ex.stream()));
    void* p = s.get(Backend::Cuda, tmp);
    LBDEM_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(p, tmp, in, out, n, ex.stream()));
    return;
#else
    throw_not_compiled_for_cuda("exclusive_scan");
#endif
  }
  (void)s;
  T run{};
  for (Index i = 0; i < n; ++i) {
    const T v = in[i];
    out[i] = run;
    run += v;
  }
}

// Stable radix sort of (key, value) pairs by the key bits [begin_bit, end_bit).
// Keys and values are read from *_in and written to *_out (no aliasing).
template <class K, class V>
void sort_pairs(const Exec& ex, const K* keys_in, K* keys_out, const V* vals_in, V* vals_out, Index n,
                Scratch& s, int begin_bit = 0, int end_bit = static_cast<int>(sizeof(K) * 8)) {
  if (n <= 0) return;
  if (ex.on_device()) {
#if defined(__CUDACC__)
    std::size_t tmp = 0;
    LBDEM_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, tmp, keys_in, keys_out, vals_in, vals_out, n,
                                                     begin_bit, end_bit, ex.stream()));
    void* p = s.get(Backend::Cuda, tmp);
    LBDEM_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(p, tmp, keys_in, keys_out, vals_in, vals_out, n,
                                                     begin_bit, end_bit, ex.stream()));
    return;
#else
    throw_not_compiled_for_cuda("sort_pairs");
#endif
  }
  (void)begin_bit;
  (void)end_bit;
  // Host: stable sort of an index permutation, reusing the scratch bytes.
  Index* perm = static_cast<Index*>(s.get(Backend::Host, sizeof(Index) * static_cast<std::size_t>(n)));
  std::iota(perm, perm + n, Index{0});
  std::stable_sort(perm, perm + n, [&](Index a, Index b) { return keys_in[a] < keys_in[b]; });
  for (Index i = 0; i < n; ++i) {
    keys_out[i] = keys_in[perm[i]];
    vals_out[i] = vals_in[perm[i]];
  }
}

struct SumOp {
  template <class T> LBDEM_HD T operator()(const T& a, const T& b) const { return a + b; }
};
struct MaxOp {
  template <class T> LBDEM_HD T operator()(const T& a, const T& b) const { return a > b ? a : b; }
};

}  // namespace lbdem
