// RebuildScheduler: the report ring and the look-ahead decision
// (dem/README.md, "Rebuild decisions").
//
// The list built at state t_build holds every contact while no particle has
// moved more than skin/2 since. Before the step that produces state t, with
// the last report read at state t_k, the host bounds one particle's motion
// over the m = t - t_k steps since by
//   M(m) = S dt (m v + dt a m (m + 1) / 2)
// (constant acceleration a from speed v, S = lookahead_safety) and rebuilds
// when d + M(m) > skin/2, d the reported displacement, or, if the list was
// rebuilt at t_b >= t_k since, when M(m) - M(t_b - t_k) > skin/2. Which steps
// report and when each report is read depend only on the state and the
// advance() call lengths, never on timing, so both backends and repeated runs
// take the same decisions.
#include "rebuild_scheduler.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "format.hpp"
#include "kernels.hpp"

namespace lbdem::dem {

void RebuildScheduler::init(const Exec& e, bool ahead, double skin_m, double dt_s, double safety_factor) {
  if (!(safety_factor >= 1))
    throw ConfigError(fmtx("lookahead_safety: {} must be >= 1 (a factor on the predicted motion)", safety_factor));
  ex = e;
  lookahead = ahead;
  skin = skin_m;
  dt = dt_s;
  safety = safety_factor;
  status = Buffer<StatusRecord>(ex.backend(), kRing + 1);
  status.fill_zero(ex);
  if (ex.on_device()) {
#if defined(LBDEM_HAVE_CUDA)
    LBDEM_CUDA_CHECK(cudaMallocHost(reinterpret_cast<void**>(&mirror), sizeof(StatusRecord) * kRing));
    for (auto& ev : events) LBDEM_CUDA_CHECK(cudaEventCreateWithFlags(&ev, cudaEventDisableTiming));
#endif
  } else {
    mirror_host.resize(kRing);
    mirror = mirror_host.data();
  }
}

RebuildScheduler::~RebuildScheduler() {
#if defined(LBDEM_HAVE_CUDA)
  if (!mirror_host.empty() || !mirror) return;
  cudaFreeHost(mirror);
  for (auto& ev : events)
    if (ev) cudaEventDestroy(ev);
#endif
}

const StatusRecord& RebuildScheduler::wait_report(int s) {
  if (ex.on_device()) {
#if defined(LBDEM_HAVE_CUDA)
    const cudaError_t e = cudaEventQuery(events[s]);
    if (e == cudaErrorNotReady) {
      ++status_waits;
      LBDEM_CUDA_CHECK(cudaEventSynchronize(events[s]));
    } else {
      LBDEM_CUDA_CHECK(e);
    }
#endif
  }
  ++status_reads;
  return mirror[s];
}

// One collective per read: each rank puts its four values in its own slots
// of a zeroed vector and the element-wise sum (exact: one non-zero term per
// slot) hands every rank all of them; the maxima are then taken locally.
StatusRecord RebuildScheduler::global(const StatusRecord& r) {
  if (!comm || comm->size() <= 1) return r;
  const int nr = comm->size(), me = comm->rank();
  reduce_buf.assign(static_cast<std::size_t>(4 * nr), 0.0);
  double* mine = reduce_buf.data() + 4 * me;
  mine[0] = r.disp2; mine[1] = r.speed2; mine[2] = r.accel2; mine[3] = r.over2;
  comm->sum(std::span<double>(reduce_buf));
  StatusRecord g{};
  for (int q = 0; q < nr; ++q) {
    const double* v = reduce_buf.data() + 4 * q;
    g.disp2 = std::max(g.disp2, static_cast<std::uint32_t>(v[0]));
    g.speed2 = std::max(g.speed2, static_cast<std::uint32_t>(v[1]));
    g.accel2 = std::max(g.accel2, static_cast<std::uint32_t>(v[2]));
    g.over2 = std::max(g.over2, static_cast<std::uint32_t>(v[3]));
  }
  return g;
}

RebuildScheduler::Pending RebuildScheduler::pop_front() {
  const Pending p = pending[0];
  for (int k = 1; k < npending; ++k) pending[k - 1] = pending[k];
  --npending;
  return p;
}

std::string RebuildScheduler::stale_message(const Pending& p, std::uint32_t over2) const {
  return fmtx("DEM neighbour list went stale between steps {} and {}: a particle moved {} m since the list was "
              "built, more than skin/2 = {} m (skin {} m), at a step where the rebuild look-ahead (largest "
              "speed and acceleration of the last report x lookahead_safety = {}) predicted it would not; "
              "contacts of those steps may have been missed. A force or collision changed a particle's "
              "speed faster than the bound: raise DemParams::lookahead_safety, or the skin (larger skin, "
              "more slack per rebuild), or lower dt (or the DEM sub-steps per advance() call); "
              "rebuild_check = every_step tests every step exactly at one blocking read per step. "
              "rebuild() clears this error.",
              p.from, p.t, std::sqrt(detail::from_float_bits(over2)), 0.5 * skin, skin, safety);
}

// Reads the oldest pending report (Lookahead): the stale check, then the
// known state and the report interval it implies.
void RebuildScheduler::read_front() {
  const Pending p = pop_front();
  const StatusRecord r = global(wait_report(p.slot));
  if (r.over2 != 0) {
    stale_error = stale_message(p, r.over2);
    throw DivergenceError(stale_error);
  }
  known = true;
  t_known = p.t;
  d_known = std::sqrt(detail::from_float_bits(r.disp2));
  v_known = std::sqrt(detail::from_float_bits(r.speed2));
  a_known = std::sqrt(detail::from_float_bits(r.accel2));
  // Report every k = n/8 steps (clamped to 1..kMaxReportEvery), n the steps
  // in which a particle at the bounded speed S (v + kMaxReportEvery dt a)
  // crosses skin/2: then m < n/4, and a rebuild comes at most about 1/8 of
  // its interval earlier than the exact test would call it.
  const double S = safety;
  const double per_step = S * dt * (v_known + dt * a_known * kMaxReportEvery);
  const double cross = per_step > 0 ? 0.5 * skin / per_step : 1e30;
  report_every = static_cast<int>(std::clamp(cross / 8.0, 1.0, static_cast<double>(kMaxReportEvery)));
}

void RebuildScheduler::take_report(long t, long due) {
  const int s = static_cast<int>(reports % kRing);
  // The oldest pending report may still sit in this mirror slot (not with the
  // report schedule of DemSystem::advance, which keeps at most two pending):
  // read it first.
  if (npending == kRing) read_front();
  if (ex.on_device()) {
#if defined(LBDEM_HAVE_CUDA)
    LBDEM_CUDA_CHECK(cudaMemcpyAsync(mirror + s, status.data() + s, sizeof(StatusRecord), cudaMemcpyDeviceToHost,
                                     ex.stream()));
    LBDEM_CUDA_CHECK(cudaEventRecord(events[s], ex.stream()));
#endif
  } else {
    mirror[s] = status.data()[s];
  }
  pending[npending++] = Pending{t_last_report + 1, t, due, s};
  t_last_report = t;
  ++reports;
}

void RebuildScheduler::zero_slot(long q) {
  ex.synchronize();
  backend_memset_on(ex, slot(q), 0, sizeof(StatusRecord));
}

void RebuildScheduler::initial_report(const State& st, Index count, long step) {
  launch(ex, count, Report{st, slot(reports), slot(reports + 1)});
  if (count == 0) {
    zero_slot(reports);
    zero_slot(reports + 1);
  }
  take_report(step, step);
  while (npending > 0) read_front();
}

bool RebuildScheduler::exact_check(long t) {
  take_report(t, t);
  const Pending p = pop_front();
  return global(wait_report(p.slot)).over2 != 0;
}

// Bound on one particle's motion over the k steps after the known state [m].
double RebuildScheduler::motion_bound(long k) const {
  const double kk = static_cast<double>(k);
  return safety * dt * (kk * v_known + 0.5 * dt * a_known * kk * (kk + 1));
}

// Largest displacement since the build that state t could have.
double RebuildScheduler::predicted_displacement(long t) const {
  if (t_build >= t_known) return motion_bound(t - t_known) - motion_bound(t_build - t_known);
  return d_known + motion_bound(t - t_known);
}

void RebuildScheduler::reset() {
  ex.synchronize();
  npending = 0;
  status.fill_zero(ex);
  known = false;
  stale_error.clear();
}

void RebuildScheduler::check_arrived() {
  // A decomposed run learns of a stale list at the next (reduced) read, on
  // every rank at once: one rank alone must not throw here.
  if (!lookahead || !stale_error.empty() || (comm && comm->size() > 1)) return;
  for (int k = 0; k < npending; ++k) {
    const std::uint32_t over2 = mirror[pending[k].slot].over2;
    if (over2 != 0) {
      stale_error = stale_message(pending[k], over2);
      throw DivergenceError(stale_error);
    }
  }
}

}  // namespace lbdem::dem
