// Phase times of a step (core/phase_clock.hpp).
#include "core/phase_clock.hpp"

#include <chrono>

#include "core/error.hpp"
#if defined(LBDEM_HAVE_CUDA)
#include <cuda_runtime.h>
#endif

namespace lbdem {

namespace {
double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
#if defined(LBDEM_HAVE_CUDA)
void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw Error(std::string("PhaseClock: ") + what + ": " + cudaGetErrorString(e));
}
#endif
}  // namespace

PhaseClock::PhaseClock(Backend backend, std::vector<std::string> names, int every)
    : backend_(backend), names_(std::move(names)), every_(every < 1 ? 1 : every), totals_(names_.size(), 0.0) {
  if (names_.empty() || names_.size() > kMaxPhases) throw Error("PhaseClock: 1 to 8 phases");
#if defined(LBDEM_HAVE_CUDA)
  if (backend_ == Backend::Cuda) {
    ring_.resize(kRing);
    for (auto& s : ring_) {
      cudaEvent_t e;
      check(cudaEventCreate(&e), "cudaEventCreate");
      s.begin = e;
      for (auto& p : s.ev) {
        check(cudaEventCreate(&e), "cudaEventCreate");
        p = e;
      }
    }
  }
#endif
}

PhaseClock::~PhaseClock() {
#if defined(LBDEM_HAVE_CUDA)
  for (auto& s : ring_) {
    if (s.begin) cudaEventDestroy(static_cast<cudaEvent_t>(s.begin));
    for (auto* p : s.ev)
      if (p) cudaEventDestroy(static_cast<cudaEvent_t>(p));
  }
#endif
}

void PhaseClock::begin_step() {
  in_step_ = true;
  if (ring_.empty()) {
    last_ = now();
    return;
  }
#if defined(LBDEM_HAVE_CUDA)
  sampled_ = steps_ % every_ == 0;
  if (!sampled_) return;
  if (pending_ == kRing) collect();
  Slot& s = ring_[static_cast<std::size_t>((head_ + pending_) % kRing)];
  s.marks = 0;
  check(cudaEventRecord(static_cast<cudaEvent_t>(s.begin), nullptr), "cudaEventRecord");
#endif
}

void PhaseClock::mark(int phase) {
  if (!in_step_ || phase < 0 || phase >= static_cast<int>(totals_.size())) return;
  if (ring_.empty()) {
    const double t = now();
    totals_[static_cast<std::size_t>(phase)] += t - last_;
    last_ = t;
    return;
  }
#if defined(LBDEM_HAVE_CUDA)
  if (!sampled_) return;
  Slot& s = ring_[static_cast<std::size_t>((head_ + pending_) % kRing)];
  if (s.marks >= kMaxPhases) return;
  s.phase[static_cast<std::size_t>(s.marks)] = phase;
  check(cudaEventRecord(static_cast<cudaEvent_t>(s.ev[static_cast<std::size_t>(s.marks)]), nullptr), "cudaEventRecord");
  ++s.marks;
#endif
}

void PhaseClock::end_step() {
  if (!in_step_) return;
  in_step_ = false;
  ++steps_;
  if (!ring_.empty() && sampled_) ++pending_;
}

void PhaseClock::collect() {
#if defined(LBDEM_HAVE_CUDA)
  while (pending_ > 0) {
    Slot& s = ring_[static_cast<std::size_t>(head_)];
    if (s.marks > 0) {
      check(cudaEventSynchronize(static_cast<cudaEvent_t>(s.ev[static_cast<std::size_t>(s.marks - 1)])), "cudaEventSynchronize");
      cudaEvent_t prev = static_cast<cudaEvent_t>(s.begin);
      for (int m = 0; m < s.marks; ++m) {
        float ms = 0;
        const auto e = static_cast<cudaEvent_t>(s.ev[static_cast<std::size_t>(m)]);
        check(cudaEventElapsedTime(&ms, prev, e), "cudaEventElapsedTime");
        totals_[static_cast<std::size_t>(s.phase[static_cast<std::size_t>(m)])] += 1e-3 * double(ms);
        prev = e;
      }
    }
    ++collected_;
    head_ = (head_ + 1) % kRing;
    --pending_;
  }
#endif
}

std::vector<double> PhaseClock::totals() const {
  if (ring_.empty() || collected_ == 0) return totals_;
  std::vector<double> t = totals_;
  for (double& v : t) v *= double(steps_) / double(collected_);
  return t;
}

}  // namespace lbdem
