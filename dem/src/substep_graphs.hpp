#pragma once
// CUDA graphs of "plain" DEM sub-steps (dem/README.md, "Sub-step graphs"): a
// sub-step that neither reports to the rebuild scheduler nor rebuilds the
// list, and is not the first of an advance() call, is the same launches
// (KickDrift with synced 0, extrapolation 1, no report, displacement check
// on, then the particle-path force; or, with fused sub-steps, the previous
// step's forces and this kick-drift in one kernel) with arguments the host
// knows in advance. DemSystem::advance() queues such steps here instead of launching
// them and flushes the queue, as one graph launch, before anything else is
// issued (a report, a rebuild, the closing kick) and before the host waits
// for a report. Each graph is the capture of exactly the launches the queue
// stands for, keyed by every pointer and count those launches read, so a
// replay is the same work in the same stream order as launching them one by
// one (the same bits) and a changed particle count or buffer is a new key.
// Captured graphs are kept in a fixed table (least recently used replaced,
// through cudaGraphExecUpdate where the shape allows): no allocation in the
// time loop once the keys seen recur.
#include <array>
#include <cstdint>
#include <vector>

#include "core/exec.hpp"
#include "report.hpp"
#include "state.hpp"

namespace lbdem::dem {

class SubstepGraphs {
 public:
  static constexpr int kMaxRun = 16;  // sub-steps per graph (a longer run is flushed in parts)
  // Graphs kept: a run's key takes 2 rebuild parities (the reorder and the
  // list swap their arrays at each build) x 2 force parities x 4 report
  // slots x 2 position parities (fused sub-steps swap the positions at each
  // step but an advance() call's first) = 32 values per run length, so every
  // key of runs up to kMaxRun long fits and a steady schedule never captures
  // again.
  static constexpr int kTable = 32 * kMaxRun;

  // Issues one plain sub-step's launches on `ex` (DemSystem's own kernels, so
  // that a capture records exactly what a direct launch runs): the kick-drift
  // on the first view and the forces on the second, or, fused, the forces of
  // the first view and the kick-drift into the second's positions and
  // predictors.
  using IssueStep = void (*)(const Exec& ex, const State& kick, StatusRecord* rec, StatusRecord* next,
                             const State& force, bool friction);
  SubstepGraphs(const Exec& ex, bool friction, IssueStep issue);
  ~SubstepGraphs();
  SubstepGraphs(const SubstepGraphs&) = delete;
  SubstepGraphs& operator=(const SubstepGraphs&) = delete;

  // Queues one plain sub-step: its first view and report slots, then its
  // second view (IssueStep).
  void add(const State& kick, StatusRecord* rec, StatusRecord* next, const State& force);
  int queued() const { return len_; }
  bool full() const { return len_ == kMaxRun; }
  // Issues the queued sub-steps on the system's stream (nothing if none).
  void flush();

  long graph_launches = 0;  // graphs launched
  long graph_steps = 0;     // sub-steps run inside them
  long captures = 0;        // graphs captured (table misses)

 private:
  // Per queued step: every pointer and count its launches read (the
  // views' constants — box, walls, contact laws, dt, skin — are fixed for a
  // system's life, and the table is the system's).
  static constexpr int kWords = 2 * 20 + 2;
  using StepKey = std::array<std::uintptr_t, kWords>;
  struct Entry {
    int len = 0;
    long used = 0;
    void* exec = nullptr;  // cudaGraphExec_t
    std::vector<StepKey> key;  // kMaxRun slots, the first `len` in use
  };
  static void key_words(const State& s, std::uintptr_t* out);
  Entry* find();
  void capture(Entry& e);

  Exec ex_;
  bool friction_;
  IssueStep issue_;
  void* cap_stream_ = nullptr;  // cudaStream_t of the captures
  int len_ = 0;
  long clock_ = 0;
  std::array<State, kMaxRun> kick_{}, force_{};
  std::array<StatusRecord*, kMaxRun> rec_{}, next_{};
  std::vector<StepKey> queue_key_;  // kMaxRun slots
  std::vector<Entry> table_;        // kTable entries
};

}  // namespace lbdem::dem
