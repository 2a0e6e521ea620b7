// DomainExchange: migration, ghost rebuild and ghost refresh of a decomposed
// DemSystem (dem/README.md, "Many ranks").
#include "domain_exchange.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "core/error.hpp"
#include "format.hpp"
#include "state.hpp"
#include "system_impl.hpp"

namespace lbdem::dem {

// Refresh records: position, predicted velocity and (with rotation) predicted
// angular velocity of owned particle idx[k] into buf[k * per ...].
struct GhostPack {
  const int* idx;
  const Real4 *pos, *vpr, *wpr;
  Real4* buf;
  int per;
  LBDEM_HD void operator()(Index k) const {
    const int i = idx[k];
    Real4* b = buf + k * per;
    b[0] = pos[i];
    b[1] = vpr[i];
    if (per == 3) b[2] = wpr[i];
  }
};

// The records into the ghost copies (store index idx[k]).
struct GhostUnpack {
  const int* idx;
  Real4 *pos, *vpr, *wpr;
  const Real4* buf;
  int per;
  LBDEM_HD void operator()(Index k) const {
    const int i = idx[k];
    const Real4* b = buf + k * per;
    pos[i] = b[0];
    vpr[i] = b[1];
    if (per == 3) wpr[i] = b[2];
  }
};

// A ghost's coupling input (force, torque) into the return buffer.
struct CouplingPack {
  const int* idx;
  const Real4 *extf, *extt;
  Real4* buf;
  LBDEM_HD void operator()(Index k) const {
    const int i = idx[k];
    buf[2 * k] = extf[i];
    buf[2 * k + 1] = extt[i];
  }
};

// One peer's shares added to the owned particles' coupling input.
struct CouplingAdd {
  const int* idx;
  Real4 *extf, *extt;
  const Real4* buf;
  LBDEM_HD void operator()(Index k) const {
    const int i = idx[k];
    const Real4 f = buf[2 * k], t = buf[2 * k + 1];
    extf[i].x += f.x;
    extf[i].y += f.y;
    extf[i].z += f.z;
    extt[i].x += t.x;
    extt[i].y += t.y;
    extt[i].z += t.z;
  }
};

namespace {

constexpr int kTagMigrate = 1, kTagGhost = 2, kTagRefresh = 3, kTagCoupling = 4;

// A migrating particle: every per-particle array, then (variable part) its
// wall histories and its list row as (partner global id, tangential history).
struct Migrant {
  Real4 a[11];  // pos vel omg frc trq frco trqo vpr wpr extf extt
  std::int64_t gid;
  int type;
  int nrow;
};
// A ghost copy: what the force loop reads of a partner.
struct GhostRecord {
  Real4 pos, vpr, wpr;
  std::int64_t gid;
  int type;
  int pad;
};
// Per-particle list rows on the host: entries [off[i], off[i + 1]).
struct Rows {
  std::vector<std::size_t> off{0};
  std::vector<RowEntry> e;
};

}  // namespace

void DomainExchange::init(const DemDomain& d, const Box& b, double w, const Exec& e, bool coupling) {
  dom = d;
  box = b;
  width = w;
  ex = e;
  const int me = dom.rank();
  const auto& dims = dom.dec.dims;
  if (dom.dec.ranks() != dom.comm->size())
    throw ConfigError(fmtx("decomposition: {} pieces for {} ranks", dom.dec.ranks(), dom.comm->size()));
  for (int a = 0; a < 3; ++a) {
    const auto& c = dom.cuts[static_cast<std::size_t>(a)];
    const int n = dims[static_cast<std::size_t>(a)];
    if (static_cast<int>(c.size()) != n + 1)
      throw ConfigError(fmtx("decomposition: axis {} has {} pieces but {} cut positions (need {})", a, n, c.size(), n + 1));
    if (n == 1) continue;
    for (int i = 0; i < n; ++i) {
      const double t = c[static_cast<std::size_t>(i) + 1] - c[static_cast<std::size_t>(i)];
      if (!(t >= w))
        throw ConfigError(fmtx("decomposition: piece {} of {} along axis {} is {} m thick, thinner than the DEM ghost "
                               "width 2 r_max + skin = {} m (a particle's contact partners must lie in the "
                               "neighbouring pieces): use fewer ranks along axis {}, a smaller skin, or a larger box",
                               i, n, a, t, w, a));
    }
  }
  // Neighbour ranks: the 26 pieces around this one (periodic wrap), each once.
  const auto c = dom.dec.coords(me);
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        std::array<int, 3> q{c[0] + dx, c[1] + dy, c[2] + dz};
        bool ok = true;
        for (std::size_t a = 0; a < 3; ++a) {
          if (q[a] < 0 || q[a] >= dims[a]) {
            if (!box.periodic[a]) ok = false;
            q[a] = (q[a] + dims[a]) % dims[a];
          }
        }
        if (!ok) continue;
        const int r = dom.dec.rank_at(q);
        if (r != me) peers.push_back(r);
      }
  std::sort(peers.begin(), peers.end());
  peers.erase(std::unique(peers.begin(), peers.end()), peers.end());
  for (int r : peers) {
    Vec3d lo, hi;
    dom.piece(r, lo, hi);
    peer_lo.push_back(lo);
    peer_hi.push_back(hi);
  }
  sent.assign(peers.size(), {});
  received.assign(peers.size(), {});
  transport = halo::make_transport(dom.transport, *dom.comm, ex.backend());
  if (coupling) back = halo::make_transport(dom.transport, *dom.comm, ex.backend());
}

