#include "core/progress.hpp"

#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>

namespace lbdem {

std::string format_duration(double s) {
  if (!std::isfinite(s) || s < 0) return "--:--:--";
  const long t = static_cast<long>(s + 0.5);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%02ld:%02ld:%02ld", t / 3600, (t / 60) % 60, t % 60);
  return buf;
}

Progress::Progress(std::string label, long total_steps, double interval_s, bool quiet, long first_step)
    : label_(std::move(label)), total_(total_steps), interval_(interval_s), quiet_(quiet),
      start_(std::chrono::steady_clock::now()), last_(start_), first_step_(first_step), last_step_(first_step) {}

bool Progress::due() const {
  if (quiet_) return false;
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - last_).count() >= interval_;
}

double Progress::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::report(long step, double sim_time_s, double work_per_step, const char* work_unit) {
  const auto now = std::chrono::steady_clock::now();
  const double dt = std::chrono::duration<double>(now - last_).count();
  const double rate = dt > 0 ? (step - last_step_) * work_per_step / dt : 0;
  const double total_el = std::chrono::duration<double>(now - start_).count();
  const double eta = step > first_step_ ? total_el * double(total_ - step) / double(step - first_step_) : NAN;
  if (!quiet_)
    spdlog::info("{}: step {}/{} ({:.0f}%)  t = {:.6g} s  {:.1f} {}  elapsed {}  ETA {}", label_, step, total_,
                 total_ > 0 ? 100.0 * step / total_ : 100.0, sim_time_s, rate, work_unit, format_duration(total_el),
                 format_duration(eta));
  last_ = now;
  last_step_ = step;
}

}  // namespace lbdem
