// Checkpoint state of a DemSystem (DemSystem::save_state / load_state): what
// the next advance() reads besides the set-up, stored raw so that a restarted
// system takes the same steps, rebuild decisions and sums, bit for bit.
//
// Not stored, because a system constructed from the same case rebuilds it
// identically or every step rewrites it before reading: the cell grid and
// the cell sort (each build starts afresh), the reorder targets, the previous
// Verlet list (the current one becomes it at the next build), the pair path's
// compacted pairs (rebuilt at every force evaluation).
//
// A decomposed system stores its rank's records (owned, then ghosts) and the
// ghost bookkeeping of the last build (which ids went to and came from each
// neighbour rank), from which load_state() rebinds the per-step refresh: a
// run of the same decomposition continues bit for bit. For another
// decomposition, saved_particles() turns a stored section into portable
// records of the owned particles (the list rows by partner global id) and
// restore_particles() rebuilds a system from them.
#include <algorithm>
#include <cstring>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "domain_exchange.hpp"
#include "system_impl.hpp"

namespace lbdem::dem {

namespace {
constexpr std::uint32_t kTagDem = 0x44454d31;       // "DEM1": the layout of this section
constexpr std::uint32_t kTagDemRanks = 0x44454d52;  // "DEMR": the same for one rank of a decomposed system
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

void DomainExchange::save_state(ckpt::Sink& out) const {
  out.put<std::uint64_t>(peers.size());
  for (int p : peers) out.put<std::int32_t>(p);
  for (const auto* lists : {&sent, &received})
    for (const auto& ids : *lists) out.put_vector(ids);
  for (long v : migrations) out.put<std::int64_t>(v);
  out.put<std::int64_t>(migrations_periodic);
}

void DomainExchange::load_state(ckpt::Source& in) {
  in.expect<std::uint64_t>(peers.size(), "the number of neighbour ranks of the DEM piece");
  for (int p : peers) in.expect<std::int32_t>(p, "a neighbour rank of the DEM piece");
  for (auto* lists : {&sent, &received}) {
    lists->assign(peers.size(), {});
    for (auto& ids : *lists) ids = in.get_vector<std::int64_t>(std::uint64_t{1} << 32);
  }
  for (long& v : migrations) v = in.get<std::int64_t>();
  migrations_periodic = in.get<std::int64_t>();
}

void DemSystem::save_state(ckpt::Sink& out) const {
  const Impl& m = *impl_;
  m.ex.synchronize();
  impl_->sched.check_arrived();  // a stale list reported meanwhile is not saved as good state
  const ParticleStore& s = m.store;
  // One rank: whole buffers (the layout one-rank checkpoints have always
  // had). Decomposed: the n records held (the buffers keep head room).
  const bool dec = m.decomposed();
  out.put<std::uint32_t>(dec ? kTagDemRanks : kTagDem);
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
    if (dec) out.put_buffer(*b, b->size() > 0 ? s.n : 0);
    else out.put_buffer(*b);
  if (dec) {
    out.put_buffer(s.gid, s.n);
    out.put_buffer(s.type, s.n);
    out.put_buffer(s.whist, s.n * s.layout.wall_histories);
  } else {
    out.put_buffer(s.gid);
    out.put_buffer(s.type);
    out.put_buffer(s.whist);
  }
  m.lists.save_state(out);
  m.sched.save_state(out);
  if (dec) m.domain->save_state(out);
}

void DemSystem::load_state(ckpt::Source& in) {
  Impl& m = *impl_;
  m.ex.synchronize();
  ParticleStore& s = m.store;
  const bool dec = m.decomposed();
  in.expect<std::uint32_t>(dec ? kTagDemRanks : kTagDem,
                           dec ? "the DEM state's layout tag (a piece of a decomposed run)" : "the DEM state's layout tag");
  const auto n = in.get<std::int64_t>(), n_owned = in.get<std::int64_t>();
  if (dec) {
    if (n_owned < 0 || n < n_owned || n > (std::int64_t{1} << 30)) in.mismatch("a DEM piece of out-of-range size");
  } else {
    if (n != s.n) in.mismatch("the particle count differs from this run's");
    if (n_owned != s.n_owned) in.mismatch("the owned particle count differs from this run's");
  }
  in.expect<std::uint8_t>(s.layout.rotation, "the rotation flag (friction)");
  in.expect<std::uint8_t>(s.layout.external_forcing, "the external-forcing flag (coupling)");
  in.expect<std::int32_t>(s.layout.wall_histories, "the number of walls with tangential histories");
  m.steps = in.get<std::int64_t>();
  m.rebuilds = in.get<std::int64_t>();
  m.time = in.get<double>();
  m.forces_valid = in.get<std::uint8_t>() != 0;
  m.old_valid = in.get<std::uint8_t>() != 0;
  if (dec) {
    // Room for the piece's records (and the reorder twins), then its arrays.
    HostState h;
    h.resize(n, s.layout);
    h.n_owned = n_owned;
    s.load(m.ex.backend(), h);
    for (Buffer<Real4>* b : {&s.pos, &s.vel, &s.omg, &s.frc, &s.trq, &s.frco, &s.trqo, &s.vpr, &s.wpr, &s.extf,
                             &s.extt, &s.x0})
      in.get_buffer(*b, b->size() > 0 ? n : 0);
    in.get_buffer(s.gid, n);
    in.get_buffer(s.type, n);
    in.get_buffer(s.whist, n * s.layout.wall_histories);
    m.lists.resize(m.ex.backend(), n);
  } else {
    for (Buffer<Real4>* b : {&s.pos, &s.vel, &s.omg, &s.frc, &s.trq, &s.frco, &s.trqo, &s.vpr, &s.wpr, &s.extf,
                             &s.extt, &s.x0})
      in.get_buffer(*b);
    in.get_buffer(s.gid);
    in.get_buffer(s.type);
    in.get_buffer(s.whist);
  }
  m.lists.load_state(in, m.ex.backend());
  m.sched.load_state(in);
  if (dec) {
    m.domain->load_state(in);
    m.domain->bind_refresh(m);
  }
  m.ex.synchronize();
}

// ---------------------------------------------------------------------------
// Another decomposition: portable particle records
// ---------------------------------------------------------------------------
namespace {

// The fixed part of a record; then wall histories (Vec3d each) and the list
// row (RowEntry each).
struct ParticleRecord {
  Real4 a[11];  // pos vel omg frc trq frco trqo vpr wpr extf extt
  std::int64_t gid;
  std::int32_t type;
  std::int32_t nrow;
};
// Reads a stored array (count, then count values) into v (count at most max).
template <class T>
void read_array(ckpt::Source& in, std::vector<T>& v, std::uint64_t max) { v = in.get_vector<T>(max); }

// Record k of `buf` (the offsets of each record's start).
std::vector<std::size_t> record_offsets(const std::vector<std::byte>& buf, int nw) {
  std::vector<std::size_t> off;
  std::size_t at = 0;
  while (at < buf.size()) {
    off.push_back(at);
    const auto r = take_pod<ParticleRecord>(buf, at);
    at += static_cast<std::size_t>(nw) * sizeof(Vec3d) + static_cast<std::size_t>(r.nrow) * sizeof(RowEntry);
    if (r.nrow < 0 || at > buf.size()) throw Error("DEM restart: a particle record cut short");
  }
  return off;
}

}  // namespace

DemSystem::SavedCounters DemSystem::saved_particles(ckpt::Source& in, std::vector<std::byte>& out) const {
  const Impl& m = *impl_;
  const StoreLayout& lay = m.store.layout;
  const auto tag = in.get<std::uint32_t>();
  if (tag != kTagDem && tag != kTagDemRanks) in.mismatch("the DEM state's layout tag");
  const bool dec = tag == kTagDemRanks;
  const auto n = in.get<std::int64_t>(), no = in.get<std::int64_t>();
  if (no < 0 || n < no || n > (std::int64_t{1} << 30)) in.mismatch("a DEM state of out-of-range size");
  in.expect<std::uint8_t>(lay.rotation, "the rotation flag (friction)");
  in.expect<std::uint8_t>(lay.external_forcing, "the external-forcing flag (coupling)");
  in.expect<std::int32_t>(lay.wall_histories, "the number of walls with tangential histories");
  SavedCounters c;
  c.steps = in.get<std::int64_t>();
  c.rebuilds = in.get<std::int64_t>();
  c.time = in.get<double>();
  c.forces_valid = in.get<std::uint8_t>();
  c.old_valid = in.get<std::uint8_t>();
  const std::uint64_t cap = std::uint64_t{1} << 32;
  std::vector<Real4> a[12];
  for (auto& v : a) {
    read_array(in, v, cap);
    if (!v.empty() && v.size() < static_cast<std::size_t>(n)) in.mismatch("a particle array shorter than its records");
  }
  std::vector<std::int64_t> gid;
  std::vector<int> type;
  std::vector<Vec3d> whist;
  read_array(in, gid, cap);
  read_array(in, type, cap);
  read_array(in, whist, cap);
  const int nw = lay.wall_histories;
  if (gid.size() < static_cast<std::size_t>(n) || type.size() < static_cast<std::size_t>(n) ||
      whist.size() < static_cast<std::size_t>(n) * static_cast<std::size_t>(nw))
    in.mismatch("particle arrays shorter than their records");
  // The neighbour list (NeighbourList::save_state): rows of the owned particles.
  const auto ln = in.get<std::int64_t>();
  in.get<std::int64_t>();  // rows
  const auto lcap = in.get<std::int32_t>();
  in.expect<std::uint8_t>(m.lists.history, "the tangential-history flag (friction)");
  in.get<std::uint8_t>();
  const bool have_list = in.get<std::uint8_t>() != 0;
  if (ln != n || lcap < 1) in.mismatch("a neighbour list of another size than its particles");
  std::vector<int> count, nb;
  std::vector<Vec3d> hs;
  read_array(in, count, static_cast<std::uint64_t>(n));
  read_array(in, nb, cap);
  read_array(in, hs, cap);
  std::vector<int> flags;
  read_array(in, flags, 2);
  const std::size_t slots = have_list ? static_cast<std::size_t>(n) * static_cast<std::size_t>(lcap) : 0;
  if (nb.size() != slots || (m.lists.history && hs.size() != slots)) in.mismatch("a neighbour list of another size");
  // The rebuild scheduler (RebuildScheduler::save_state): its decisions start afresh at the load's build.
  in.get<std::uint8_t>();
  in.get<std::uint8_t>();
  in.get<std::int32_t>();
  for (int k = 0; k < 3; ++k) in.get<std::int64_t>();
  in.get<std::int32_t>();
  for (int k = 0; k < RebuildScheduler::kRing; ++k) {
    in.get<std::int64_t>();
    in.get<std::int64_t>();
    in.get<std::int64_t>();
    in.get<std::int32_t>();
  }
  in.get<std::int64_t>();
  for (int k = 0; k < 3; ++k) in.get<double>();
  in.get<std::int64_t>();
  std::vector<StatusRecord> status;
  read_array(in, status, 64);
  for (int k = 0; k < RebuildScheduler::kRing; ++k) in.get<StatusRecord>();
  if (dec) {
    // DomainExchange::save_state: not needed (the ghosts are rebuilt at the load).
    const auto np = in.get<std::uint64_t>();
    if (np > (1u << 20)) in.mismatch("a neighbour-rank count out of range");
    for (std::uint64_t k = 0; k < np; ++k) in.get<std::int32_t>();
    for (std::uint64_t k = 0; k < 2 * np; ++k) in.get_vector<std::int64_t>(cap);
    for (int k = 0; k < 4; ++k) in.get<std::int64_t>();
  }
  const Real4 zero{0, 0, 0, 0};
  for (std::int64_t i = 0; i < no; ++i) {
    const auto u = static_cast<std::size_t>(i);
    ParticleRecord r{};
    for (int k = 0; k < 11; ++k) r.a[k] = a[k].empty() ? zero : a[k][u];
    r.gid = gid[u];
    r.type = type[u];
    r.nrow = 0;
    std::vector<RowEntry> row;
    if (have_list && m.lists.history) {
      const int cnt = count[u];
      if (cnt < 0 || cnt > lcap) in.mismatch("a neighbour-list row out of range");
      for (int q = 0; q < cnt; ++q) {
        const std::size_t sl = static_cast<std::size_t>(q) * static_cast<std::size_t>(n) + u;
        const int j = nb[sl];
        if (j < 0 || j >= n) in.mismatch("a neighbour-list partner out of range");
        row.push_back({gid[static_cast<std::size_t>(j)], hs[sl]});
      }
    }
    r.nrow = static_cast<std::int32_t>(row.size());
    append_pod(out, r);
    for (int w = 0; w < nw; ++w) append_pod(out, whist[static_cast<std::size_t>(w) * static_cast<std::size_t>(n) + u]);
    for (const RowEntry& e : row) append_pod(out, e);
  }
  return c;
}

std::vector<std::byte> DemSystem::select_particles(const std::vector<std::byte>& records) const {
  const Impl& m = *impl_;
  const int nw = m.store.layout.wall_histories;
  const auto off = record_offsets(records, nw);
  std::vector<std::byte> mine;
  for (std::size_t k = 0; k < off.size(); ++k) {
    std::size_t at = off[k];
    const auto r = take_pod<ParticleRecord>(records, at);
    if (m.decomposed() && m.domain->dom.owner(xyz(r.a[0])) != m.domain->dom.rank()) continue;
    const std::size_t end = k + 1 < off.size() ? off[k + 1] : records.size();
    mine.insert(mine.end(), records.begin() + static_cast<std::ptrdiff_t>(off[k]),
                records.begin() + static_cast<std::ptrdiff_t>(end));
  }
  return mine;
}

void DemSystem::restore_particles(const std::vector<std::byte>& mine, const SavedCounters& c) {
  Impl& m = *impl_;
  m.ex.synchronize();
  ParticleStore& s = m.store;
  NeighbourList& nl = m.lists;
  const Backend be = m.ex.backend();
  const StoreLayout lay = s.layout;
  const int nw = lay.wall_histories;
  // The records by global id (a fixed order whatever the old decomposition).
  auto off = record_offsets(mine, nw);
  std::vector<std::pair<std::int64_t, std::size_t>> order;
  for (std::size_t at : off) {
    std::size_t t = at;
    order.emplace_back(take_pod<ParticleRecord>(mine, t).gid, at);
  }
  std::sort(order.begin(), order.end());
  for (std::size_t k = 1; k < order.size(); ++k)
    if (order[k].first == order[k - 1].first)
      throw ConfigError("--restart: particle " + std::to_string(order[k].first) + " is stored twice in the checkpoint");
  const auto n_own = static_cast<Index>(order.size());
  // Partners named by the rows that are not owned here: placeholder records
  // behind the owned ones, so that a row can name them by index (the build
  // that follows replaces them by the ghosts; redistribution reads only
  // their ids).
  std::unordered_map<std::int64_t, int> at;
  for (Index i = 0; i < n_own; ++i) at.emplace(order[static_cast<std::size_t>(i)].first, static_cast<int>(i));
  std::vector<std::int64_t> extra;
  std::vector<ParticleRecord> recs;
  std::vector<std::vector<RowEntry>> rows;
  std::vector<Vec3d> wh;
  for (const auto& [g, o] : order) {
    std::size_t t = o;
    recs.push_back(take_pod<ParticleRecord>(mine, t));
    for (int w = 0; w < nw; ++w) wh.push_back(take_pod<Vec3d>(mine, t));
    rows.emplace_back();
    for (int e = 0; e < recs.back().nrow; ++e) {
      rows.back().push_back(take_pod<RowEntry>(mine, t));
      const std::int64_t pg = rows.back().back().gid;
      if (!at.count(pg)) {
        at.emplace(pg, static_cast<int>(n_own + static_cast<Index>(extra.size())));
        extra.push_back(pg);
      }
    }
  }
  const Index n = n_own + static_cast<Index>(extra.size());
  HostState h;
  h.resize(n, lay);
  h.n_owned = n_own;
  const Real4 zero{0, 0, 0, 0};
  for (Index i = 0; i < n; ++i) {
    const auto u = static_cast<std::size_t>(i);
    if (i < n_own) {
      const ParticleRecord& r = recs[u];
      h.pos[u] = r.a[0]; h.vel[u] = r.a[1]; h.omg[u] = r.a[2]; h.frc[u] = r.a[3]; h.trq[u] = r.a[4];
      h.frco[u] = r.a[5]; h.trqo[u] = r.a[6]; h.vpr[u] = r.a[7];
      if (lay.rotation) h.wpr[u] = r.a[8];
      if (lay.external_forcing) { h.extf[u] = r.a[9]; h.extt[u] = r.a[10]; }
      h.gid[u] = r.gid;
      h.type[u] = r.type;
      for (int w = 0; w < nw; ++w) h.whist[static_cast<std::size_t>(w) * static_cast<std::size_t>(n) + u] = wh[u * static_cast<std::size_t>(nw) + static_cast<std::size_t>(w)];
    } else {
      // A placeholder: its id; its position that of the first owned record (any position in the box will do).
      h.pos[u] = n_own > 0 ? recs[0].a[0] : zero;
      h.vel[u] = h.omg[u] = h.frc[u] = h.trq[u] = h.frco[u] = h.trqo[u] = h.vpr[u] = zero;
      h.vel[u].w = 1;
      if (lay.rotation) h.wpr[u] = zero;
      if (lay.external_forcing) h.extf[u] = h.extt[u] = zero;
      h.gid[u] = extra[static_cast<std::size_t>(i - n_own)];
      h.type[u] = 0;
    }
  }
  s.load(be, h);
  nl.resize(be, n);
  // The rows as the current list (partners by index), which the build that
  // follows hands over by partner id.
  if (nl.history && nl.has_list()) {
    int cap = nl.cap;
    for (const auto& r : rows) cap = std::max(cap, static_cast<int>(r.size()));
    nl.cap = cap;
    const std::size_t slots = static_cast<std::size_t>(n) * static_cast<std::size_t>(cap);
    std::vector<int> cnt(static_cast<std::size_t>(n), 0), nb(slots, 0);
    std::vector<Vec3d> hs(slots);
    for (Index i = 0; i < n_own; ++i) {
      const auto& r = rows[static_cast<std::size_t>(i)];
      cnt[static_cast<std::size_t>(i)] = static_cast<int>(r.size());
      for (std::size_t q = 0; q < r.size(); ++q) {
        const std::size_t sl = q * static_cast<std::size_t>(n) + static_cast<std::size_t>(i);
        nb[sl] = at.at(r[q].gid);
        hs[sl] = r[q].h;
      }
    }
    nl.nbr.reserve_discard(be, static_cast<Index>(slots));
    nl.hist.reserve_discard(be, static_cast<Index>(slots));
    if (n > 0) nl.ncount.copy_from_host(cnt.data(), n);
    if (slots > 0) {
      nl.nbr.copy_from_host(nb.data(), static_cast<Index>(slots));
      nl.hist.copy_from_host(hs.data(), static_cast<Index>(slots));
    }
  }
  m.steps = c.steps;
  m.time = c.time;
  m.sched.reset();
  m.sched.known = false;
  rebuild();
  m.rebuilds = c.rebuilds;
  m.forces_valid = c.forces_valid != 0;
  m.old_valid = c.old_valid != 0;
  m.ex.synchronize();
}

}  // namespace lbdem::dem