HostParticles DomainExchange::select_owned(const HostParticles& hp) const {
  HostParticles o;
  const int me = dom.rank();
  for (Index i = 0; i < hp.size(); ++i) {
    const Vec3d x = box.wrap(hp.x[i]);
    if (dom.owner(x) != me) continue;
    o.x.push_back(hp.x[i]);
    o.v.push_back(hp.v[i]);
    o.w.push_back(hp.w.empty() ? Vec3d{} : hp.w[i]);
    o.r.push_back(hp.r[i]);
    o.mass.push_back(hp.mass[i]);
    o.id.push_back(hp.id[i]);
    o.type.push_back(i < static_cast<Index>(hp.type.size()) ? hp.type[i] : 0);
  }
  return o;
}

// Whether position x lies within the ghost width of peer k's piece (nearest
// periodic image per axis; Euclidean distance to the box).
bool DomainExchange::near_piece(const Vec3d& x, std::size_t k) const {
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double lo = peer_lo[k][a], hi = peer_hi[k][a];
    auto gap = [lo, hi](double v) { return v < lo ? lo - v : (v > hi ? v - hi : 0.0); };
    double g = gap(x[a]);
    if (box.periodic[a]) g = std::min({g, gap(x[a] + box.len[a]), gap(x[a] - box.len[a])});
    d2 += g * g;
  }
  const double w = width * (1 + 1e-9);  // a spare ghost is harmless; a missing one is not
  return d2 < w * w;
}

