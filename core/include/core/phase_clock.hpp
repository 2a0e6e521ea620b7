#pragma once
// Wall time of the phases of a time step, per rank, without a host
// synchronisation per step.
//
// The caller marks the end of each phase of a step (mark(p)); the time since
// the previous mark (or since begin_step) is phase p's. On the host backend
// the work is done when the call returns, so a steady clock at the marks
// measures every step. On the device the marks record CUDA events on the
// default stream, only in every `every`-th step (a sampled step), and
// collect() (called where the run synchronises anyway, e.g. at a series row)
// reads the completed ones; the totals scale them by steps / sampled steps. The
// events are made once (a ring of kRing sampled steps); nothing is allocated
// per step. A ring that fills before collect() is read at once (that one
// waits for the device).
#include <array>
#include <string>
#include <vector>

#include "core/exec.hpp"

namespace lbdem {

class PhaseClock {
 public:
  static constexpr int kMaxPhases = 8;
  static constexpr int kRing = 64;
  // names: one per phase (at most kMaxPhases).
  PhaseClock(Backend backend, std::vector<std::string> names, int every = 16);
  ~PhaseClock();
  PhaseClock(const PhaseClock&) = delete;
  PhaseClock& operator=(const PhaseClock&) = delete;
  void begin_step();
  void mark(int phase);
  void end_step();
  // Folds the completed device samples into the totals (no-op on the host).
  void collect();
  // Seconds per phase over the steps so far (device: estimated from the samples).
  // Device: the sampled steps' times scaled by steps / sampled steps.
  std::vector<double> totals() const;
  const std::vector<std::string>& names() const { return names_; }
  long steps() const { return steps_; }
  bool in_step() const { return in_step_; }

 private:
  Backend backend_;
  std::vector<std::string> names_;
  int every_;
  std::vector<double> totals_;
  long steps_ = 0;
  long collected_ = 0;  // device: sampled steps folded into totals_
  bool in_step_ = false;
  bool sampled_ = false;
  double last_ = 0;  // host: time of the previous mark
  // Device: per ring slot, the begin event and one per mark (phase of each mark).
  struct Slot {
    void* begin = nullptr;
    std::array<void*, kMaxPhases> ev{};
    std::array<int, kMaxPhases> phase{};
    int marks = 0;
  };
  std::vector<Slot> ring_;
  int head_ = 0, pending_ = 0;
};

}  // namespace lbdem
