// Host-side queries of DemSystem (downloads; tests, output, statistics).
// Plain C++: no kernels here.
#include <algorithm>

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
  const Index n = m.store.size();
  if (n > 0) {
    std::vector<int> c = m.lists.ncount.to_vector();
    double sum = 0;
    for (Index i = 0; i < n; ++i) sum += c[i];
    s.mean_neighbours = sum / static_cast<double>(n);
  }
  return s;
}

ParticleView DemSystem::view() { return impl_->store.view(); }

HostParticles DemSystem::download() const {
  impl_->ex.synchronize();
  impl_->sched.check_arrived();
  return impl_->store.download();
}

std::vector<std::pair<std::int64_t, std::int64_t>> DemSystem::neighbour_pairs() const {
  const Impl& m = *impl_;
  std::vector<std::pair<std::int64_t, std::int64_t>> out;
  const Index n = m.store.size();
  if (n == 0) return out;
  std::vector<int> nbr = m.lists.nbr.to_vector(), cnt = m.lists.ncount.to_vector();
  std::vector<std::int64_t> gid = m.store.gid.to_vector();
  for (Index i = 0; i < n; ++i)
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
  std::vector<int> nbr = m.lists.nbr.to_vector(), cnt = m.lists.ncount.to_vector();
  std::vector<std::int64_t> gid = m.store.gid.to_vector();
  std::vector<Real4> pos = m.store.pos.to_vector();
  for (Index i = 0; i < n; ++i)
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
