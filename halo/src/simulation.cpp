#include "halo/simulation.hpp"

#include <algorithm>
#include <chrono>

#include <spdlog/spdlog.h>

#include "core/output.hpp"
#include "core/signals.hpp"
#include "halo/stop_poll.hpp"

namespace lbdem::sim {

namespace {
double now_s() {
  using clk = std::chrono::steady_clock;
  return std::chrono::duration<double>(clk::now().time_since_epoch()).count();
}
// The smallest multiple of `every` above `step`.
long next_multiple(long step, long every) { return (step / every + 1) * every; }
}  // namespace

Trigger checkpoint_trigger(const ckpt::Policy& p) {
  Trigger t;
  t.every_steps = p.interval;
  t.every_seconds = 60.0 * p.minutes;
  t.at_stop = p.on_signal;
  t.at_finish = p.interval > 0 || p.minutes > 0;
  t.aligned = true;  // checkpoint.interval kept exactly (a scene whose answer depends on chunk ends sets false)
  t.agreed = true;
  return t;
}

Simulation::Simulation(const halo::Comm& comm, std::string scene, long first_step, long last_step, Stepping stepping,
                       std::string step_phase)
    : comm_(comm),
      scene_(std::move(scene)),
      first_(first_step),
      last_(std::max(first_step, last_step)),
      step_(first_step),
      stepping_(std::move(stepping)),
      step_phase_(std::move(step_phase)) {}

Simulation::~Simulation() = default;

void Simulation::add(std::string name, Trigger when, Op op, bool timed) {
  Entry e{std::move(name), when, std::move(op), timed};
  // A restart continues at a step where the run that wrote the checkpoint
  // ran its operations already (its series row, snapshot and checkpoint are
  // kept): none runs there again.
  if (first_ > 0) e.last_run = first_;
  ops_.push_back(std::move(e));
}

void Simulation::progress(std::function<double(long)> time_of, double work_per_step, std::string unit, bool quiet,
                          double interval_s) {
  progress_ = std::make_unique<Progress>(scene_, last_, interval_s, quiet || !comm_.root(), first_);
  time_of_ = std::move(time_of);
  work_per_step_ = work_per_step;
  unit_ = std::move(unit);
}

long Simulation::next_stop(long step) const {
  long next = last_;
  for (const auto& e : ops_)
    if (e.when.every_steps > 0 && e.when.aligned) next = std::min(next, next_multiple(step, e.when.every_steps));
  if (stepping_.chunk > 0) next = std::min(next, next_multiple(step, stepping_.chunk));
  return next;
}

double Simulation::elapsed() const { return started_ ? now_s() - t0_ : 0.0; }

double Simulation::phase(const std::string& name) const {
  const auto it = phases_.phases().find(name);
  return it == phases_.phases().end() ? 0.0 : it->second;
}

void Simulation::run_ops(const Event& ev) {
  const double t = elapsed();
  for (auto& e : ops_) {
    if (e.last_run == ev.step) continue;  // at most once per step
    const Trigger& w = e.when;
    bool fire = (ev.start && w.at_start) || (ev.last && w.at_end) || (ev.stopping && w.at_stop) ||
                (ev.finished && w.at_finish) || (!ev.start && w.every_steps > 0 && ev.step % w.every_steps == 0);
    if (w.every_seconds > 0 && !ev.start) {
      bool late = t - e.last_time >= w.every_seconds;
      // The clocks of the ranks differ: a collective operation runs where any
      // rank's is due (every rank meets here at the same step).
      if (w.agreed && comm_.distributed()) late = comm_.any(late);
      fire = fire || late;
    }
    if (!fire) continue;
    const double t_op = now_s();
    e.op(ev);
    e.last_run = ev.step;
    e.last_time = elapsed();
    if (e.timed) phases_.add(e.name, now_s() - t_op);
  }
}

void Simulation::report_progress(bool force) {
  if (!progress_ || !(force || progress_->due())) return;
  if (stepping_.wait) stepping_.wait();
  progress_->report(step_, time_of_ ? time_of_(step_) : 0.0, work_per_step_, unit_.c_str());
}

bool Simulation::run(const Advance& advance) {
  t0_ = now_s();
  started_ = true;
  const bool distributed = comm_.distributed();
  bool stop = false;
  if (first_ == 0) run_ops(Event{.step = 0, .start = true});
  std::unique_ptr<halo::StopPoll> poll;
  if (stepping_.chunk == 0) {
    poll = std::make_unique<halo::StopPoll>(comm_);
  } else {
    stop = comm_.any(stop_requested());
  }
  while (step_ < last_ && !stop && !ended_) {
    const long next = next_stop(step_);
    const double t_step = now_s();
    if (poll) {
      // Calls as long as the poll allows: one rank checks its flag after each
      // step, several ranks decide together every ~0.25 s of steps.
      while (step_ < next && !stop) {
        const long n = std::min(next - step_, poll->until_check());
        advance(n);
        step_ += n;
        if (distributed && stepping_.wait) stepping_.wait();  // the poll times the steps done
        stop = poll->after_steps(n);
      }
      if (stepping_.wait) stepping_.wait();
    } else {
      advance(next - step_);
      step_ = next;
      stop = comm_.any(stop_requested());
    }
    phases_.add(step_phase_, now_s() - t_step);
    const bool finished = step_ == last_;
    run_ops(Event{.step = step_, .last = finished || stop, .stopping = stop, .finished = finished});
    report_progress(false);
  }
  // A run with nothing left to do (a restart at its last step, or a stop
  // before the first step) still has its last boundary.
  if (step_ == first_ && (stop || step_ == last_))
    run_ops(Event{.step = step_, .last = true, .stopping = stop && step_ < last_, .finished = step_ == last_});
  stopped_ = step_ < last_ && !ended_;
  return !stopped_;
}

void Simulation::write_summary(const std::string& dir) {
  json::Value s = json::Value::object();
  s.set("scene", scene_)
      .set("steps", step_)
      .set("steps_planned", last_)
      .set("restarted_from_step", first_)
      .set("interrupted", interrupted())
      .set("ranks", comm_.size())
      .set("seconds", elapsed());
  json::Value ph = json::Value::object();
  for (const auto& [k, v] : phases_.phases()) ph.set(k, v);
  s.set("phases_s", ph);
  // The scene's fields after the loop's (a scene's value of the same key wins).
  for (const auto& [k, v] : summary_.members()) s.set(k, v);
  if (comm_.root()) io::write_text_atomically(dir + "/summary.json", s.dump());
}

int Simulation::conclude(const std::string& dir, double sim_time) {
  write_summary(dir);
  if (!interrupted()) return 0;
  if (comm_.root())
    spdlog::warn("stopped by {} at step {} of {} (t = {:.6g} s); output up to that step is in {}", stop_signal_name(),
                 step_, last_, sim_time, dir);
  return kExitInterrupted;
}

}  // namespace lbdem::sim
