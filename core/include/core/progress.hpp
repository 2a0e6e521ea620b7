#pragma once
// Progress lines every few seconds (step, simulated time, throughput, ETA)
// and a phase timer for the end-of-run summary.
#include <chrono>
#include <map>
#include <string>

namespace lbdem {

class Progress {
 public:
  // `first_step`: where the run starts (a restart's step): rates and the ETA
  // count the steps from there.
  Progress(std::string label, long total_steps, double interval_s, bool quiet, long first_step = 0);
  // Cheap: reads the clock; logs only when the interval has passed. Returns
  // true when it logged (callers synchronise the device before, if needed).
  bool due() const;
  void report(long step, double sim_time_s, double work_per_step, const char* work_unit);
  double elapsed() const;

 private:
  std::string label_;
  long total_;
  double interval_;
  bool quiet_;
  std::chrono::steady_clock::time_point start_, last_;
  long first_step_ = 0, last_step_ = 0;
};

// Accumulates wall time per named phase.
class PhaseTimer {
 public:
  void add(const std::string& phase, double seconds) { t_[phase] += seconds; }
  const std::map<std::string, double>& phases() const { return t_; }
  double total() const {
    double s = 0;
    for (auto& [k, v] : t_) s += v;
    return s;
  }

 private:
  std::map<std::string, double> t_;
};

std::string format_duration(double seconds);

}  // namespace lbdem
