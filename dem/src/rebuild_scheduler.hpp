#pragma once
// Neighbour-list rebuild decisions of a DemSystem without a blocking read per
// step: a ring of device reports (largest displacement since the build,
// speed, acceleration) copied to page-locked host memory, read a few steps
// late, and the bound on the motion since that decides each rebuild ahead of
// time. dem/README.md ("Rebuild decisions") derives the bound and the report
// schedule.
#include <cstdint>
#include <string>
#include <vector>

#include "core/buffer.hpp"
#include "core/checkpoint.hpp"
#include "core/exec.hpp"
#include "halo/comm.hpp"
#include "report.hpp"

namespace lbdem::dem {

struct State;

class RebuildScheduler {
 public:
  static constexpr int kRing = 4;         // report slots (device and host mirror)
  static constexpr int kMaxReportEvery = 8;

  // A report taken and not yet read.
  struct Pending {
    long from, t;  // the steps it covers (over2) and the state it reports
    long due;      // read before deciding the step that produces this state
    int slot;
  };

  RebuildScheduler() = default;
  ~RebuildScheduler();  // frees the page-locked mirror and the events
  RebuildScheduler(const RebuildScheduler&) = delete;
  RebuildScheduler& operator=(const RebuildScheduler&) = delete;

  // `lookahead`: decide from lagged reports (RebuildCheck::Lookahead); else
  // every step reports and is read at once. Throws ConfigError for safety < 1.
  void init(const Exec& ex, bool lookahead, double skin, double dt, double safety);

  // Device slot of report q (reports are reduced into slot q % kRing).
  StatusRecord* slot(long q) { return status.data() + q % kRing; }
  // Zeroes slot(q) from the host: what particle 0 of a report kernel does
  // for the next report, on a rank that owns no particle (decomposed run).
  void zero_slot(long q);
  // Where reductions go that no report will read (bench hook).
  StatusRecord* sink() { return status.data() + kRing; }
  // Queues the copy of the report just reduced into slot(reports) (device:
  // asynchronous, page-locked target, event after it; host: already final).
  // t: the state it reports; due: the step before whose decision it is read.
  void take_report(long t, long due);
  // A synchronous report of the state in `s` (first advance() call, or after
  // a bench hook moved the particles); `step`: its step count.
  void initial_report(const State& s, Index count, long step);
  // Reads the reports due before deciding the step that produces state t.
  // Throws DivergenceError if one shows a stale list.
  void read_due(long t) {
    while (npending > 0 && pending[0].due <= t) read_front();
  }
  // Whether read_due(t) reads a report (and may wait for the device).
  bool read_waits(long t) const { return npending > 0 && pending[0].due <= t; }
  // Whether the list must be rebuilt before the forces of state t (Lookahead).
  bool rebuild_due(long t) const { return predicted_displacement(t) > 0.5 * skin; }
  // Every-step check: takes the report of state t and reads it now (one
  // blocking read); true when a displacement exceeded skin/2.
  bool exact_check(long t);
  // A list build at state t.
  void on_build(long t) { t_build = t; }
  // Drops all reports, zeroes the ring and clears a stale-list error (after
  // a full synchronisation, which this does).
  void reset();
  // Throws DivergenceError if a report that arrived (the device being
  // synchronised) shows a stale list (Lookahead; once).
  void check_arrived();

  // Checkpoint state: the report ring (device slots and host copies), the
  // reports pending and the last one read (dem/src/system_state.cpp).
  // Synchronous.
  void save_state(ckpt::Sink& out) const;
  void load_state(ckpt::Source& in);

  // A decomposed run: every report read is reduced over the ranks (largest
  // values), so all ranks take the same decisions (null on one rank).
  const halo::Comm* comm = nullptr;
  bool lookahead = true;
  bool known = false;     // a report has been read since the last reset
  int report_every = 1;   // steps between reports inside a call, and their lag
  long reports = 0;       // reports taken so far (the next one uses slot reports % kRing)
  long t_last_report = 0; // state (step count) of the last report taken
  long status_reads = 0, status_waits = 0;
  std::string stale_error;  // set once a stale list was reported: advance() refuses until rebuild()

 private:
  const StatusRecord& wait_report(int s);
  // The report over all ranks (comm), else r itself.
  StatusRecord global(const StatusRecord& r);
  std::vector<double> reduce_buf;
  Pending pop_front();
  std::string stale_message(const Pending& p, std::uint32_t over2) const;
  void read_front();
  double motion_bound(long k) const;
  double predicted_displacement(long t) const;

  Exec ex;
  double skin = 0, dt = 0, safety = 1;
  Buffer<StatusRecord> status;         // kRing slots + one sink slot (bench hook), zeroed at start
  StatusRecord* mirror = nullptr;      // host copies: page-locked (CUDA) or mirror_host's storage
  std::vector<StatusRecord> mirror_host;
#if defined(LBDEM_HAVE_CUDA)
  cudaEvent_t events[kRing] = {};
#endif
  Pending pending[kRing] = {};  // oldest first
  int npending = 0;
  // The last report read: state t_known, largest displacement since the
  // build [m], speed [m/s] and acceleration [m/s^2] there.
  long t_known = 0;
  double d_known = 0, v_known = 0, a_known = 0;
  long t_build = 0;  // state (step count) of the last list build
};

}  // namespace lbdem::dem
