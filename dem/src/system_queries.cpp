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
  s.neighbour_capacity = m.cap;
  s.status_reads = m.status_reads;
  s.status_waits = m.status_waits;
  if (m.n > 0) {
    std::vector<int> c = m.ncount.to_vector();
    double sum = 0;
    for (Index i = 0; i < m.n; ++i) sum += c[i];
    s.mean_neighbours = sum / static_cast<double>(m.n);
  }
  return s;
}

ParticleView DemSystem::view() {
  Impl& m = *impl_;
  ParticleView v;
  v.pos_r = m.pos.data();
  v.vel_im = m.vel.data();
  v.omega_ii = m.omg.data();
  v.ext_force = m.extf.data();
  v.ext_torque = m.extt.data();
  v.force = m.frc.data();
  v.torque = m.trq.data();
  v.n = m.n;
  return v;
}

HostParticles DemSystem::download() const {
  const Impl& m = *impl_;
  m.ex.synchronize();
  check_arrived_reports(*impl_);
  HostParticles h;
  const Index n = m.n;
  std::vector<Real4> pos = m.pos.to_vector(), vel = m.vel.to_vector(), omg = m.omg.to_vector(),
                     frc = m.frc.to_vector(), trq = m.trq.to_vector();
  h.id = m.gid.to_vector();
  h.type = m.type.to_vector();
  h.id.resize(n);
  h.type.resize(n);
  for (Index i = 0; i < n; ++i) {
    h.x.push_back(xyz(pos[i]));
    h.r.push_back(pos[i].w);
    h.v.push_back(xyz(vel[i]));
    h.mass.push_back(1.0 / vel[i].w);
    h.w.push_back(xyz(omg[i]));
    h.f.push_back(xyz(frc[i]));
    h.t.push_back(m.p.friction ? xyz(trq[i]) : Vec3d{});
  }
  return h;
}

std::vector<std::pair<std::int64_t, std::int64_t>> DemSystem::neighbour_pairs() const {
  const Impl& m = *impl_;
  std::vector<std::pair<std::int64_t, std::int64_t>> out;
  if (m.n == 0) return out;
  std::vector<int> nbr = m.nbr.to_vector(), cnt = m.ncount.to_vector();
  std::vector<std::int64_t> gid = m.gid.to_vector();
  for (Index i = 0; i < m.n; ++i)
    for (int q = 0; q < cnt[i]; ++q) {
      const int j = nbr[q * m.n + i];
      if (j > i) out.emplace_back(std::min(gid[i], gid[j]), std::max(gid[i], gid[j]));
    }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::pair<std::int64_t, std::int64_t>> DemSystem::contact_pairs() const {
  const Impl& m = *impl_;
  std::vector<std::pair<std::int64_t, std::int64_t>> out;
  if (m.n == 0) return out;
  std::vector<int> nbr = m.nbr.to_vector(), cnt = m.ncount.to_vector();
  std::vector<std::int64_t> gid = m.gid.to_vector();
  std::vector<Real4> pos = m.pos.to_vector();
  for (Index i = 0; i < m.n; ++i)
    for (int q = 0; q < cnt[i]; ++q) {
      const int j = nbr[q * m.n + i];
      if (j <= i) continue;
      const Vec3d d = m.box.min_image(xyz(pos[j]) - xyz(pos[i]));
      const double rs = pos[i].w + pos[j].w;
      if (dot(d, d) < rs * rs) out.emplace_back(std::min(gid[i], gid[j]), std::max(gid[i], gid[j]));
    }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace lbdem::dem
