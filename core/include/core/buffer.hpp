#pragma once
// RAII memory on a backend. Kernels never see a Buffer: they take a
// trivially-copyable View (pointer + size) by value.
#include <cstring>
#include <utility>
#include <vector>
#include "core/exec.hpp"

namespace lbdem {

// Raw allocation on a backend, checked. Host memory is 64-byte aligned.
void* backend_alloc(Backend b, std::size_t bytes);
void backend_free(Backend b, void* p) noexcept;
// Copies between a backend buffer and host memory (synchronous).
void backend_copy_to_host(Backend b, void* dst_host, const void* src, std::size_t bytes);
void backend_copy_from_host(Backend b, void* dst, const void* src_host, std::size_t bytes);
void backend_copy(Backend b, void* dst, const void* src, std::size_t bytes);
void backend_memset(Backend b, void* dst, int value, std::size_t bytes);
// The same in the order of the Exec's queue (asynchronous on the device).
void backend_memset_on(const Exec& ex, void* dst, int value, std::size_t bytes);
// Bytes a new allocation can still take on this backend (device: free memory;
// host: available physical memory), at most the limit set below.
std::size_t backend_free_bytes(Backend b);
// Caps what backend_free_bytes reports (both backends): the memory checks then
// refuse a run that needs more (`lbdem run --memory`). 0 removes the cap.
void set_memory_limit(std::size_t bytes);
// Makes backend_free_bytes report `bytes` on both backends, whatever is free
// here, more or less: the memory checks then answer for the machine a case is
// meant for (`lbdem check --memory` on a login node for a GPU node). 0
// measures again.
void set_memory_assumed(std::size_t bytes);

template <class T>
struct View {
  T* ptr = nullptr;
  Index n = 0;
  LBDEM_HD T& operator[](Index i) const { return ptr[i]; }
  LBDEM_HD Index size() const { return n; }
};

template <class T>
class Buffer {
 public:
  Buffer() = default;
  Buffer(Backend b, Index n) : backend_(b), n_(n) {
    if (n_ > 0) ptr_ = static_cast<T*>(backend_alloc(b, bytes()));
  }
  ~Buffer() { reset(); }
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  Buffer(Buffer&& o) noexcept { swap(o); }
  Buffer& operator=(Buffer&& o) noexcept {
    if (this != &o) { reset(); swap(o); }
    return *this;
  }
  void swap(Buffer& o) noexcept {
    std::swap(backend_, o.backend_);
    std::swap(ptr_, o.ptr_);
    std::swap(n_, o.n_);
  }
  void reset() noexcept {
    if (ptr_) backend_free(backend_, ptr_);
    ptr_ = nullptr;
    n_ = 0;
  }
  // Grows (never shrinks) to at least n elements; contents are not kept.
  // Grows (contents discarded); a new allocation starts zeroed, so that host
  // copies of a whole buffer never read memory no kernel wrote (initcheck).
  void reserve_discard(Backend b, Index n) {
    if (n <= n_ && b == backend_) return;
    reset();
    *this = Buffer(b, n);
    fill_zero();
  }

  T* data() const { return ptr_; }
  Index size() const { return n_; }
  std::size_t bytes() const { return static_cast<std::size_t>(n_) * sizeof(T); }
  Backend backend() const { return backend_; }
  View<T> view() const { return View<T>{ptr_, n_}; }

  void copy_from_host(const T* src, Index count, Index offset = 0) {
    backend_copy_from_host(backend_, ptr_ + offset, src, static_cast<std::size_t>(count) * sizeof(T));
  }
  void copy_from_host(const std::vector<T>& v) { copy_from_host(v.data(), static_cast<Index>(v.size())); }
  void copy_to_host(T* dst, Index count, Index offset = 0) const {
    backend_copy_to_host(backend_, dst, ptr_ + offset, static_cast<std::size_t>(count) * sizeof(T));
  }
  std::vector<T> to_vector() const {
    std::vector<T> v(static_cast<std::size_t>(n_));
    if (n_ > 0) copy_to_host(v.data(), n_);
    return v;
  }
  // Zeroes the buffer in the legacy default stream's order (setup code).
  void fill_zero() { if (n_ > 0) backend_memset(backend_, ptr_, 0, bytes()); }
  // Zeroes the buffer in the order of `queue` (a stream on the device): what
  // work queued on another stream than the legacy default one must use.
  void fill_zero(const Exec& queue) { if (n_ > 0) backend_memset_on(queue, ptr_, 0, bytes()); }

 private:
  Backend backend_ = Backend::Host;
  T* ptr_ = nullptr;
  Index n_ = 0;
};

}  // namespace lbdem
