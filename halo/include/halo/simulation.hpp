#pragma once
// The one time loop every scene runs through (DESIGN.md, habit 12).
//
// A scene parses its case, sets up its solvers and hands the loop a step
// function (advance n steps) and its operations: series rows and the
// watchdog, snapshots, checkpoints, ... each with a Trigger saying when it
// runs (every N steps, every M seconds of wall time, at the start of a fresh
// run, at the end, when a stop signal ends the run). The loop owns the rest:
// stepping to the next step an operation needs, stop polling (the same step
// on every rank), progress lines with ETA, the wall time of each phase, and
// the summary (summary.json), to which the scene adds its own fields.
//
// The model is waLBerla's timeloop of named sweeps and HOOMD-blue's
// operations with triggers; unlike those the loop also decides, for every
// rank alike, where a run may stop.
//
// Steps are run in chunks that end at the multiples of every aligned
// trigger's step count and at the last step (a restart at step s resumes the
// same grid of multiples: a restarted run meets its operations where a
// straight run does). Within a chunk, stops are polled:
//  - adaptively (Stepping::chunk = 0): halo::StopPoll, one collective decision
//    every ~0.25 s of steps on several ranks, after every step on one rank.
//    For scenes whose results do not depend on how their steps are split
//    into calls (the fluid, the coupled step).
//  - at fixed multiples (Stepping::chunk = K > 0): chunks also end at the
//    multiples of K, with one collective check after each. For scenes whose
//    split shapes the bits (DEM closes each call with a half kick): the
//    chunks depend on the case only, never on the wall clock or a signal.
//
// At each chunk end that an aligned step trigger, the end or a stop makes a
// "boundary", the operations run in the order they were added, each at most
// once per step; then a progress line when due.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/checkpoint.hpp"
#include "core/json.hpp"
#include "core/progress.hpp"
#include "halo/comm.hpp"

namespace lbdem::sim {

// When an operation runs. Several conditions may be set; any one fires it.
struct Trigger {
  long every_steps = 0;      // at steps that are multiples of this (0: never by count)
  double every_seconds = 0;  // at a boundary when this much wall time has passed since it last ran (0: never)
  bool at_start = false;     // before the first step of a fresh run (not on a restart)
  bool at_end = false;       // at the last boundary, whether the run finished or was stopped
  bool at_stop = false;      // at the boundary where a stop signal ends the run
  bool at_finish = false;    // at the last boundary of a run that did all its steps
  // The multiples of every_steps end a chunk (the loop stops there). False:
  // the operation fires only where another trigger's boundary falls on one
  // (a checkpoint interval that must not change how DEM splits its steps).
  bool aligned = true;
  // Wall-time decisions agreed by every rank (one reduction): for collective
  // operations (a checkpoint). False for rank-local ones.
  bool agreed = true;

  static Trigger steps(long n) { return Trigger{.every_steps = n}; }
  // Every n steps (n > 0) and at the end; never by count for n = 0.
  static Trigger steps_and_end(long n) { return Trigger{.every_steps = n, .at_end = true}; }
};

// What the loop tells an operation when it runs it.
struct Event {
  long step = 0;
  bool start = false;     // the fresh run's step 0, before any step
  bool last = false;      // the loop's final boundary (finished or stopped)
  bool stopping = false;  // a stop signal ends the run here
  bool finished = false;  // the planned steps are done
};

struct Stepping {
  // 0: adaptive stop polling; K > 0: chunks end at multiples of K (see above).
  long chunk = 0;
  // Waits for the work the step function launched (the device queue): after
  // each chunk on several ranks (so the stop poll times the steps), before a
  // progress line and at the end of each stepping phase.
  std::function<void()> wait = {};
};

// A checkpoint policy (case file `checkpoint:`) as a trigger: every
// `interval` steps exactly (aligned; a scene whose answer depends on where
// its chunks end, as DEM's, sets aligned false), every `minutes` of wall time
// (agreed by every rank), at a stop signal (`on_signal`), and at the end of a
// finished run when either cadence is set (so that a longer run can go on).
Trigger checkpoint_trigger(const ckpt::Policy& p);

class Simulation {
 public:
  using Op = std::function<void(const Event&)>;
  using Advance = std::function<void(long n)>;

  // Steps first_step+1 .. last_step (first_step: 0, or a restart's step).
  // `step_phase`: the name under which the step function's wall time is
  // summed ("lbm", "coupled", "dem").
  Simulation(const halo::Comm& comm, std::string scene, long first_step, long last_step, Stepping stepping = {},
             std::string step_phase = "step");
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // Adds an operation; `timed`: its wall time is summed under `name` in
  // phases() (and the summary's "phases_s").
  void add(std::string name, Trigger when, Op op, bool timed = false);
  // Progress lines every `interval_s` seconds on rank 0 (none when quiet):
  // step, simulated time time_of(step), `work_per_step` per second in `unit`, ETA.
  void progress(std::function<double(long)> time_of, double work_per_step, std::string unit, bool quiet,
                double interval_s = 5.0);

  // Runs the loop; true when every planned step is done, false when a stop
  // signal ended it (after the operations of its last boundary).
  bool run(const Advance& advance);

  // Called by an operation: the run is done at this boundary (a steady state
  // reached) and takes no further step; the operations after it in this
  // boundary still run, the end-of-run triggers do not fire again. Every rank
  // must call it at the same boundary. run() then returns true.
  void end_here() { ended_ = true; }

  long step() const { return step_; }
  long first_step() const { return first_; }
  long last_step() const { return last_; }
  // A stop signal ended the run before its last step.
  bool interrupted() const { return stopped_; }
  // An operation ended the run early (end_here).
  bool ended_early() const { return ended_; }
  const PhaseTimer& phases() const { return phases_; }
  double phase(const std::string& name) const;
  double elapsed() const;  // wall seconds since run() began
  const halo::Comm& comm() const { return comm_; }

  // The summary: the loop's fields (scene, steps, steps_planned,
  // restarted_from_step, interrupted, ranks, seconds, phases_s) are set by
  // write_summary(); a scene adds its own with summary()["key"] = value.
  json::Value& summary() { return summary_; }
  // Writes `dir`/summary.json on rank 0 (atomically: a temporary renamed).
  void write_summary(const std::string& dir);
  // The end of a run: the summary, and for a run a stop signal ended the
  // warning naming the signal, the step and the folder. Returns the exit
  // code: 0, or kExitInterrupted (core/signals.hpp).
  int conclude(const std::string& dir, double sim_time);

  // Where the loop stops after `step` (the next boundary, or a fixed-chunk
  // end): the smallest aligned multiple above `step`, at most last_step.
  // (Public for tests.)
  long next_stop(long step) const;

 private:
  struct Entry {
    std::string name;
    Trigger when;
    Op op;
    bool timed;
    long last_run = -1;
    double last_time = 0;  // seconds since the loop began when it last ran
  };
  bool boundary_step(long step) const;
  void run_ops(const Event& ev);
  void report_progress(bool force);

  const halo::Comm& comm_;
  std::string scene_;
  long first_, last_, step_;
  Stepping stepping_;
  std::string step_phase_;
  std::vector<Entry> ops_;
  PhaseTimer phases_;
  json::Value summary_ = json::Value::object();
  std::unique_ptr<Progress> progress_;
  std::function<double(long)> time_of_;
  double work_per_step_ = 0;
  std::string unit_;
  double t0_ = 0;
  bool started_ = false;
  bool stopped_ = false;
  bool ended_ = false;
};

}  // namespace lbdem::sim
