#include "halo/stop_poll.hpp"

#include <algorithm>
#include <cmath>

#include "core/signals.hpp"

namespace lbdem::halo {

StopPoll::StopPoll(const Comm& comm, double period_s, std::function<void()> wait)
    : comm_(comm), period_(period_s), wait_(std::move(wait)), last_(std::chrono::steady_clock::now()) {}

bool StopPoll::after_steps(long n) {
  if (stop_) return true;
  if (!comm_.distributed()) return stop_ = stop_requested();
  since_ += n;
  if (since_ < stride_) return false;
  return now();
}

bool StopPoll::now() {
  if (stop_) return true;
  if (!comm_.distributed()) return stop_ = stop_requested();
  if (wait_) wait_();
  const auto t = std::chrono::steady_clock::now();
  const double secs = std::chrono::duration<double>(t - last_).count();
  // This rank's proposal: the steps that take `period_` at the speed just
  // measured, at most twice the current stride, at least 1.
  long mine = 2 * stride_;
  if (since_ > 0 && secs > 0) {
    const double per_step = secs / static_cast<double>(since_);
    mine = static_cast<long>(std::clamp(std::floor(period_ / per_step), 1.0, static_cast<double>(mine)));
  }
  // One reduction: 0 from any rank that saw a signal, else the smallest proposal.
  const long agreed = comm_.min(stop_requested() ? 0L : mine);
  stop_ = agreed == 0;
  if (!stop_) stride_ = agreed;
  since_ = 0;
  last_ = std::chrono::steady_clock::now();
  return stop_;
}

}  // namespace lbdem::halo
