// Host-side queries of DemSystem (downloads; tests, output, statistics).
// Plain C++: no kernels here.
#include <algorithm>
#include <cstring>
#include <numeric>

#include "domain_exchange.hpp"
#include "substep_graphs.hpp"
#include "system_impl.hpp"

namespace lbdem::dem {

DemStats DemSystem::stats() const {
  const Impl& m = *impl_;
  DemStats s;
  s.steps = m.steps;
  s.rebuilds = m.rebuilds;
  s.neighbour_capacity = m.lists.cap;
  s.status_reads = m.sched.status_reads;
  s.status_waits = m.sched.status_waits;
  s.fused_steps = m.fused_steps;
  if (m.graphs) {
    s.graph_launches = m.graphs->graph_launches;
    s.graph_steps = m.graphs->graph_steps;
    s.graph_captures = m.graphs->captures;
  }
  if (m.domain) {
    for (int k = 0; k < 3; ++k) s.migrations[k] = m.domain->migrations[k];
    s.migrations_periodic = m.domain->migrations_periodic;
    s.ghosts = m.store.n - m.store.n_owned;
  }
  const Index n = m.lists.rows;  // the owned particles' rows
  if (n > 0) {
    std::vector<int> c(static_cast<std::size_t>(n));  // the rows only: the buffer may hold more, never written
    m.ex.synchronize();  // the copy is on the legacy queue
    m.lists.ncount.copy_to_host(c.data(), n);
    double sum = 0;
    for (Index i = 0; i < n; ++i) sum += c[i];
    s.mean_neighbours = sum / static_cast<double>(n);
  }
  return s;
}

ParticleView DemSystem::view() { return impl_->store.view(); }

const std::int64_t* DemSystem::ids() const { return impl_->store.gid.data(); }

ParticleView DemSystem::held_view() {
  ParticleView v = impl_->store.view();
  v.n = impl_->store.size();
  return v;
}

HostParticles DemSystem::download() const {
  impl_->ex.synchronize();
  impl_->sched.check_arrived();
  return impl_->store.download();
}

namespace {

// One particle of a gather: what HostParticles holds.
struct GatherRecord {
  Vec3d x, v, w, f, t;
  double r, mass;
  std::int64_t id;
  int type, pad;
};

HostParticles sorted_by_id(const std::vector<GatherRecord>& recs) {
  std::vector<std::size_t> order(recs.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&recs](std::size_t a, std::size_t b) { return recs[a].id < recs[b].id; });
  HostParticles h;
  for (std::size_t k : order) {
    const GatherRecord& g = recs[k];
    h.x.push_back(g.x); h.v.push_back(g.v); h.w.push_back(g.w); h.f.push_back(g.f); h.t.push_back(g.t);
    h.r.push_back(g.r); h.mass.push_back(g.mass); h.id.push_back(g.id); h.type.push_back(g.type);
  }
  return h;
}

}  // namespace

HostParticles DemSystem::gather(int root) const {
  const HostParticles mine = download();
  std::vector<GatherRecord> recs(static_cast<std::size_t>(mine.size()));
  for (Index i = 0; i < mine.size(); ++i) {
    const auto u = static_cast<std::size_t>(i);
    recs[u] = GatherRecord{mine.x[u], mine.v[u], mine.w[u], mine.f[u], mine.t[u], mine.r[u], mine.mass[u],
                           mine.id[u], mine.type[u], 0};
  }
  const halo::Comm* comm = impl_->comm;
  if (!comm || comm->size() <= 1) return sorted_by_id(recs);
  const auto* bytes = reinterpret_cast<const std::byte*>(recs.data());
  const auto parts = comm->gather(std::span<const std::byte>(bytes, recs.size() * sizeof(GatherRecord)), root);
  if (comm->rank() != root) return HostParticles{};
  std::vector<GatherRecord> all;
  for (const auto& p : parts) {
    const std::size_t k = p.size() / sizeof(GatherRecord);
    const std::size_t at = all.size();
    all.resize(at + k);
    if (k > 0) std::memcpy(static_cast<void*>(all.data() + at), p.data(), k * sizeof(GatherRecord));
  }
  return sorted_by_id(all);
}

std::vector<std::pair<std::int64_t, std::int64_t>> DemSystem::neighbour_pairs() const {
  const Impl& m = *impl_;
  std::vector<std::pair<std::int64_t, std::int64_t>> out;
  const Index n = m.store.size();
  if (n == 0) return out;
  m.ex.synchronize();  // the copies are on the legacy queue
  std::vector<int> nbr = m.lists.nbr.to_vector(), cnt = m.lists.ncount.to_vector();
  std::vector<std::int64_t> gid = m.store.gid.to_vector();
  for (Index i = 0; i < m.lists.rows; ++i)
    for (int q = 0; q < cnt[i]; ++q) {
      const int j = nbr[q * n + i];
      if (j > i) out.emplace_back(std::min(gid[i], gid[j]), std::max(gid[i], gid[j]));
    }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::pair<std::int64_t, std::int64_t>> DemSystem::contact_pairs() const {
  const Impl& m = *impl_;
  std::vector<std::pair<std::int64_t, std::int64_t>> out;
  const Index n = m.store.size();
  if (n == 0) return out;
  m.ex.synchronize();  // the copies are on the legacy queue
  std::vector<int> nbr = m.lists.nbr.to_vector(), cnt = m.lists.ncount.to_vector();
  std::vector<std::int64_t> gid = m.store.gid.to_vector();
  std::vector<Real4> pos = m.store.pos.to_vector();
  for (Index i = 0; i < m.lists.rows; ++i)
    for (int q = 0; q < cnt[i]; ++q) {
      const int j = nbr[q * n + i];
      if (j <= i) continue;
      const Vec3d d = m.box.min_image(xyz(pos[j]) - xyz(pos[i]));
      const double rs = pos[i].w + pos[j].w;
      if (dot(d, d) < rs * rs) out.emplace_back(std::min(gid[i], gid[j]), std::max(gid[i], gid[j]));
    }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace lbdem::dem