void DomainExchange::redistribute(DemSystem::Impl& m) {
  const halo::Comm& comm = *dom.comm;
  ParticleStore& st = m.store;
  NeighbourList& nl = m.lists;
  const Backend be = ex.backend();
  const int me = dom.rank();
  const StoreLayout lay = st.layout;
  const int nw = lay.wall_histories;
  ex.synchronize();

  // 1. The owned particles and their list rows (partner id, history) to the host.
  HostState h;
  st.save(h);
  const Index no = h.n;
  Rows rows;
  rows.off.assign(static_cast<std::size_t>(no) + 1, 0);
  const bool carry = nl.history && nl.has_list();
  if (carry && no > 0) {
    const Index stride = st.n;
    std::vector<int> cnt(static_cast<std::size_t>(no));
    nl.ncount.copy_to_host(cnt.data(), no);
    const Index slots = stride * nl.cap;
    std::vector<int> nb(static_cast<std::size_t>(slots));
    std::vector<Vec3d> hs(static_cast<std::size_t>(slots));
    std::vector<std::int64_t> ids(static_cast<std::size_t>(stride));
    if (slots > 0) {
      nl.nbr.copy_to_host(nb.data(), slots);
      nl.hist.copy_to_host(hs.data(), slots);
    }
    st.gid.copy_to_host(ids.data(), stride);
    for (Index i = 0; i < no; ++i) {
      for (int q = 0; q < cnt[static_cast<std::size_t>(i)]; ++q) {
        const std::size_t s = static_cast<std::size_t>(q * stride + i);
        rows.e.push_back({ids[static_cast<std::size_t>(nb[s])], hs[s]});
      }
      rows.off[static_cast<std::size_t>(i) + 1] = rows.e.size();
    }
  }

  // Record u's fixed part (every per-particle array, id, type, row length).
  auto record = [&h, &rows, &lay](std::size_t u) {
    Migrant mg{};
    const Real4 zero{0, 0, 0, 0};
    const Real4 a[11] = {h.pos[u],  h.vel[u],  h.omg[u],  h.frc[u], h.trq[u], h.frco[u], h.trqo[u], h.vpr[u],
                         lay.rotation ? h.wpr[u] : zero, lay.external_forcing ? h.extf[u] : zero,
                         lay.external_forcing ? h.extt[u] : zero};
    std::copy(a, a + 11, mg.a);
    mg.gid = h.gid[u];
    mg.type = h.type[u];
    mg.nrow = static_cast<int>(rows.off[u + 1] - rows.off[u]);
    return mg;
  };

  // 2. Migration: each particle whose centre left the piece goes to its owner.
  const std::size_t np = peers.size();
  std::vector<std::vector<std::byte>> out(np);
  std::vector<Index> kept;
  for (Index i = 0; i < no; ++i) {
    const int r = dom.owner(xyz(h.pos[static_cast<std::size_t>(i)]));
    if (r == me) {
      kept.push_back(i);
      continue;
    }
    const auto it = std::lower_bound(peers.begin(), peers.end(), r);
    if (it == peers.end() || *it != r)
      throw DivergenceError(fmtx("DEM particle {} moved from rank {} into the piece of rank {}, which is not a "
                                 "neighbour: it moved more than a piece's thickness between two list builds",
                                 h.gid[static_cast<std::size_t>(i)], me, r));
    {
      const auto cm = dom.dec.coords(me), cr = dom.dec.coords(r);
      const int changed = (cm[0] != cr[0]) + (cm[1] != cr[1]) + (cm[2] != cr[2]);
      ++migrations[changed - 1];
      // Through a periodic face: the wrapped centre lies far beyond the piece
      // (a particle moves less than the ghost width between builds).
      Vec3d lo, hi;
      dom.piece(me, lo, hi);
      const Vec3d x = xyz(h.pos[static_cast<std::size_t>(i)]);
      for (int a = 0; a < 3; ++a)
        if (box.periodic[a] && (x[a] < lo[a] - width || x[a] >= hi[a] + width)) {
          ++migrations_periodic;
          break;
        }
    }
    auto& b = out[static_cast<std::size_t>(it - peers.begin())];
    const auto u = static_cast<std::size_t>(i);
    append_pod(b, record(u));
    for (int w = 0; w < nw; ++w) append_pod(b, h.whist[static_cast<std::size_t>(w * no + i)]);
    for (std::size_t e = rows.off[u]; e < rows.off[u + 1]; ++e) append_pod(b, rows.e[e]);
  }
  const std::vector<int> tags_m(np, kTagMigrate);
  const auto in = comm.exchange(peers, tags_m, out, tags_m);

  // 3. The new owned set: kept particles (in storage order), then arrivals
  // (in peer order), in flat arrays: fixed parts, wall histories (nw per
  // particle) and list rows (entries [ro[i], ro[i + 1])).
  std::vector<Migrant> own;
  std::vector<Vec3d> own_wh;
  std::vector<RowEntry> own_row;
  std::vector<std::size_t> ro{0};
  own.reserve(kept.size());
  for (Index i : kept) {
    const auto u = static_cast<std::size_t>(i);
    own.push_back(record(u));
    for (int w = 0; w < nw; ++w) own_wh.push_back(h.whist[static_cast<std::size_t>(w * no + i)]);
    own_row.insert(own_row.end(), rows.e.begin() + static_cast<std::ptrdiff_t>(rows.off[u]),
                   rows.e.begin() + static_cast<std::ptrdiff_t>(rows.off[u + 1]));
    ro.push_back(own_row.size());
  }
  for (const auto& b : in) {
    std::size_t at = 0;
    while (at < b.size()) {
      own.push_back(take_pod<Migrant>(b, at));
      for (int w = 0; w < nw; ++w) own_wh.push_back(take_pod<Vec3d>(b, at));
      for (int e = 0; e < own.back().nrow; ++e) own_row.push_back(take_pod<RowEntry>(b, at));
      ro.push_back(own_row.size());
    }
  }
  const Index n_own = static_cast<Index>(own.size());

  // 4. Ghosts: every owned particle within the ghost width of a neighbour's
  // piece, sent to it once (ascending global id).
  std::vector<std::vector<std::pair<std::int64_t, Index>>> pick(np);
  for (Index i = 0; i < n_own; ++i) {
    const Vec3d x = xyz(own[static_cast<std::size_t>(i)].a[0]);
    for (std::size_t k = 0; k < np; ++k)
      if (near_piece(x, k)) pick[k].emplace_back(own[static_cast<std::size_t>(i)].gid, i);
  }
  for (std::size_t k = 0; k < np; ++k) {
    std::sort(pick[k].begin(), pick[k].end());
    out[k].clear();
    sent[k].clear();
    for (const auto& [g, i] : pick[k]) {
      const Migrant& o = own[static_cast<std::size_t>(i)];
      append_pod(out[k], GhostRecord{o.a[0], o.a[7], o.a[8], o.gid, o.type, 0});
      sent[k].push_back(g);
    }
  }
  const std::vector<int> tags_g(np, kTagGhost);
  const auto gin = comm.exchange(peers, tags_g, out, tags_g);
  std::vector<GhostRecord> ghosts;
  for (std::size_t k = 0; k < np; ++k) {
    received[k].clear();
    std::size_t at = 0;
    while (at < gin[k].size()) {
      const GhostRecord g = take_pod<GhostRecord>(gin[k], at);
      received[k].push_back(g.gid);
      ghosts.push_back(g);
    }
  }

  // 5. The store: owned records first, then the ghosts.
  const Index n = n_own + static_cast<Index>(ghosts.size());
  HostState s;
  s.resize(n, lay);
  s.n_owned = n_own;
  const Real4 zero{0, 0, 0, 0};
  std::fill(s.whist.begin(), s.whist.end(), Vec3d{});
  for (Index i = 0; i < n_own; ++i) {
    const auto u = static_cast<std::size_t>(i);
    const Migrant& o = own[u];
    s.pos[u] = o.a[0]; s.vel[u] = o.a[1]; s.omg[u] = o.a[2]; s.frc[u] = o.a[3]; s.trq[u] = o.a[4];
    s.frco[u] = o.a[5]; s.trqo[u] = o.a[6]; s.vpr[u] = o.a[7];
    if (lay.rotation) s.wpr[u] = o.a[8];
    if (lay.external_forcing) { s.extf[u] = o.a[9]; s.extt[u] = o.a[10]; }
    s.gid[u] = o.gid;
    s.type[u] = o.type;
    for (int w = 0; w < nw; ++w) s.whist[static_cast<std::size_t>(w * n + i)] = own_wh[u * nw + w];
  }
  for (std::size_t k = 0; k < ghosts.size(); ++k) {
    const auto u = static_cast<std::size_t>(n_own) + k;
    const GhostRecord& g = ghosts[k];
    s.pos[u] = g.pos; s.vel[u] = g.vpr; s.omg[u] = lay.rotation ? g.wpr : zero;
    s.frc[u] = s.trq[u] = s.frco[u] = s.trqo[u] = zero;
    s.vpr[u] = g.vpr;
    if (lay.rotation) s.wpr[u] = g.wpr;
    if (lay.external_forcing) s.extf[u] = s.extt[u] = zero;
    s.gid[u] = g.gid;
    s.type[u] = g.type;
  }
  st.load(be, s);
  nl.resize(be, n);

  // 6. The previous list in the new order: each owned particle's row, its
  // partners found by global id among the records now held (a partner not
  // held is out of range: the build will not list it).
  if (carry) {
    std::unordered_map<std::int64_t, int> at;
    at.reserve(static_cast<std::size_t>(n) * 2);
    for (Index i = 0; i < n; ++i) at.emplace(s.gid[static_cast<std::size_t>(i)], static_cast<int>(i));
    int cap_prev = 1;
    for (std::size_t u = 0; u + 1 < ro.size(); ++u) cap_prev = std::max(cap_prev, static_cast<int>(ro[u + 1] - ro[u]));
    std::vector<int> cnt(static_cast<std::size_t>(n), 0), nb(static_cast<std::size_t>(n) * cap_prev, 0);
    std::vector<Vec3d> hs(static_cast<std::size_t>(n) * cap_prev);
    for (Index i = 0; i < n_own; ++i) {
      int c = 0;
      for (std::size_t q = ro[static_cast<std::size_t>(i)]; q < ro[static_cast<std::size_t>(i) + 1]; ++q) {
        const RowEntry& e = own_row[q];
        const auto f = at.find(e.gid);
        if (f == at.end()) continue;
        const auto s2 = static_cast<std::size_t>(c * n + i);
        nb[s2] = f->second;
        hs[s2] = e.h;
        ++c;
      }
      cnt[static_cast<std::size_t>(i)] = c;
    }
    nl.load_previous(be, cnt, nb, hs, cap_prev);
  }
}

