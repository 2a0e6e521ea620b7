#pragma once
// When a time loop looks for a stop signal (core/signals.hpp), the same way
// on every rank.
//
// On one rank the flag is a host variable: after_step() reads it after every
// step. On several ranks a signal may reach the ranks at different steps, and
// they must stop at the same one, so they decide together (one reduction)
// every stride() steps. The stride adapts to the wall time of a step so that
// a check comes about every `period` seconds (a reduction costs microseconds
// to a few hundred on many ranks, well under 1 % of that): it is the smallest
// of the ranks' proposals, carried in the same reduction as the stop flag, so
// every rank runs the same stride; it at most doubles from one check to the
// next (a short measurement cannot make it jump), and drops at once when
// steps become slower.
//
// The stride changes only where a loop checks, not what it computes: use it
// where one step per call gives the same result as longer calls (the fluid
// and coupled loops).
#include <chrono>
#include <functional>

#include "halo/comm.hpp"

namespace lbdem::halo {

class StopPoll {
 public:
  // `wait` (optional) waits for the work launched so far (a device queue),
  // so that the wall time measured is that of the steps done; it is called
  // before each collective check on several ranks.
  explicit StopPoll(const Comm& comm, double period_s = 0.25, std::function<void()> wait = {});

  // Counts `n` steps done (at most until_check()); true when the run is to
  // stop now. On several ranks every rank must call it after the same steps
  // (a collective when stride() steps are done). Once true it stays true.
  bool after_steps(long n = 1);
  // Steps to run before the next check is due (1 on one rank).
  long until_check() const { return stride_ - since_; }
  // Decides now (collective on several ranks), e.g. where all ranks meet anyway.
  bool now();
  // Steps between two collective checks (1 on one rank).
  long stride() const { return stride_; }
  bool stopping() const { return stop_; }

 private:
  const Comm& comm_;
  double period_;
  std::function<void()> wait_;
  long stride_ = 1;
  long since_ = 0;  // steps since the last check
  bool stop_ = false;
  std::chrono::steady_clock::time_point last_;
};

}  // namespace lbdem::halo
