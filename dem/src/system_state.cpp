// Checkpoint state of a DemSystem (DemSystem::save_state / load_state): what
// the next advance() reads besides the set-up, stored raw so that a restarted
// system takes the same steps, rebuild decisions and sums, bit for bit.
//
// Not stored, because a system constructed from the same case rebuilds it
// identically or every step rewrites it before reading: the cell grid and
// the cell sort (each build starts afresh), the reorder targets, the previous
// Verlet list (the current one becomes it at the next build), the pair path's
// compacted pairs (rebuilt at every force evaluation).
#include <vector>

#include "core/error.hpp"
#include "system_impl.hpp"

namespace lbdem::dem {

namespace {
constexpr std::uint32_t kTagDem = 0x44454d31;  // "DEM1": the layout of this section
}

void NeighbourList::save_state(ckpt::Sink& out) const {
  out.put<std::int64_t>(n);
  out.put<std::int64_t>(rows);
  out.put<std::int32_t>(cap);
  out.put<std::uint8_t>(history);
  out.put<std::uint8_t>(have_prev);
  out.put<std::uint8_t>(have_list);
  out.put_buffer(ncount, n);
  // The slots beyond a row's count were never written (their bytes are
  // whatever the allocation held): stored as zeros, so that two runs in the
  // same state write the same file.
  const Index slots = have_list ? n * cap : 0;
  std::vector<int> count(static_cast<std::size_t>(n)), nb(static_cast<std::size_t>(slots));
  std::vector<Vec3d> hs(history ? static_cast<std::size_t>(slots) : 0);
  if (n > 0) ncount.copy_to_host(count.data(), n);
  if (slots > 0) {
    nbr.copy_to_host(nb.data(), slots);
    if (history) hist.copy_to_host(hs.data(), slots);
  }
  for (Index s = 0; s < cap && slots > 0; ++s)
    for (Index i = 0; i < n; ++i)
      if (s >= count[static_cast<std::size_t>(i)]) {
        nb[static_cast<std::size_t>(s * n + i)] = 0;
        if (history) hs[static_cast<std::size_t>(s * n + i)] = Vec3d{};
      }
  out.put<std::uint64_t>(static_cast<std::uint64_t>(slots));
  if (slots > 0) out.write(nb.data(), nb.size() * sizeof(int));
  out.put<std::uint64_t>(static_cast<std::uint64_t>(hs.size()));
  if (!hs.empty()) out.write(hs.data(), hs.size() * sizeof(Vec3d));
  out.put_buffer(flags, 2);
}

void NeighbourList::load_state(ckpt::Source& in, Backend be) {
  in.expect<std::int64_t>(n, "the particle count of the neighbour list");
  const auto r = in.get<std::int64_t>();
  const auto c = in.get<std::int32_t>();
  if (r < 0 || r > n || c < 1 || c > (1 << 24)) in.mismatch("a neighbour list of " + std::to_string(r) + " rows and capacity " + std::to_string(c));
  in.expect<std::uint8_t>(history, "the tangential-history flag (friction)");
  const bool prev = in.get<std::uint8_t>() != 0, list = in.get<std::uint8_t>() != 0;
  rows = r;
  cap = c;
  in.get_buffer(ncount, n);
  if (list) {
    nbr.reserve_discard(be, n * cap);
    if (history) hist.reserve_discard(be, n * cap);
    if (pair_path) pairs.reserve_discard(be, n * cap / 2 + 1);
  }
  in.get_buffer(nbr, list ? n * cap : 0);
  in.get_buffer(hist, list && history ? n * cap : 0);
  in.get_buffer(flags, 2);
  have_prev = prev;
  have_list = list;
  prev_loaded = false;
}

void RebuildScheduler::save_state(ckpt::Sink& out) const {
  ex.synchronize();
  out.put<std::uint8_t>(lookahead);
  out.put<std::uint8_t>(known);
  out.put<std::int32_t>(report_every);
  out.put<std::int64_t>(reports);
  out.put<std::int64_t>(t_last_report);
  out.put<std::int64_t>(status_reads);
  // status_waits is left out: it counts reads that found the device not yet
  // done, which depends on timing, and a checkpoint holds state only.
  out.put<std::int32_t>(npending);
  for (const Pending& p : pending) {  // field by field: no padding bytes in the file
    out.put<std::int64_t>(p.from);
    out.put<std::int64_t>(p.t);
    out.put<std::int64_t>(p.due);
    out.put<std::int32_t>(p.slot);
  }
  out.put<std::int64_t>(t_known);
  out.put<double>(d_known);
  out.put<double>(v_known);
  out.put<double>(a_known);
  out.put<std::int64_t>(t_build);
  out.put_buffer(status);
  for (int k = 0; k < kRing; ++k) out.put(mirror[k]);
}

void RebuildScheduler::load_state(ckpt::Source& in) {
  ex.synchronize();
  in.expect<std::uint8_t>(lookahead, "the rebuild check (dem rebuild_check)");
  known = in.get<std::uint8_t>() != 0;
  report_every = in.get<std::int32_t>();
  reports = in.get<std::int64_t>();
  t_last_report = in.get<std::int64_t>();
  status_reads = in.get<std::int64_t>();
  npending = in.get<std::int32_t>();
  if (npending < 0 || npending > kRing || report_every < 1 || report_every > kMaxReportEvery || reports < 0)
    in.mismatch("a rebuild-scheduler state out of range");
  for (Pending& p : pending) {
    p.from = in.get<std::int64_t>();
    p.t = in.get<std::int64_t>();
    p.due = in.get<std::int64_t>();
    p.slot = in.get<std::int32_t>();
  }
  for (int k = 0; k < npending; ++k)
    if (pending[k].slot < 0 || pending[k].slot >= kRing) in.mismatch("a report slot out of range");
  t_known = in.get<std::int64_t>();
  d_known = in.get<double>();
  v_known = in.get<double>();
  a_known = in.get<double>();
  t_build = in.get<std::int64_t>();
  in.get_buffer(status);
  for (int k = 0; k < kRing; ++k) mirror[k] = in.get<StatusRecord>();
  stale_error.clear();
}

void DemSystem::save_state(ckpt::Sink& out) const {
  const Impl& m = *impl_;
  if (m.decomposed())
    throw ConfigError("checkpoint: a DEM system decomposed over several ranks cannot be checkpointed yet; run on one "
                      "rank or leave the checkpoint section out");
  m.ex.synchronize();
  impl_->sched.check_arrived();  // a stale list reported meanwhile is not saved as good state
  const ParticleStore& s = m.store;
  out.put<std::uint32_t>(kTagDem);
  out.put<std::int64_t>(s.n);
  out.put<std::int64_t>(s.n_owned);
  out.put<std::uint8_t>(s.layout.rotation);
  out.put<std::uint8_t>(s.layout.external_forcing);
  out.put<std::int32_t>(s.layout.wall_histories);
  out.put<std::int64_t>(m.steps);
  out.put<std::int64_t>(m.rebuilds);
  out.put<double>(m.time);
  out.put<std::uint8_t>(m.forces_valid);
  out.put<std::uint8_t>(m.old_valid);
  for (const Buffer<Real4>* b : {&s.pos, &s.vel, &s.omg, &s.frc, &s.trq, &s.frco, &s.trqo, &s.vpr, &s.wpr, &s.extf,
                                 &s.extt, &s.x0})
    out.put_buffer(*b);
  out.put_buffer(s.gid);
  out.put_buffer(s.type);
  out.put_buffer(s.whist);
  m.lists.save_state(out);
  m.sched.save_state(out);
}

void DemSystem::load_state(ckpt::Source& in) {
  Impl& m = *impl_;
  if (m.decomposed())
    throw ConfigError("--restart: a DEM system decomposed over several ranks cannot be restarted yet; run on one rank");
  m.ex.synchronize();
  ParticleStore& s = m.store;
  in.expect<std::uint32_t>(kTagDem, "the DEM state's layout tag");
  in.expect<std::int64_t>(s.n, "the particle count");
  in.expect<std::int64_t>(s.n_owned, "the owned particle count");
  in.expect<std::uint8_t>(s.layout.rotation, "the rotation flag (friction)");
  in.expect<std::uint8_t>(s.layout.external_forcing, "the external-forcing flag (coupling)");
  in.expect<std::int32_t>(s.layout.wall_histories, "the number of walls with tangential histories");
  m.steps = in.get<std::int64_t>();
  m.rebuilds = in.get<std::int64_t>();
  m.time = in.get<double>();
  m.forces_valid = in.get<std::uint8_t>() != 0;
  m.old_valid = in.get<std::uint8_t>() != 0;
  for (Buffer<Real4>* b : {&s.pos, &s.vel, &s.omg, &s.frc, &s.trq, &s.frco, &s.trqo, &s.vpr, &s.wpr, &s.extf, &s.extt,
                           &s.x0})
    in.get_buffer(*b);
  in.get_buffer(s.gid);
  in.get_buffer(s.type);
  in.get_buffer(s.whist);
  m.lists.load_state(in, m.ex.backend());
  m.sched.load_state(in);
  m.ex.synchronize();
}

}  // namespace lbdem::dem