void DomainExchange::bind_refresh(DemSystem::Impl& m) {
  ex.synchronize();  // the build's reorder and row sort are done
  const ParticleStore& st = m.store;
  const Backend be = ex.backend();
  per = st.layout.rotation ? 3 : 2;
  const Index n = st.n;
  std::vector<std::int64_t> ids(static_cast<std::size_t>(n));
  if (n > 0) st.gid.copy_to_host(ids.data(), n);
  std::unordered_map<std::int64_t, int> at;
  at.reserve(static_cast<std::size_t>(n) * 2);
  for (Index i = 0; i < n; ++i) at.emplace(ids[static_cast<std::size_t>(i)], static_cast<int>(i));
  std::vector<int> sidx, ridx;
  std::vector<std::size_t> soff{0}, roff{0};
  for (std::size_t k = 0; k < peers.size(); ++k) {
    for (std::int64_t g : sent[k]) sidx.push_back(at.at(g));
    for (std::int64_t g : received[k]) ridx.push_back(at.at(g));
    soff.push_back(sidx.size());
    roff.push_back(ridx.size());
  }
  nsend = static_cast<Index>(sidx.size());
  nrecv = static_cast<Index>(ridx.size());
  auto fit = [be](auto& b, Index want) {
    if (b.size() < want) b.reserve_discard(be, want + want / 4 + 16);
  };
  fit(send_idx, nsend);
  fit(recv_idx, nrecv);
  fit(send_buf, nsend * per);
  fit(recv_buf, nrecv * per);
  if (nsend > 0) send_idx.copy_from_host(sidx.data(), nsend);
  if (nrecv > 0) recv_idx.copy_from_host(ridx.data(), nrecv);
  std::vector<halo::Message> msgs;
  const std::size_t rec = sizeof(Real4) * static_cast<std::size_t>(per);
  for (std::size_t k = 0; k < peers.size(); ++k) {
    const std::size_t ns = soff[k + 1] - soff[k], nr = roff[k + 1] - roff[k];
    if (ns == 0 && nr == 0) continue;  // the peer holds no ghost of ours nor we of its
    halo::Message msg;
    msg.peer = peers[k];
    msg.tag = kTagRefresh;
    msg.send = send_buf.data() + soff[k] * per;
    msg.send_bytes = ns * rec;
    msg.recv_tag = kTagRefresh;
    msg.recv = recv_buf.data() + roff[k] * per;
    msg.recv_bytes = nr * rec;
    msgs.push_back(msg);
  }
  messages = !msgs.empty();
  transport->bind(std::move(msgs));
  this->soff = soff;
  this->roff = roff;
  if (!back) return;
  // The coupling return: the refresh messages reversed (ghost shares to their owners).
  fit(back_send, nrecv * 2);
  fit(back_recv, nsend * 2);
  std::vector<halo::Message> bm;
  for (std::size_t k = 0; k < peers.size(); ++k) {
    const std::size_t ns = soff[k + 1] - soff[k], nr = roff[k + 1] - roff[k];
    if (ns == 0 && nr == 0) continue;
    halo::Message msg;
    msg.peer = peers[k];
    msg.tag = kTagCoupling;
    msg.send = back_send.data() + roff[k] * 2;
    msg.send_bytes = nr * 2 * sizeof(Real4);
    msg.recv_tag = kTagCoupling;
    msg.recv = back_recv.data() + soff[k] * 2;
    msg.recv_bytes = ns * 2 * sizeof(Real4);
    bm.push_back(msg);
  }
  back->bind(std::move(bm));
}

void DomainExchange::sync_state(DemSystem::Impl& m) {
  if (!messages) return;
  ParticleStore& st = m.store;
  launch(ex, nsend, GhostPack{send_idx.data(), st.pos.data(), st.vel.data(), st.omg.data(), send_buf.data(), per});
  transport->start(ex);
  transport->finish(ex);
  launch(ex, nrecv, GhostUnpack{recv_idx.data(), st.pos.data(), st.vel.data(), st.omg.data(), recv_buf.data(), per});
}

void DomainExchange::return_coupling(DemSystem::Impl& m) {
  if (!back) throw Error("DemSystem: the coupling return needs a system created with external forcing");
  if (!messages) return;
  ParticleStore& st = m.store;
  launch(ex, nrecv, CouplingPack{recv_idx.data(), st.extf.data(), st.extt.data(), back_send.data()});
  back->start(ex);
  back->finish(ex);
  // Peer by peer, ascending: a particle shared with several peers sums in that order.
  for (std::size_t k = 0; k + 1 < soff.size(); ++k) {
    const auto n = static_cast<Index>(soff[k + 1] - soff[k]);
    if (n == 0) continue;
    launch(ex, n,
           CouplingAdd{send_idx.data() + soff[k], st.extf.data(), st.extt.data(), back_recv.data() + 2 * soff[k]});
  }
}

void DomainExchange::refresh(DemSystem::Impl& m) {
  if (!messages) return;
  ParticleStore& st = m.store;
  launch(ex, nsend, GhostPack{send_idx.data(), st.pos.data(), st.vpr.data(), st.wpr.data(), send_buf.data(), per});
  transport->start(ex);
  transport->finish(ex);
  launch(ex, nrecv, GhostUnpack{recv_idx.data(), st.pos.data(), st.vpr.data(), st.wpr.data(), recv_buf.data(), per});
}

}  // namespace lbdem::dem
